//! What an EM-gain fit models and holds fixed.

use serde::{Deserialize, Serialize};

/// Stages of the register assumed unless told (the e2v CCD201/CCD97 family, and the Roman
/// coronagraph's EMCCD, have 604).
pub const DEFAULT_STAGES: u32 = 604;

/// Law of the EM register output for one input electron.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum EmShape {
    /// Exponential of mean G (the Erlang/Gamma model of paper Eq. 2; F^2 = 2).
    Gamma,
    /// A Gamma law per input electron with the F^2 of a register of `stages` stages at the
    /// fitted gain (shape k = 1 / (F^2 - 1)): the register without its electron lattice,
    /// for when the conversion gain is not known (the gain in adu/e- then stands for the
    /// register's e-/e- in F^2, which varies by < 0.3 % over gains 100 to 5000).
    RegisterGamma {
        /// Number of multiplication stages.
        stages: u32,
    },
    /// The exact register of `stages` stages (needs the conversion gain to place the
    /// electron lattice; F^2 = 1 + var1/g^2).
    Register {
        /// Number of multiplication stages.
        stages: u32,
    },
}

impl EmShape {
    /// The default law: the exact register of [`DEFAULT_STAGES`] when the conversion gain
    /// is known, else the Gamma law with that register's F^2.
    pub fn default_for(gain_e_per_adu: Option<f64>) -> EmShape {
        match gain_e_per_adu {
            Some(_) => EmShape::Register {
                stages: DEFAULT_STAGES,
            },
            None => EmShape::RegisterGamma {
                stages: DEFAULT_STAGES,
            },
        }
    }

    /// The same law with `stages` stages (the exponential law has none).
    pub fn with_stages(self, stages: u32) -> EmShape {
        match self {
            EmShape::Gamma => EmShape::Gamma,
            EmShape::RegisterGamma { .. } => EmShape::RegisterGamma { stages },
            EmShape::Register { .. } => EmShape::Register { stages },
        }
    }

    /// One line naming the law, for summaries.
    pub fn describe(&self) -> String {
        match self {
            EmShape::Gamma => "exponential per input electron (paper Eq. 2, F^2 = 2)".into(),
            EmShape::RegisterGamma { stages } => {
                format!("Gamma per input electron with the F^2 of a {stages}-stage register")
            }
            EmShape::Register { stages } => format!("exact register of {stages} stages"),
        }
    }
}

/// A register law by name, its stages given apart (the command line's `--law`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum EmLaw {
    /// The exact register (needs the conversion gain).
    Register,
    /// The Gamma law with the register's F^2.
    Gamma,
    /// The exponential law of the paper (Eq. 2), F^2 = 2.
    Exponential,
}

impl EmLaw {
    /// The law with `stages` stages.
    pub fn shape(self, stages: u32) -> EmShape {
        match self {
            EmLaw::Register => EmShape::Register { stages },
            EmLaw::Gamma => EmShape::RegisterGamma { stages },
            EmLaw::Exponential => EmShape::Gamma,
        }
    }
}

/// Whether the fit models serial clock-induced charge (electrons born inside the register).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum SerialCic {
    /// Fit with and without it and keep the model the comparison (BIC) prefers.
    #[default]
    Auto,
    /// Always model it.
    On,
    /// Never model it.
    Off,
}

/// How to fit.
#[derive(Debug, Clone, Default)]
pub struct EmGainOptions {
    /// Single-electron output law; default [`EmShape::default_for`] the conversion gain.
    pub shape: Option<EmShape>,
    /// Conversion gain (e- per adu); the gain is then reported in e-/e-.
    pub gain_e_per_adu: Option<f64>,
    /// Values above this (adu) are excluded (cosmics, hot pixels). Default: bias + 40 G
    /// (1 + lambda + 5 sqrt(lambda)) from the start values.
    pub max_value_adu: Option<f64>,
    /// Bias (adu) known from no-signal frames: held fixed (with the read noise).
    pub fixed_bias_adu: Option<f64>,
    /// Read noise (adu rms) known from no-signal frames: held fixed (with the bias).
    pub fixed_read_noise_adu: Option<f64>,
    /// Serial clock-induced charge (electrons born inside the register, with partial gain):
    /// auto (default), on or off. Parallel CIC is part of lambda.
    pub serial_cic: SerialCic,
    /// The pixels' spread of mean charge (a histogram pooling pixels of different dark
    /// charge): the light term becomes that mixture of Poisson laws, lambda its mean. None:
    /// one lambda for all pixels.
    pub lambda_mixture: Option<super::LambdaMixture>,
}
