//! The settings shared by the readout models of a run; each registry entry lists the fields
//! its builder reads.

use crate::calib::Map;
use std::sync::Arc;

use super::pp::PpRule;
use crate::pdf::RmsPdf;

/// Parameters shared by the models of a run.
#[derive(Debug, Clone)]
pub struct ModelParams {
    /// EMCCD mean gain (output e- per input e-); paper default 500.
    pub em_gain: f64,
    /// EM register stages; paper default 520.
    pub stages: u32,
    /// EMCCD read noise before division by the gain (e-); paper default 50.
    pub emccd_read_noise_e: f64,
    /// Above this many input electrons `emccd-distribution` uses N(n g, n g^2); None = exact Gamma.
    pub gaussian_switch_e: Option<u32>,
    /// Use the per-stage binomial cascade instead of the tabulated register (reference, slow).
    pub cascade_register: bool,
    /// sigma (e-) for a bare `scmos-constant`.
    pub sigma_e: f64,
    /// Distribution of per-pixel rms for the sCMOS models.
    pub pdf: Arc<dyn RmsPdf>,
    /// Seed of the fixed sCMOS noise patterns (pattern K uses stream K of it).
    pub pattern_seed: u64,
    /// Measured noise map for `scmos-map`.
    pub map: Option<Arc<Map>>,
    /// Threshold rule of `emccd-pp`.
    pub pp_rule: PpRule,
    /// Fixed reference light level of `emccd-pp` (photo-electrons per pixel); None = sub-aperture mean.
    pub pp_lambda: Option<f64>,
}

impl Default for ModelParams {
    fn default() -> Self {
        ModelParams {
            em_gain: 500.0,
            stages: 520,
            emccd_read_noise_e: 50.0,
            gaussian_switch_e: None,
            cascade_register: false,
            sigma_e: 1.0,
            pdf: Arc::new(crate::pdf::paper()),
            pattern_seed: 2015,
            map: None,
            pp_rule: PpRule::PoissonPrior,
            pp_lambda: None,
        }
    }
}
