//! The settings shared by the readout models of a run; each registry entry lists the fields
//! its builder reads.

use crate::calib::Map;
use std::sync::Arc;

use super::dark_frames::DarkFrames;
use super::pp::PpRule;
use super::rts_table::RtsTable;
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
    /// Telegraph (RTS) pixels of `scmos-rts`, from the `rts.csv` of `darks` (levels in e-).
    pub rts_table: Option<Arc<RtsTable>>,
    /// Row-noise amplitude of `scmos-correlated` (e- rms, shared by a row of the window).
    pub row_noise_e: Option<f64>,
    /// Column-noise amplitude of `scmos-correlated` (e- rms, shared by a column of the window).
    pub column_noise_e: Option<f64>,
    /// The bias-subtracted dark frames (e-) of `scmos-frames`.
    pub dark_frames: Option<Arc<DarkFrames>>,
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
            rts_table: None,
            row_noise_e: None,
            column_noise_e: None,
            dark_frames: None,
        }
    }
}
