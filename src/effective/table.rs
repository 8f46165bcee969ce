//! The effective read noise over a grid of configurations: one record per detector model and
//! configuration, written as `effective_noise.csv` and `effective_noise.json`.

use super::precision::Precision;
use super::solve::{effective_sigma_with, planned_work_with, Effective};
use crate::centroid::CentroiderSpec;
use crate::detector::{ModelParams, ModelSpec};
use crate::montecarlo::{config_columns, SimConfig};
use crate::progress::Observer;
use crate::Result;
use serde::ser::{Serialize, SerializeStruct, Serializer};
use std::path::{Path, PathBuf};

/// Files [`write_tables`] writes: the table as CSV and as JSON.
pub const TABLE_NAMES: [&str; 2] = ["effective_noise.csv", "effective_noise.json"];

/// One configuration's effective read noise.
///
/// Serialised (CSV, JSON) as the columns `model`, `centroider`; the configuration (`subap_px`, `spot`,
/// `sampling`, `signal_photons`, `qe`, then `iters`: the iterations the value rests on, from
/// the starting count up to the cap, and `seed`); `sigma_eff_e` and `sigma_eff_se_e` (e-, the
/// uniform camera with the same R under the same centroider; empty/null for `unreachable` and
/// `no_eligible_level`); `target_se_e` (e-, the standard error the value had to reach: the
/// larger of the absolute target and the relative one times the value; empty/null without a
/// target or a value); `sigma_cog_equiv_e` and `sigma_cog_equiv_se_e` (e-, the uniform camera
/// with the same R under plain `cog`: sigma_eff itself for `cog`; empty/null without a value);
/// `r_px`, `r_se_px` (the detector's R and its SE), `r_crlb_px` and `crlb_efficiency` (the
/// Cramer-Rao floor of R for the detector, px, and r_crlb_px / r_px; empty/null when not
/// computed: see [`crate::crlb`]), `b_opt_e` (its best background level), `centroider_param`
/// and `centroider_param_opt`
/// (the centroider's parameter at the optimum; empty for `cog`); and `status` (`ok`, `imprecise`, `lower_bound`,
/// `unreachable`, `no_eligible_level`: see [`crate::effective::Status::meaning`]); then the
/// error's parts ([`crate::effective::EffectiveParts`]): `sigma_random_e`,
/// `sigma_random_se_e` (e-, the constant sigma of the detector's random part), and
/// `sigma_random_extrapolated`, `random_rms_px`, the static offset `static_x_px`,
/// `static_y_px`, `static_px`, `static_se_px` and `static_resolved`.
#[derive(Debug, Clone)]
pub struct EffectiveRecord {
    /// The detector model (its name, or a caller's label).
    pub model: String,
    /// The detector's centroider (`--centroider` text; the references use the same one).
    pub centroider: String,
    /// The configuration solved.
    pub config: SimConfig,
    /// The solution.
    pub effective: Effective,
    /// The Cramer-Rao floor of the detector's R (px; None when not computed or infinite).
    pub r_crlb_px: Option<f64>,
}

impl EffectiveRecord {
    /// The record of `model` (a label) read through `cog` in configuration `cfg`.
    pub fn new(model: String, cfg: &SimConfig, e: &Effective) -> Self {
        EffectiveRecord {
            model,
            centroider: CentroiderSpec::default().label(),
            config: cfg.clone(),
            effective: e.clone(),
            r_crlb_px: None,
        }
    }
}

