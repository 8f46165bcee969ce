//! What a report returns: its key numbers (the content of `summary.json`), the tables it
//! computed, and the files it wrote.

use super::point::ChosenPoint;
use super::qe_factor::QeSummary;
pub use super::real_noise::{RealNoise, RealNoiseRow};
use crate::calib::ptc::PtcResult;
use crate::calib::summary::InputFile;
use crate::detector::ModelSpec;
use crate::effective::{EffectiveRecord, QeRecord, Status};
use crate::fit::emgain::EmGainFit;
use crate::fit::pdf_fit::PdfFitReport;
use crate::montecarlo::SimRecord;
use std::path::PathBuf;

/// The outcome of [`super::run`].
#[derive(Debug)]
pub struct ReportResult {
    /// The key numbers, as written to `summary.json`.
    pub summary: Summary,
    /// Effective read noise per configuration: the fitted pdf's records, then the measured
    /// map's (sCMOS; empty for an EMCCD).
    pub effective: Vec<EffectiveRecord>,
    /// R against signal at the operating sub-aperture and spot, per compared model.
    pub comparison: Vec<Compared>,
    /// The fit of the per-pixel read-noise distribution (sCMOS).
    pub pdf_fit: Option<PdfFitReport>,
    /// Photon transfer on the flats, when it gave the conversion gain (sCMOS).
    pub ptc: Option<PtcResult>,
    /// The output directory, as given.
    pub out_dir: PathBuf,
    /// Every file the report wrote, inside `out_dir` (the directory's manifest aside).
    pub files: Vec<PathBuf>,
}

impl ReportResult {
    /// The sCMOS summary, if this was an sCMOS report.
    pub fn scmos(&self) -> Option<&ReportSummary> {
        match &self.summary {
            Summary::Scmos(s) => Some(s),
            Summary::Emccd(_) => None,
        }
    }

    /// The EMCCD summary, if this was an EMCCD report.
    pub fn emccd(&self) -> Option<&EmccdSummary> {
        match &self.summary {
            Summary::Emccd(s) => Some(s),
            Summary::Scmos(_) => None,
        }
    }
}

/// One compared model's result at one signal: the model as selected, and its record.
#[derive(Debug, Clone)]
pub struct Compared {
    /// The readout model.
    pub spec: ModelSpec,
    /// Its configuration and R (px).
    pub record: SimRecord,
}

/// The key numbers of a report, by camera kind.
#[derive(Debug)]
pub enum Summary {
    /// An sCMOS report.
    Scmos(Box<ReportSummary>),
    /// An EMCCD report.
    Emccd(Box<EmccdSummary>),
}

/// One input file of a report: its role (`darks` or `flats`), path, BLAKE3 checksum, frames and format.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ReportInput {
    /// `darks` or `flats`.
    pub role: String,
    /// The file: path, BLAKE3 (hex), frames read, format and stored sample type.
    #[serde(flatten)]
    pub file: InputFile,
}

impl ReportInput {
    /// The records of `files`, each in `role`.
    pub fn all(role: &str, files: Vec<InputFile>) -> impl Iterator<Item = ReportInput> + '_ {
        files.into_iter().map(move |file| ReportInput {
            role: role.into(),
            file,
        })
    }
}

