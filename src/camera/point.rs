//! [`OperatingPoint`]: how the camera is run (a leaf: the campaign's range and the camera at
//! a point both name it).

/// How the camera is run: the exposure of each frame, the EM gain commanded (None: no EM
/// gain, or a camera without a register) and the sensor temperature (None: the temperature
/// the dark current was measured at).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OperatingPoint {
    /// Exposure (integration) time of each frame, s (> 0).
    pub exposure_s: f64,
    /// Commanded EM gain, e-/e-; None: no multiplication (gain 1).
    pub em_gain: Option<f64>,
    /// Sensor temperature, degrees C; None: the dark current's reference temperature.
    pub temperature_c: Option<f64>,
}
