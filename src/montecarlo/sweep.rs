//! The sweep: a grid of configurations, each run with the same readout models, one record per
//! configuration and model. Every caller (simulate, the paper's figures, the report) uses it.

use super::config::SimConfig;
use super::engine::{Arm, Experiment};
use super::record::SimRecord;
use crate::centroid::CentroiderSpec;
use crate::detector::{ModelParams, ModelSpec, Readout};
use crate::progress::Observer;
use crate::spot::Spot;
use crate::Result;

/// A grid of configurations: every sub-aperture size x spot x signal, the other settings shared.
#[derive(Debug, Clone)]
pub struct Grid {
    /// Sub-aperture sides (px).
    pub subaps_px: Vec<usize>,
    /// Spot shapes.
    pub spots: Vec<Spot>,
    /// Signals, photons per sub-aperture before QE.
    pub signals_photons: Vec<f64>,
    /// Every other setting (sampling, QE, iterations, seed, background grid, ...); its own
    /// sub-aperture, spot and signal are replaced by the grid's.
    pub shared: SimConfig,
}

impl Grid {
    /// The configurations in sub-aperture, then spot, then signal order, each validated (the
    /// error names the field at fault).
    pub fn configs(&self) -> Result<Vec<SimConfig>> {
        let mut out = Vec::new();
        for &subap_px in &self.subaps_px {
            for &spot in &self.spots {
                for &signal_photons in &self.signals_photons {
                    let cfg = SimConfig {
                        subap_px,
                        spot,
                        signal_photons,
                        ..self.shared.clone()
                    };
                    cfg.validate()?;
                    out.push(cfg);
                }
            }
        }
        Ok(out)
    }
}

/// Run every configuration with every model of `specs` (built with `params` for its
/// sub-aperture); the models of one configuration share their random numbers. Records come in
/// configuration order, then model order. `observer` sees one stage, `simulate`, counting
/// iterations, and a warning for every optimum at the top of the background grid.
pub fn sweep(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    params: &ModelParams,
    observer: &dyn Observer,
) -> Result<Vec<SimRecord>> {
    sweep_with(
        configs,
        specs,
        &[CentroiderSpec::default()],
        params,
        observer,
    )
}

/// [`sweep`] with every model read through each of `centroiders` (each model read once per
/// frame, its centroiders sharing that frame): records in configuration, then model, then
/// centroider order.
pub fn sweep_with(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    centroiders: &[CentroiderSpec],
    params: &ModelParams,
    observer: &dyn Observer,
) -> Result<Vec<SimRecord>> {
    let work: u64 = configs
        .iter()
        .map(|c| c.iters * (c.subap_px * c.subap_px * specs.len()) as u64)
        .sum();
    observer.begin("simulate", configs.iter().map(|c| c.iters).sum(), work);
    let records = run_all(configs, specs, centroiders, params, observer);
    observer.end();
    records
}

