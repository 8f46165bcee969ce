//! The measured camera: every map and amplitude a campaign of darks gives ([`CameraModel`]),
//! stored as one folder ([`CameraModel::write`], [`CameraModel::read`]), and what it is at an
//! operating point ([`OperatingPoint`], [`CameraModel::at`]): the expected dark signal, the
//! offset and the noise of each pixel, for the readout model `camera`, `synth` and the report.
//!
//! Layout: `model` (the type, its parts and their checks), `file` (the folder format),
//! `point` (an operating point), `operating` (the camera at it), `range` (the campaign's
//! conditions), `choice` (the point a run chooses from them), `sample` (a frame's draws of it).

mod choice;
mod file;
mod model;
mod operating;
mod point;
mod range;
mod sample;

pub use choice::CameraChoice;
pub use file::{CAMERA_JSON, MAP_FILES};
pub use model::{CameraModel, DarkCurrent, EmRegisterModel};
pub use operating::{CameraAt, MAX_EXPOSURE_S};
pub use point::OperatingPoint;
pub use range::{ExposureChoice, OperatingRange};
pub use sample::CameraSampler;
