//! [`Sensor`]: the kind of camera a readout model simulates (a leaf: the camera model names
//! its kind without the registry).

/// The kind of camera a readout model simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensor {
    /// Electron-multiplying CCD: register gain, read noise divided by the gain.
    Emccd,
    /// sCMOS: photo-electrons plus per-pixel Gaussian read noise.
    Scmos,
}
