//! The effective QE factor over a grid of configurations: one record per EMCCD model and
//! configuration, written as `effective_qe.csv` and `effective_qe.json`.

use super::qe::{effective_qe, QeFactor, QePrecision};
use super::solve::planned_work;
use crate::detector::{EmccdSimple, ModelParams, ModelSpec};
use crate::montecarlo::{config_columns, SimConfig};
use crate::progress::Observer;
use crate::{Error, Result};
use serde::ser::{Serialize, SerializeStruct, Serializer};
use std::path::{Path, PathBuf};

/// Files [`write_qe_tables`] writes: the table as CSV and as JSON.
pub const QE_TABLE_NAMES: [&str; 2] = ["effective_qe.csv", "effective_qe.json"];

/// One configuration's effective QE factor of the simple model.
///
/// Serialised (CSV, JSON) as `model`; the configuration (`subap_px`, `spot`, `sampling`,
/// `signal_photons`, `qe`, `em_gain`, `iters`: the iterations the value rests on, `seed`);
/// `emccd_read_noise_e` (the camera's, output e-) and `simple_read_noise_e` (the simple
/// model's, e- referred to the input: their ratio to the gain); `qe_factor` and
/// `qe_factor_se` (unitless; empty/null without a value); `qe_factor_target_se` (the standard
/// error the factor had to reach); `paper_z` ((q - 0.5) / SE: the departure from the paper's
/// factor in standard errors; empty/null unless `ok` or `imprecise`); `r_px`, `r_se_px`,
/// `b_opt_e` (the detector's R, its SE and best level); and `status` (`ok`, `imprecise`,
/// `above_range`, `below_range`, `no_eligible_level`: see [`super::QeStatus::meaning`]).
#[derive(Debug, Clone)]
pub struct QeRecord {
    /// The detector model (its name, or a caller's label).
    pub model: String,
    /// The configuration solved.
    pub config: SimConfig,
    /// The camera's EM gain (e-/e-).
    pub em_gain: f64,
    /// The camera's read noise before division by the gain (output e- rms).
    pub emccd_read_noise_e: f64,
    /// The solution.
    pub qe: QeFactor,
}

impl Serialize for QeRecord {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let q = &self.qe;
        let mut s = serializer.serialize_struct("QeRecord", 18)?;
        s.serialize_field("model", &self.model)?;
        let used = SimConfig {
            iters: q.iters,
            ..self.config.clone()
        };
        config_columns(&mut s, &used, Some(Some(self.em_gain)))?;
        s.serialize_field("emccd_read_noise_e", &self.emccd_read_noise_e)?;
        s.serialize_field("simple_read_noise_e", &q.read_noise_e)?;
        // Non-finite values (no value, or an infinite SE) are written as empty/null, never NaN.
        let finite = |v: f64| v.is_finite().then_some(v);
        s.serialize_field("qe_factor", &finite(q.qe_factor))?;
        s.serialize_field("qe_factor_se", &finite(q.qe_factor_se))?;
        s.serialize_field("qe_factor_target_se", &q.target_se)?;
        s.serialize_field("paper_z", &q.paper_z())?;
        s.serialize_field("r_px", &q.r_px)?;
        s.serialize_field("r_se_px", &q.r_se_px)?;
        s.serialize_field("b_opt_e", &q.b_opt_e)?;
        s.serialize_field("status", &q.status)?;
        s.end()
    }
}

/// Solve the effective QE factor of every configuration (its `iters` the starting count) for
/// every EMCCD model of `specs` (built with `params`; the simple model's read noise is
/// `emccd_read_noise_e` / `em_gain`) to `precision`: records in model order, then configuration
/// order. `observer` sees one stage, `effective_qe`, counting pixel-frames as
/// [`super::effective_table`] does.
pub fn effective_qe_table(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    params: &ModelParams,
    precision: &QePrecision,
    observer: &dyn Observer,
) -> Result<Vec<QeRecord>> {
    for cfg in configs {
        cfg.validate()?;
        precision.validate(cfg.iters)?;
    }
    if let Some(spec) = specs.iter().find(|s| !s.is_emccd()) {
        return Err(Error::invalid(
            "model",
            format!(
                "{}: the QE factor of the simple EMCCD model is solved for EMCCD models only",
                spec.name()
            ),
        ));
    }
    let read_noise_e = EmccdSimple::read_noise_of(params.em_gain, params.emccd_read_noise_e)?;
    let work: u64 = configs.iter().map(planned_work).sum::<u64>() * specs.len() as u64;
    observer.begin("effective_qe", work, work);
    observer.unit("pixel-frames");
    let records = solve_all(configs, specs, params, read_noise_e, precision, observer);
    observer.end();
    records
}

fn solve_all(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    params: &ModelParams,
    read_noise_e: f64,
    precision: &QePrecision,
    observer: &dyn Observer,
) -> Result<Vec<QeRecord>> {
    let mut out = Vec::with_capacity(specs.len() * configs.len());
    for spec in specs {
        for cfg in configs {
            let model = spec.build(params, cfg.subap_px)?;
            out.push(QeRecord {
                model: model.name(),
                config: cfg.clone(),
                em_gain: params.em_gain,
                emccd_read_noise_e: params.emccd_read_noise_e,
                qe: effective_qe(cfg, model.as_ref(), read_noise_e, precision, observer)?,
            });
        }
    }
    Ok(out)
}

