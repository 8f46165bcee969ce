//! What an EM-gain fit models and holds fixed.

use serde::{Deserialize, Serialize};

/// Law of the EM register output for one input electron.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum EmShape {
    /// Exponential of mean G (the Erlang/Gamma model of paper Eq. 2; F^2 = 2).
    Gamma,
    /// The exact register of `stages` stages (needs the conversion gain to place the
    /// electron lattice; F^2 = 1 + var1/g^2).
    Register {
        /// Number of multiplication stages.
        stages: u32,
    },
}

/// How to fit.
#[derive(Debug, Clone)]
pub struct EmGainOptions {
    /// Single-electron output law.
    pub shape: EmShape,
    /// Conversion gain (e- per adu); the gain is then reported in e-/e-.
    pub gain_e_per_adu: Option<f64>,
    /// Values above this (adu) are excluded (cosmics, hot pixels). Default: bias + 40 G
    /// (1 + lambda + 5 sqrt(lambda)) from the start values.
    pub max_value_adu: Option<f64>,
    /// Bias (adu) known from no-signal frames: held fixed (with the read noise).
    pub fixed_bias_adu: Option<f64>,
    /// Read noise (adu rms) known from no-signal frames: held fixed (with the bias).
    pub fixed_read_noise_adu: Option<f64>,
    /// Also fit serial clock-induced charge (electrons born inside the register, with
    /// partial gain); needs the exact register shape. Parallel CIC is part of lambda.
    pub serial_cic: bool,
}

impl Default for EmGainOptions {
    fn default() -> Self {
        EmGainOptions {
            shape: EmShape::Gamma,
            gain_e_per_adu: None,
            max_value_adu: None,
            fixed_bias_adu: None,
            fixed_read_noise_adu: None,
            serial_cic: false,
        }
    }
}
