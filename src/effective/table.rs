//! The effective read noise over a grid of configurations: one record per detector model and
//! configuration, written as `effective_noise.csv` and `effective_noise.json`.

use super::solve::{effective_sigma, Effective};
use crate::detector::{ModelParams, ModelSpec};
use crate::montecarlo::{config_columns, SimConfig};
use crate::output::{render, write_atomic, TableFormat};
use crate::progress::Observer;
use crate::Result;
use serde::ser::{Serialize, SerializeStruct, Serializer};
use std::path::{Path, PathBuf};

/// Files [`write_tables`] writes: the table as CSV and as JSON.
pub const TABLE_NAMES: [&str; 2] = ["effective_noise.csv", "effective_noise.json"];

/// One configuration's effective read noise.
///
/// Serialised (CSV, JSON) as the columns `model`, the configuration (`subap_px`, `spot`,
/// `sampling`, `signal_photons`, `qe`, `iters`, `seed`), then `sigma_eff_e`, `sigma_eff_se_e`,
/// `r_px`, `r_se_px`, `b_opt_e` and `status` (ok, lower_bound: sigma_eff = 0, or unreachable:
/// no constant sigma gives this R, sigma_eff null).
#[derive(Debug, Clone)]
pub struct EffectiveRecord {
    /// The detector model (its name, or a caller's label).
    pub model: String,
    /// The configuration solved.
    pub config: SimConfig,
    /// The solution.
    pub effective: Effective,
}

impl EffectiveRecord {
    /// The record of `model` (a label) in configuration `cfg`.
    pub fn new(model: String, cfg: &SimConfig, e: &Effective) -> Self {
        EffectiveRecord {
            model,
            config: cfg.clone(),
            effective: e.clone(),
        }
    }
}

impl Serialize for EffectiveRecord {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let e = &self.effective;
        let mut s = serializer.serialize_struct("EffectiveRecord", 14)?;
        s.serialize_field("model", &self.model)?;
        config_columns(&mut s, &self.config, None)?;
        s.serialize_field("sigma_eff_e", &e.sigma_eff_e)?;
        s.serialize_field("sigma_eff_se_e", &e.sigma_eff_se_e)?;
        s.serialize_field("r_px", &e.r_px)?;
        s.serialize_field("r_se_px", &e.r_se_px)?;
        s.serialize_field("b_opt_e", &e.b_opt_e)?;
        s.serialize_field("status", &e.status)?;
        s.end()
    }
}

/// Solve every configuration for every detector model of `specs` (built with `params` for its
/// sub-aperture): records in model order, then configuration order. `observer` sees one stage,
/// `effective`, counting the iterations of the full-length runs.
pub fn effective_table(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    params: &ModelParams,
    observer: &dyn Observer,
) -> Result<Vec<EffectiveRecord>> {
    let iters: u64 = configs.iter().map(|c| c.iters).sum();
    // Pilot (10 %) plus the detector and four constant sigmas in the final run.
    let work: u64 = configs
        .iter()
        .map(|c| c.iters * (c.subap_px * c.subap_px) as u64 * 6)
        .sum();
    let n = specs.len() as u64;
    observer.begin("effective", n * iters, n * work);
    let records = solve_all(configs, specs, params, observer);
    observer.end();
    records
}

fn solve_all(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    params: &ModelParams,
    observer: &dyn Observer,
) -> Result<Vec<EffectiveRecord>> {
    let mut out = Vec::with_capacity(specs.len() * configs.len());
    for spec in specs {
        for cfg in configs {
            let model = spec.build(params, cfg.subap_px)?;
            let e = effective_sigma(cfg, model.as_ref(), observer)?;
            out.push(EffectiveRecord::new(model.name(), cfg, &e));
        }
    }
    Ok(out)
}

/// Write the table into `dir` as [`TABLE_NAMES`] (CSV and JSON, each atomically); returns
/// their paths.
pub fn write_tables(records: &[EffectiveRecord], dir: &Path) -> Result<Vec<PathBuf>> {
    let formats = [TableFormat::Csv, TableFormat::Json];
    let mut written = Vec::new();
    for (name, format) in TABLE_NAMES.iter().zip(formats) {
        let path = dir.join(name);
        write_atomic(&path, render(records, format)?.as_bytes())?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Recorder;
    use std::sync::atomic::Ordering::Relaxed;

    #[test]
    fn table_solves_each_model_and_configuration_like_the_solver() {
        // Records in model-then-configuration order, each equal bit for bit to a direct solve.
        let mut configs = Vec::new();
        for (n, s) in [(4usize, 50.0), (6, 200.0)] {
            let mut c = SimConfig::paper(n);
            c.signal_photons = s;
            c.iters = 600;
            configs.push(c);
        }
        let specs = [
            ModelSpec::parse("scmos-constant:0.8").unwrap(),
            ModelSpec::ScmosMedian,
        ];
        let params = ModelParams::default();
        let recorder = Recorder::default();
        let table = effective_table(&configs, &specs, &params, &recorder).unwrap();
        assert_eq!(table.len(), 4);
        for (k, rec) in table.iter().enumerate() {
            let (spec, cfg) = (&specs[k / 2], &configs[k % 2]);
            let model = spec.build(&params, cfg.subap_px).unwrap();
            let direct = effective_sigma(cfg, model.as_ref(), &crate::progress::Silent).unwrap();
            assert_eq!(rec.model, model.name());
            assert_eq!(rec.config.subap_px, cfg.subap_px);
            assert_eq!(
                rec.effective.sigma_eff_e.to_bits(),
                direct.sigma_eff_e.to_bits()
            );
        }
        let work = 2 * 600 * (16 + 36) * 6;
        assert_eq!(
            *recorder.stages.lock().unwrap(),
            [("effective".to_string(), 2 * 1200, work)]
        );
        // At least every final run is counted once (a fallback to the wide grid counts again).
        assert!(recorder.advanced.load(Relaxed) >= 2 * 1200);
        assert_eq!(recorder.ended.load(Relaxed), 1);
    }

    #[test]
    fn tables_are_written_as_csv_and_json_with_the_record_columns() {
        let cfg = SimConfig::paper(8);
        let e = Effective {
            sigma_eff_e: f64::NAN,
            sigma_eff_se_e: f64::NAN,
            r_px: 0.5,
            r_se_px: 0.25,
            b_opt_e: 2.0,
            sigma_grid_e: vec![0.0, 1.0],
            r_const_px: vec![0.1, 0.2],
            status: crate::effective::Status::Unreachable,
        };
        let records = [EffectiveRecord::new("scmos-map".into(), &cfg, &e)];
        let dir = tempfile::tempdir().unwrap();
        let written = write_tables(&records, dir.path()).unwrap();
        assert_eq!(written, TABLE_NAMES.map(|n| dir.path().join(n)));
        let csv = std::fs::read_to_string(&written[0]).unwrap();
        assert_eq!(
            csv,
            "model,subap_px,spot,sampling,signal_photons,qe,iters,seed,sigma_eff_e,\
             sigma_eff_se_e,r_px,r_se_px,b_opt_e,status\n\
             scmos-map,8,airy:2,integrated,50,1,10000,1,,,0.5,0.25,2,unreachable\n"
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&written[1]).unwrap()).unwrap();
        assert!(json[0]["sigma_eff_e"].is_null());
        assert_eq!(json[0]["status"], "unreachable");
        assert_eq!(json[0].as_object().unwrap().len(), 14);
    }
}
