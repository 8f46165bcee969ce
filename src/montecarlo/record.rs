//! One row of simulation output: a configuration, the EM gain in use and one model's result.

use super::config::SimConfig;
use super::engine::SimResult;
use serde::ser::{Serialize, SerializeStruct, Serializer};

/// One row of simulation output: a configuration and one model's result in it.
///
/// Serialised (CSV, JSON) as the columns `model`, `centroider`, the configuration
/// (`subap_px`, `spot`, `sampling`, `signal_photons`, `qe`, `em_gain` (empty for models without
/// an EM register), `iters`, `seed`), the result (`r_px`, `r_se_px`, the Cramer-Rao floor
/// `r_crlb_px`, `crlb_efficiency` = R_crlb / R and `below_crlb` (R below the floor by more than
/// 3 SE: a biased centroid), `b_opt_e` ... `zero_frames`, then `centroider_param` and
/// `centroider_param_opt`, empty for `cog`), the error's static and random parts at the optimum
/// (`static_x_px`, `static_y_px`, `static_px`, `static_se_px`, `static_resolved`,
/// `random_rms_px`, `random_rms_se_px`: see [`super::ErrorParts`]), `model_range` (`ok` or
/// `outside_range` for a model with a useful range, e.g. `emccd-pp`; empty otherwise), then
/// `bg_levels_e`,
/// `param_by_level` and `r_by_level_px` (arrays: JSON only).
#[derive(Debug, Clone)]
pub struct SimRecord {
    /// The configuration run.
    pub config: SimConfig,
    /// EMCCD mean gain of the model (e-/e-); None for a model without an EM register.
    pub em_gain: Option<f64>,
    /// The model's result.
    pub result: SimResult,
    /// The Cramer-Rao floor of R for the configuration and the model's noise (px; None when
    /// not computed or infinite), see [`crate::crlb`].
    pub r_crlb_px: Option<f64>,
    /// Whether the model's R describes a usable camera at this light level (see
    /// [`crate::detector::Readout::in_range`]); None for a model valid at every level.
    pub in_range: Option<bool>,
}

impl SimRecord {
    /// Combine a configuration, the model's EM gain (None without a register) and its result.
    pub fn new(config: &SimConfig, em_gain: Option<f64>, result: SimResult) -> Self {
        SimRecord {
            config: config.clone(),
            em_gain,
            result,
            r_crlb_px: None,
            in_range: None,
        }
    }

    /// The record with its Cramer-Rao floor `r_crlb_px` (px).
    pub fn with_floor(mut self, r_crlb_px: Option<f64>) -> Self {
        self.r_crlb_px = r_crlb_px;
        self
    }

    /// The record with the model's range verdict at its light level (None: no range).
    pub fn with_range(mut self, in_range: Option<bool>) -> Self {
        self.in_range = in_range;
        self
    }

    /// The range's status word: `ok`, `outside_range`, or None for a model without a range.
    pub fn model_range(&self) -> Option<&'static str> {
        self.in_range
            .map(|ok| if ok { "ok" } else { "outside_range" })
    }

    /// R_crlb / R: how close the centroid comes to the floor (1 = efficient).
    pub fn crlb_efficiency(&self) -> Option<f64> {
        self.r_crlb_px.map(|f| f / self.result.r_px)
    }

    /// R below the floor by more than 3 standard errors: the centroid is biased.
    pub fn below_crlb(&self) -> Option<bool> {
        self.r_crlb_px
            .map(|f| crate::crlb::below_floor(self.result.r_px, self.result.r_se_px, f))
    }
}

/// Write the configuration columns of a record: `subap_px`, `spot`, `sampling`,
/// `signal_photons`, `qe`, then `em_gain` when asked for (`Some(None)`: an empty cell), then
/// `iters` and `seed`.
pub(crate) fn config_columns<S: SerializeStruct>(
    s: &mut S,
    cfg: &SimConfig,
    em_gain: Option<Option<f64>>,
) -> Result<(), S::Error> {
    s.serialize_field("subap_px", &cfg.subap_px)?;
    s.serialize_field("spot", &cfg.spot.label())?;
    s.serialize_field("sampling", cfg.sampling.label())?;
    s.serialize_field("signal_photons", &cfg.signal_photons)?;
    s.serialize_field("qe", &cfg.qe)?;
    if let Some(g) = em_gain {
        s.serialize_field("em_gain", &g)?;
    }
    s.serialize_field("iters", &cfg.iters)?;
    s.serialize_field("seed", &cfg.seed)
}