impl Serialize for EffectiveRecord {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let e = &self.effective;
        let mut s = serializer.serialize_struct("EffectiveRecord", 31)?;
        s.serialize_field("model", &self.model)?;
        s.serialize_field("centroider", &self.centroider)?;
        let used = SimConfig {
            iters: e.iters,
            ..self.config.clone()
        };
        config_columns(&mut s, &used, None)?;
        // Non-finite values (no value, or an infinite SE) are written as empty/null, never NaN.
        let finite = |v: f64| v.is_finite().then_some(v);
        s.serialize_field("sigma_eff_e", &finite(e.sigma_eff_e))?;
        s.serialize_field("sigma_eff_se_e", &finite(e.sigma_eff_se_e))?;
        s.serialize_field("target_se_e", &e.target_se_e)?;
        s.serialize_field("sigma_cog_equiv_e", &finite(e.sigma_cog_equiv_e))?;
        s.serialize_field("sigma_cog_equiv_se_e", &finite(e.sigma_cog_equiv_se_e))?;
        s.serialize_field("r_px", &e.r_px)?;
        s.serialize_field("r_se_px", &e.r_se_px)?;
        s.serialize_field("r_crlb_px", &self.r_crlb_px)?;
        let efficiency = self.r_crlb_px.map(|f| f / e.r_px).and_then(finite);
        s.serialize_field("crlb_efficiency", &efficiency)?;
        s.serialize_field("b_opt_e", &e.b_opt_e)?;
        s.serialize_field("centroider_param", &e.param_name)?;
        s.serialize_field("centroider_param_opt", &e.param_opt)?;
        s.serialize_field("status", &e.status)?;
        let p = &e.parts;
        s.serialize_field("sigma_random_e", &finite(p.sigma_random_e))?;
        s.serialize_field("sigma_random_se_e", &finite(p.sigma_random_se_e))?;
        s.serialize_field("sigma_random_extrapolated", &p.sigma_random_extrapolated)?;
        s.serialize_field("random_rms_px", &finite(p.random_rms_px))?;
        s.serialize_field("static_x_px", &finite(p.static_x_px))?;
        s.serialize_field("static_y_px", &finite(p.static_y_px))?;
        s.serialize_field("static_px", &finite(p.static_px))?;
        s.serialize_field("static_se_px", &finite(p.static_se_px))?;
        s.serialize_field("static_resolved", &p.static_resolved)?;
        s.end()
    }
}