fn run_all(
    configs: &[SimConfig],
    specs: &[ModelSpec],
    centroiders: &[CentroiderSpec],
    params: &ModelParams,
    observer: &dyn Observer,
) -> Result<Vec<SimRecord>> {
    let mut records = Vec::with_capacity(configs.len() * specs.len() * centroiders.len());
    for cfg in configs {
        let models: Vec<Box<dyn Readout>> = specs
            .iter()
            .map(|s| s.build(params, cfg.subap_px))
            .collect::<Result<_>>()?;
        let refs: Vec<&dyn Readout> = models.iter().map(|m| m.as_ref()).collect();
        let arms: Vec<Arm> = (0..specs.len())
            .flat_map(|model| {
                centroiders
                    .iter()
                    .map(move |&centroider| Arm { model, centroider })
            })
            .collect();
        // The Cramer-Rao floor of each model (analytic: milliseconds beside the Monte-Carlo).
        let floors: Vec<Option<f64>> = refs
            .iter()
            .map(|m| crate::crlb::r_crlb_of_readout(cfg, *m, crate::crlb::Information::Exact))
            .collect();
        let mut exp = Experiment::with_arms(cfg, &refs, &arms)?;
        exp.extend_to(cfg.iters, observer, 1)?;
        for (arm, r) in arms.iter().zip(exp.results()?) {
            let spec = &specs[arm.model];
            if r.b_at_grid_edge {
                observer.warn(&format!(
                    "{} at {}x{} px, {}, S = {}: the optimum background is the top of the grid; \
                     widen `bg_grid`",
                    r.model,
                    cfg.subap_px,
                    cfg.subap_px,
                    cfg.spot.label(),
                    cfg.signal_photons
                ));
            }
            let per_px = cfg.signal_photons * cfg.qe / (cfg.subap_px * cfg.subap_px) as f64;
            let in_range = refs[arm.model].in_range(per_px);
            // Once per model and configuration, not per centroider.
            if in_range == Some(false) && arm.centroider == centroiders[0] {
                observer.warn(&format!(
                    "{} at {}x{} px, S = {} ({per_px:.3} photo-electrons per pixel): outside the \
                     model's useful range, its R does not describe a usable camera (model_range \
                     = outside_range; see docs/models.md)",
                    r.model, cfg.subap_px, cfg.subap_px, cfg.signal_photons
                ));
            }
            let em_gain = spec.uses("em_gain").then_some(params.em_gain);
            let record = SimRecord::new(cfg, em_gain, r).with_floor(floors[arm.model]);
            records.push(record.with_range(in_range));
        }
    }
    Ok(records)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::montecarlo::{run, BgGrid};
    use crate::progress::{Recorder, Silent};
    use std::sync::atomic::Ordering::Relaxed;

    fn grid(iters: u64) -> Grid {
        let mut shared = SimConfig::paper(2);
        shared.iters = iters;
        Grid {
            subaps_px: vec![4, 6],
            spots: vec![
                Spot::Airy { diameter_px: 2.0 },
                Spot::Airy { diameter_px: 4.0 },
            ],
            signals_photons: vec![20.0, 200.0, 1000.0],
            shared,
        }
    }

    #[test]
    fn grid_order_is_subaperture_then_spot_then_signal() {
        let configs = grid(100).configs().unwrap();
        assert_eq!(configs.len(), 12);
        let key = |c: &SimConfig| (c.subap_px, c.spot.label(), c.signal_photons);
        assert_eq!(key(&configs[0]), (4, "airy:2".into(), 20.0));
        assert_eq!(key(&configs[2]), (4, "airy:2".into(), 1000.0));
        assert_eq!(key(&configs[3]), (4, "airy:4".into(), 20.0));
        assert_eq!(key(&configs[6]), (6, "airy:2".into(), 20.0));
        assert!(configs.iter().all(|c| c.iters == 100 && c.seed == 1));
        // A bad value anywhere in the grid is refused, naming its field.
        let mut g = grid(100);
        g.signals_photons.push(-1.0);
        let e = g.configs().unwrap_err().to_string();
        assert!(e.contains("`signal_photons`"), "{e}");
    }

    #[test]
    fn sweep_is_run_per_configuration_on_common_random_numbers() {
        // Each record equals a direct run of its configuration with all the models together,
        // bit for bit, in configuration-then-model order.
        let configs = grid(300).configs().unwrap();
        let specs: Vec<ModelSpec> = ["scmos-constant:0.5", "scmos-random"]
            .iter()
            .map(|m| ModelSpec::parse(m).unwrap())
            .collect();
        let params = ModelParams::default();
        let records = sweep(&configs, &specs, &params, &Silent).unwrap();
        assert_eq!(records.len(), configs.len() * specs.len());
        for (k, cfg) in configs.iter().enumerate() {
            let models: Vec<Box<dyn Readout>> = specs
                .iter()
                .map(|s| s.build(&params, cfg.subap_px).unwrap())
                .collect();
            let refs: Vec<&dyn Readout> = models.iter().map(|m| m.as_ref()).collect();
            let direct = run(cfg, &refs, &Silent).unwrap();
            for (m, r) in direct.iter().enumerate() {
                let rec = &records[k * specs.len() + m];
                assert_eq!(rec.result.model, r.model);
                assert_eq!(rec.result.r_px.to_bits(), r.r_px.to_bits());
                assert_eq!(rec.config.signal_photons, cfg.signal_photons);
                let used = specs[m].uses("em_gain");
                assert_eq!(rec.em_gain, used.then_some(params.em_gain));
            }
        }
    }

    #[test]
    fn sweep_reports_one_stage_and_warns_at_the_grid_edge() {
        // Levels 0 and 0.95 e- for 3 e- read noise: 0.95 e- is the optimum of the automatic
        // grid for this configuration, so here it is the top of the grid.
        let mut g = grid(200);
        g.subaps_px = vec![4];
        g.spots.truncate(1);
        g.signals_photons = vec![1000.0];
        g.shared.bg_grid = BgGrid::parse("0.95:0.95:1").unwrap();
        let configs = g.configs().unwrap();
        let specs = [ModelSpec::parse("scmos-constant:3").unwrap()];
        let recorder = Recorder::default();
        let records = sweep(&configs, &specs, &ModelParams::default(), &recorder).unwrap();
        assert!(records[0].result.b_at_grid_edge);
        assert_eq!(
            *recorder.stages.lock().unwrap(),
            [("simulate".to_string(), 200, 200 * 16)]
        );
        assert_eq!(recorder.advanced.load(Relaxed), 200);
        assert_eq!(recorder.ended.load(Relaxed), 1);
        let warnings = recorder.warnings.lock().unwrap();
        assert_eq!(warnings.len(), 1);
        assert!(
            warnings[0].starts_with("scmos-constant:3 at 4x4 px, airy:2, S = 1000: ")
                && warnings[0].ends_with("widen `bg_grid`"),
            "{}",
            warnings[0]
        );
    }
}