/// The key numbers of an sCMOS report, written to `summary.json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ReportSummary {
    /// Tool and version.
    pub tool: String,
    /// Every input file (darks, then flats), with BLAKE3.
    pub inputs: Vec<ReportInput>,
    /// Dark frames used.
    pub frames: usize,
    /// Frame shape [rows, cols].
    pub shape: [usize; 2],
    /// Conversion gain used (e-/adu) and where it came from.
    pub gain_e_per_adu: f64,
    /// `ptc` or `given`.
    pub gain_source: String,
    /// Standard error of the gain (e-/adu; photon transfer only).
    pub gain_se_e_per_adu: Option<f64>,
    /// Pixels used for the noise statistics (unflagged).
    pub pixels_used: usize,
    /// Pixels excluded by the dark flags (hot, dead, saturated, no data).
    pub pixels_flagged: usize,
    /// Median per-pixel read noise (e-).
    pub median_rms_e: f64,
    /// Mean per-pixel read noise (e-).
    pub mean_rms_e: f64,
    /// sqrt(mean(rms^2)) (e-), the noise-power equivalent single value.
    pub rms_rms_e: f64,
    /// Fraction of pixels above 3x the median.
    pub frac_above_3x_median: f64,
    /// Best pdf model by AIC.
    pub pdf_best_model: String,
    /// Split-half correlation of the noise maps (odd vs even frames).
    pub split_half_correlation: f64,
    /// The operating point and the headline numbers there.
    pub operating_point: Headline,
    /// Monte-Carlo iterations per configuration.
    pub iters: u64,
    /// Seed.
    pub seed: u64,
    /// Spot sampling.
    pub sampling: String,
    /// True for the reduced `quick` grid.
    pub quick: bool,
    /// The camera's noise beyond Gaussian pixels (row, column and telegraph noise, its own
    /// dark frames) and what it adds to the effective read noise at the operating point.
    pub real_noise: RealNoise,
    /// The per-sub-aperture map (with a lenslet geometry): its options, counts by status and
    /// the spread of sigma_eff; absent without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub subaps: Option<crate::subaps::SubapsSummary>,
    /// The camera read through each centroider: R and the same-centroider sigma_eff per method
    /// (with the cog-equivalent), the best one by R, and the comparison with an EMCCD.
    pub centroiders: super::centroiders::Centroiders,
    /// The camera model of `--camera` at its operating point; absent without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera: Option<super::camera::CameraSection>,
}

/// The headline numbers of an sCMOS report: the effective read noise at the operating point.
/// A value whose status is not `ok` is no result (null in JSON where there is none).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Headline {
    /// The operating point: sub-aperture (px), spot, signal (photons), how it was chosen.
    #[serde(flatten)]
    pub at: ChosenPoint,
    /// Effective read noise with the fitted pdf (e-).
    pub sigma_eff_fitted_pdf_e: f64,
    /// Its standard error (e-).
    pub sigma_eff_fitted_pdf_se_e: f64,
    /// Its status.
    pub sigma_eff_fitted_pdf_status: Status,
    /// Effective read noise with the measured map (e-).
    pub sigma_eff_map_e: f64,
    /// Its standard error (e-).
    pub sigma_eff_map_se_e: f64,
    /// Its status.
    pub sigma_eff_map_status: Status,
}

/// The key numbers of an EMCCD report, written to `summary.json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EmccdSummary {
    /// Tool and version.
    pub tool: String,
    /// Every input file (the frames), with BLAKE3.
    pub inputs: Vec<ReportInput>,
    /// Frames used.
    pub frames: usize,
    /// Frame shape [rows, cols].
    pub shape: [usize; 2],
    /// Conversion gain used (e-/adu).
    pub gain_e_per_adu: f64,
    /// Read noise before the EM gain divides it (output e-).
    pub read_noise_output_e: f64,
    /// The EM-gain fit (gain in e-/e-, bias and read noise in adu, lambda in e-).
    pub emgain: EmGainFit,
    /// The operating point: the comparison's sub-aperture and spot, and the signal whose
    /// verdict heads the page.
    pub operating_point: ChosenPoint,
    /// Monte-Carlo iterations.
    pub iters: u64,
    /// Seed.
    pub seed: u64,
    /// True for the reduced `quick` grid.
    pub quick: bool,
    /// The simple model's effective QE factor over the grid: counts, extremes, where the
    /// paper's 0.5 holds, and the operating point's.
    pub effective_qe: QeSummary,
    /// The effective QE factor of every configuration (written to `effective_qe.csv`/`.json`,
    /// not to `summary.json`).
    #[serde(skip)]
    pub effective_qe_records: Vec<QeRecord>,
    /// The camera model of `--camera` at its operating point; absent without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera: Option<super::camera::CameraSection>,
}