/// Solve every configuration (its `iters` the starting count) for every detector model of
/// `specs` (built with `params` for its sub-aperture) to `precision`: records in model order,
/// then configuration order. `observer` sees one stage, `effective`, counting pixel-frames
/// (iterations x models x pixels) of every run, pilot and added iterations included: its total
/// grows when a solve adds work, and ends exactly advanced.
pub fn effective_table(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    params: &ModelParams,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Vec<EffectiveRecord>> {
    let cog = [CentroiderSpec::default()];
    effective_table_with(configs, specs, &cog, params, precision, observer)
}

/// [`effective_table`] with every detector read through each of `centroiders` (the
/// references through the same centroider, and through `cog` for the cog-equivalent): records in model, then centroider, then configuration
/// order.
pub fn effective_table_with(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    centroiders: &[CentroiderSpec],
    params: &ModelParams,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Vec<EffectiveRecord>> {
    for cfg in configs {
        cfg.validate()?;
        precision.validate(cfg.iters)?;
    }
    for c in centroiders {
        c.validate()?;
    }
    let per_model: u64 = centroiders
        .iter()
        .flat_map(|c| configs.iter().map(move |cfg| planned_work_with(cfg, c)))
        .sum();
    let work = per_model * specs.len() as u64;
    observer.begin("effective", work, work);
    observer.unit("pixel-frames");
    let records = solve_all(configs, specs, centroiders, params, precision, observer);
    observer.end();
    records
}

fn solve_all(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    centroiders: &[CentroiderSpec],
    params: &ModelParams,
    precision: &Precision,
    observer: &dyn Observer,
) -> Result<Vec<EffectiveRecord>> {
    let mut out = Vec::with_capacity(specs.len() * centroiders.len() * configs.len());
    for spec in specs {
        for &c in centroiders {
            for cfg in configs {
                let model = spec.build(params, cfg.subap_px)?;
                let e = effective_sigma_with(cfg, model.as_ref(), c, precision, observer)?;
                let mut record = EffectiveRecord::new(model.name(), cfg, &e);
                record.centroider = c.label();
                record.r_crlb_px = crate::crlb::r_crlb_of_readout(
                    cfg,
                    model.as_ref(),
                    crate::crlb::Information::Exact,
                );
                out.push(record);
            }
        }
    }
    Ok(out)
}

/// Write the table into `dir` as [`TABLE_NAMES`] (CSV and JSON, each atomically); returns
/// their paths.
pub fn write_tables(records: &[EffectiveRecord], dir: &Path) -> Result<Vec<PathBuf>> {
    crate::output::write_csv_json(records, dir, TABLE_NAMES)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effective::effective_sigma;
    use crate::effective::Status;
    use crate::progress::{Recorder, Silent};
    use std::sync::atomic::Ordering::Relaxed;

    #[test]
    fn table_solves_each_model_and_configuration_like_the_solver() {
        // Records in model-then-configuration order, each equal bit for bit to a direct solve;
        // the stage counts pixel-frames and ends with exactly its total advanced, though the
        // target makes some solves add iterations (the total grows by them).
        let mut configs = Vec::new();
        for (n, s) in [(4usize, 50.0), (6, 200.0)] {
            let mut c = SimConfig::paper(n);
            c.signal_photons = s;
            c.iters = 600;
            configs.push(c);
        }
        let specs = [
            ModelSpec::parse("scmos-constant:0.8").unwrap(),
            ModelSpec::ScmosRandom,
        ];
        let params = ModelParams::default();
        let precision = Precision {
            target_se_e: 0.02,
            target_rel: 0.0,
            max_iters: 6000,
        };
        let recorder = Recorder::default();
        let table = effective_table(&configs, &specs, &params, &precision, &recorder).unwrap();
        assert_eq!(table.len(), 4);
        for (k, rec) in table.iter().enumerate() {
            let (spec, cfg) = (&specs[k / 2], &configs[k % 2]);
            let model = spec.build(&params, cfg.subap_px).unwrap();
            let direct = effective_sigma(cfg, model.as_ref(), &precision, &Silent).unwrap();
            assert_eq!(rec.model, model.name());
            assert_eq!(rec.config.subap_px, cfg.subap_px);
            assert_eq!(
                rec.effective.sigma_eff_e.to_bits(),
                direct.sigma_eff_e.to_bits()
            );
            assert_eq!(rec.effective.iters, direct.iters);
        }
        assert!(table.iter().any(|r| r.effective.iters > 600));
        // Pilot: 500 frames x 9 models; first final run: 600 frames x 5 models.
        let planned = 2 * (500 * 9 + 600 * 5) * (16 + 36);
        assert_eq!(
            *recorder.stages.lock().unwrap(),
            [("effective".to_string(), planned, planned)]
        );
        assert_eq!(*recorder.units.lock().unwrap(), ["pixel-frames"]);
        let grown = recorder.grown.load(Relaxed);
        assert!(grown > 0);
        assert_eq!(recorder.advanced.load(Relaxed), planned + grown);
        assert_eq!(recorder.ended.load(Relaxed), 1);
    }

    #[test]
    fn another_centroider_plans_and_advances_its_cog_equivalent_arms() {
        // wcog adds the cog-equivalent: the pilot's 8 references read through cog as well, and
        // a final grid of 6 through cog; the stage plans them and ends exactly advanced.
        let mut cfg = SimConfig::paper(4);
        cfg.iters = 600;
        let wcog = CentroiderSpec::parse("wcog").unwrap();
        let recorder = Recorder::default();
        let table = effective_table_with(
            std::slice::from_ref(&cfg),
            &[ModelSpec::parse("scmos-constant:0.8").unwrap()],
            &[wcog],
            &ModelParams::default(),
            &Precision::fixed(600),
            &recorder,
        )
        .unwrap();
        let planned = (500 * (1 + 8 + 8) + 600 * (1 + 4 + 6)) * 16;
        assert_eq!(planned_work_with(&cfg, &wcog), planned);
        let stages = recorder.stages.lock().unwrap().clone();
        assert_eq!(stages, [("effective".to_string(), planned, planned)]);
        let grown = recorder.grown.load(Relaxed);
        assert_eq!(recorder.advanced.load(Relaxed), planned + grown);
        let e = &table[0].effective;
        assert!(
            e.sigma_cog_equiv_e.is_finite() && e.sigma_cog_equiv_se_e > 0.0,
            "{e:?}"
        );
    }

    #[test]
    fn a_bad_precision_is_refused_before_any_work() {
        let cfg = SimConfig::paper(4);
        let recorder = Recorder::default();
        let err = effective_table(
            &[cfg],
            &[ModelSpec::ScmosMedian],
            &ModelParams::default(),
            &Precision::fixed(100),
            &recorder,
        )
        .unwrap_err();
        assert!(err.to_string().contains("`max_iters`"), "{err}");
        assert!(recorder.stages.lock().unwrap().is_empty());
    }

    fn effective(sigma: f64, se: f64, target: Option<f64>, status: Status) -> Effective {
        Effective {
            sigma_eff_e: sigma,
            sigma_eff_se_e: se,
            sigma_cog_equiv_e: sigma,
            sigma_cog_equiv_se_e: se,
            target_se_e: target,
            iters: 40_000,
            r_px: 0.5,
            r_se_px: 0.25,
            b_opt_e: 2.0,
            param_name: None,
            param_opt: None,
            sigma_grid_e: vec![0.0, 1.0],
            r_const_px: vec![0.1, 0.2],
            status,
            parts: Default::default(),
        }
    }

    #[test]
    fn tables_are_written_as_csv_and_json_with_the_record_columns() {
        let cfg = SimConfig::paper(8);
        let e = effective(f64::NAN, f64::NAN, None, Status::Unreachable);
        let mut records = [EffectiveRecord::new("scmos-map".into(), &cfg, &e)];
        records[0].r_crlb_px = Some(0.125);
        let dir = tempfile::tempdir().unwrap();
        let written = write_tables(&records, dir.path()).unwrap();
        assert_eq!(written, TABLE_NAMES.map(|n| dir.path().join(n)));
        let csv = std::fs::read_to_string(&written[0]).unwrap();
        // `iters` is the count the value rests on, not the configuration's starting one.
        assert_eq!(
            csv,
            "model,centroider,subap_px,spot,sampling,signal_photons,qe,iters,seed,sigma_eff_e,\
             sigma_eff_se_e,target_se_e,sigma_cog_equiv_e,sigma_cog_equiv_se_e,r_px,r_se_px,\
             r_crlb_px,crlb_efficiency,b_opt_e,centroider_param,centroider_param_opt,status,\
             sigma_random_e,sigma_random_se_e,sigma_random_extrapolated,random_rms_px,static_x_px,\
             static_y_px,static_px,static_se_px,static_resolved\n\
             scmos-map,cog,8,airy:2,integrated,50,1,40000,1,,,,,,0.5,0.25,0.125,0.25,2,,,\
             unreachable,,,false,,,,,,false\n"
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&written[1]).unwrap()).unwrap();
        assert!(json[0]["sigma_eff_e"].is_null() && json[0]["target_se_e"].is_null());
        assert_eq!(json[0]["status"], "unreachable");
        assert_eq!(json[0]["iters"], 40_000);
        assert!(json[0]["sigma_cog_equiv_e"].is_null());
        assert_eq!(json[0].as_object().unwrap().len(), 31);
    }

    #[test]
    fn no_status_writes_nan_or_infinity() {
        let cfg = SimConfig::paper(8);
        let cases = [
            effective(1.25, 0.02, Some(0.05), Status::Ok),
            effective(18.5, 6.5, Some(0.37), Status::Imprecise),
            effective(0.0, f64::INFINITY, Some(0.05), Status::LowerBound),
            effective(f64::NAN, f64::NAN, None, Status::Unreachable),
            effective(f64::NAN, f64::NAN, None, Status::NoEligibleLevel),
        ];
        let records: Vec<EffectiveRecord> = cases
            .iter()
            .map(|e| EffectiveRecord::new("m".into(), &cfg, e))
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let written = write_tables(&records, dir.path()).unwrap();
        for path in &written {
            let text = std::fs::read_to_string(path).unwrap().to_lowercase();
            assert!(!text.contains("nan") && !text.contains("inf"), "{text}");
        }
        let csv = std::fs::read_to_string(&written[0]).unwrap();
        let rows: Vec<&str> = csv.lines().skip(1).collect();
        assert!(rows[0].contains(",1.25,0.02,0.05,") && rows[0].contains(",ok,"));
        assert!(rows[1].contains(",18.5,6.5,0.37,") && rows[1].contains(",imprecise,"));
        assert!(rows[2].contains(",0,,0.05,") && rows[2].contains(",lower_bound,"));
    }
}