impl Serialize for SimRecord {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let r = &self.result;
        let mut s = serializer.serialize_struct("SimRecord", 34)?;
        s.serialize_field("model", &r.model)?;
        s.serialize_field("centroider", &r.centroider)?;
        config_columns(&mut s, &self.config, Some(self.em_gain))?;
        s.serialize_field("r_px", &r.r_px)?;
        s.serialize_field("r_se_px", &r.r_se_px)?;
        s.serialize_field("r_crlb_px", &self.r_crlb_px)?;
        s.serialize_field("crlb_efficiency", &self.crlb_efficiency())?;
        s.serialize_field("below_crlb", &self.below_crlb())?;
        s.serialize_field("b_opt_e", &r.b_opt_e)?;
        s.serialize_field("b_at_grid_edge", &r.b_at_grid_edge)?;
        s.serialize_field("no_eligible_level", &r.no_eligible_level)?;
        s.serialize_field("r0_px", &r.r0_px)?;
        s.serialize_field("r0_se_px", &r.r0_se_px)?;
        s.serialize_field("zero_frames", &r.zero_frames)?;
        s.serialize_field("centroider_param", &r.param_name)?;
        s.serialize_field("centroider_param_opt", &r.param_opt)?;
        let p = &r.parts;
        s.serialize_field("static_x_px", &p.static_x_px)?;
        s.serialize_field("static_y_px", &p.static_y_px)?;
        s.serialize_field("static_px", &p.static_px)?;
        s.serialize_field("static_se_px", &p.static_se_px)?;
        s.serialize_field("static_resolved", &p.static_resolved)?;
        s.serialize_field("random_rms_px", &p.random_rms_px)?;
        s.serialize_field("random_rms_se_px", &p.random_rms_se_px)?;
        s.serialize_field("model_range", &self.model_range())?;
        let levels: Vec<f64> = r.levels.iter().map(|l| l.b_e).collect();
        s.serialize_field("bg_levels_e", &levels)?;
        let params: Vec<Option<f64>> = r.levels.iter().map(|l| l.param).collect();
        s.serialize_field("param_by_level", &params)?;
        let r_by_level: Vec<f64> = r.levels.iter().map(|l| l.r_px).collect();
        s.serialize_field("r_by_level_px", &r_by_level)?;
        s.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::montecarlo::LevelStats;
    use crate::output::{render, TableFormat};

    #[test]
    fn columns_are_the_configuration_then_the_result() {
        let mut config = SimConfig::paper(8);
        config.spot = crate::spot::Spot::Gauss {
            sigma_x_px: 1.0,
            sigma_y_px: 2.5,
        };
        let level = |b_e, r_px| LevelStats {
            param: None,
            b_e,
            r_px,
            r_se_px: 0.01,
            empty_frames: 0,
        };
        let result = SimResult {
            model: "scmos-mean".into(),
            centroider: "cog".into(),
            param_name: None,
            param_opt: None,
            best: 1,
            r_px: 0.25,
            r_se_px: 0.5,
            b_opt_e: 1.5,
            b_at_grid_edge: false,
            no_eligible_level: true,
            r0_px: 0.75,
            r0_se_px: 0.125,
            zero_frames: 3,
            parts: crate::montecarlo::ErrorParts {
                static_x_px: 0.125,
                static_y_px: -0.25,
                static_px: 0.5,
                static_se_px: 0.0625,
                static_resolved: true,
                random_rms_px: 1.5,
                random_rms_se_px: 0.25,
                ..Default::default()
            },
            levels: vec![level(0.0, 0.75), level(1.5, 0.25)],
        };
        let rec = SimRecord::new(&config, None, result).with_floor(Some(0.125));
        assert_eq!(
            render(std::slice::from_ref(&rec), TableFormat::Csv).unwrap(),
            "model,centroider,subap_px,spot,sampling,signal_photons,qe,em_gain,iters,seed,r_px,\
             r_se_px,r_crlb_px,crlb_efficiency,below_crlb,b_opt_e,b_at_grid_edge,\
             no_eligible_level,r0_px,r0_se_px,zero_frames,centroider_param,centroider_param_opt,\
             static_x_px,static_y_px,static_px,static_se_px,static_resolved,random_rms_px,\
             random_rms_se_px,model_range\n\
             scmos-mean,cog,8,\"gauss:1,2.5\",integrated,50,1,,10000,1,0.25,0.5,0.125,0.5,false,\
             1.5,false,true,0.75,0.125,3,,,0.125,-0.25,0.5,0.0625,true,1.5,0.25,\n"
        );
        let json = serde_json::to_value(&rec).unwrap();
        assert_eq!(json["bg_levels_e"], serde_json::json!([0.0, 1.5]));
        assert_eq!(json["r_by_level_px"], serde_json::json!([0.75, 0.25]));
        assert_eq!(json["param_by_level"], serde_json::json!([null, null]));
        assert_eq!(json.as_object().unwrap().len(), 34);
        assert!(json["model_range"].is_null());
        let outside = rec.clone().with_range(Some(false));
        assert_eq!(outside.model_range(), Some("outside_range"));
        // R more than 3 SE under the floor: a biased centroid, flagged.
        let mut low = rec.clone().with_floor(Some(2.0));
        assert_eq!(low.below_crlb(), Some(true));
        low.r_crlb_px = None;
        assert_eq!(low.below_crlb(), None);
    }
}