/// Write the table into `dir` as [`QE_TABLE_NAMES`] (CSV and JSON, each atomically); returns
/// their paths.
pub fn write_qe_tables(records: &[QeRecord], dir: &Path) -> Result<Vec<PathBuf>> {
    crate::output::write_csv_json(records, dir, QE_TABLE_NAMES)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effective::QeStatus;
    use crate::progress::{Recorder, Silent};
    use std::sync::atomic::Ordering::Relaxed;

    #[test]
    fn the_table_solves_each_configuration_like_the_solver() {
        // Records equal bit for bit to direct solves, with the simple model's read noise from
        // the parameters (60 e- / 300 = 0.2 e-); the stage ends exactly advanced.
        let configs: Vec<SimConfig> = [(4usize, 50.0), (6, 200.0)]
            .iter()
            .map(|&(n, s)| SimConfig {
                signal_photons: s,
                iters: 600,
                ..SimConfig::paper(n)
            })
            .collect();
        let params = ModelParams {
            em_gain: 300.0,
            emccd_read_noise_e: 60.0,
            ..ModelParams::default()
        };
        let specs = [ModelSpec::EmccdStochastic];
        let precision = QePrecision {
            target_se: 0.03,
            target_rel: 0.0,
            max_iters: 4000,
        };
        let recorder = Recorder::default();
        let table = effective_qe_table(&configs, &specs, &params, &precision, &recorder).unwrap();
        assert_eq!(table.len(), 2);
        for (rec, cfg) in table.iter().zip(&configs) {
            let model = specs[0].build(&params, cfg.subap_px).unwrap();
            let direct = effective_qe(cfg, model.as_ref(), 0.2, &precision, &Silent).unwrap();
            assert_eq!(rec.qe.qe_factor.to_bits(), direct.qe_factor.to_bits());
            assert_eq!((rec.qe.iters, rec.qe.read_noise_e), (direct.iters, 0.2));
            assert_eq!((rec.em_gain, rec.emccd_read_noise_e), (300.0, 60.0));
        }
        let grown = recorder.grown.load(Relaxed);
        let (_, _, planned) = recorder.stages.lock().unwrap()[0].clone();
        assert_eq!(recorder.advanced.load(Relaxed), planned + grown);
        assert_eq!(recorder.ended.load(Relaxed), 1);
    }

    #[test]
    fn scmos_models_are_refused_before_any_work() {
        let recorder = Recorder::default();
        let err = effective_qe_table(
            &[SimConfig::paper(4)],
            &[ModelSpec::ScmosMedian],
            &ModelParams::default(),
            &QePrecision::default(),
            &recorder,
        )
        .unwrap_err();
        assert!(err.to_string().contains("`model`") && err.to_string().contains("EMCCD"));
        assert!(recorder.stages.lock().unwrap().is_empty());
    }

    #[test]
    fn tables_have_the_record_columns_and_no_nan() {
        let cfg = SimConfig::paper(8);
        let record = |q: f64, se: f64, status| QeRecord {
            model: "emccd-stochastic".into(),
            config: cfg.clone(),
            em_gain: 500.0,
            emccd_read_noise_e: 50.0,
            qe: QeFactor {
                qe_factor: q,
                qe_factor_se: se,
                target_se: q.is_finite().then_some(0.0125),
                read_noise_e: 0.1,
                iters: 4096,
                r_px: 0.2,
                r_se_px: 0.002,
                b_opt_e: 0.5,
                qe_grid: vec![],
                r_simple_px: vec![],
                status,
            },
        };
        let records = [
            record(0.45, 0.01, QeStatus::Ok),
            record(1.0, 0.2, QeStatus::AboveRange),
            record(f64::NAN, f64::NAN, QeStatus::BelowRange),
        ];
        let dir = tempfile::tempdir().unwrap();
        let written = write_qe_tables(&records, dir.path()).unwrap();
        let csv = std::fs::read_to_string(&written[0]).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "model,subap_px,spot,sampling,signal_photons,qe,em_gain,iters,seed,\
             emccd_read_noise_e,simple_read_noise_e,qe_factor,qe_factor_se,qe_factor_target_se,\
             paper_z,r_px,r_se_px,b_opt_e,status"
        );
        assert!(lines[1].contains(",0.45,0.01,0.0125,-5") && lines[1].ends_with(",ok"));
        assert!(lines[2].contains(",1,0.2,0.0125,,") && lines[2].ends_with(",above_range"));
        assert!(lines[3].contains(",0.1,,,,,0.2,") && lines[3].ends_with(",below_range"));
        let json = std::fs::read_to_string(&written[1]).unwrap();
        assert!(!json.to_lowercase().contains("nan"));
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert!(v[2]["qe_factor"].is_null() && v[2]["paper_z"].is_null());
        assert_eq!(v[0].as_object().unwrap().len(), 19);
    }
}
