//! The outputs of `detnoise campaign`: `conditions.csv` (one row per stack, units in every
//! column name) and `campaign.json` (the design, every stack's condition, noise split, EM fit
//! and input checksums, and each EM gain's CIC from the histogram fits: the intercept of the
//! mean charge against exposure time, from the fits' lambdas and from the zero peaks').

use std::path::Path;

use serde::Serialize;

use super::checks::Design;
use super::condition::{Condition, StackKind};
use super::measure::StackMeasurement;
use crate::calib::darks::TemporalNoiseSummary;
use crate::calib::summary::InputFile;
use crate::error::Result;
use crate::fit::emgain::EmGainFit;
use crate::output::{render, write_atomic, write_json, TableFormat};

/// The files `campaign` writes.
pub const CAMPAIGN_OUTPUTS: [&str; 2] = ["conditions.csv", "campaign.json"];

/// The camera model's folder inside the campaign's output.
pub const CAMERA_DIR: &str = "camera";

/// The EMVA 1288 datasheet's folder inside the campaign's output (an EMVA 1288 input only).
pub const DATASHEET_DIR: &str = "datasheet";

/// Every file `campaign` may write: its own and the decomposition's.
pub fn campaign_output_names() -> Vec<&'static str> {
    let mut names = CAMPAIGN_OUTPUTS.to_vec();
    names.extend(super::fit::OUTPUT_NAMES);
    names.push(CAMERA_DIR);
    names.push(DATASHEET_DIR);
    names
}

/// One row of conditions.csv: a stack, its condition and its noise (adu), with SEs.
#[derive(Clone, Debug, Serialize)]
pub struct ConditionRow {
    /// The stack's first file.
    pub file: String,
    /// dark or flat.
    pub kind: StackKind,
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Commanded EM gain (e-/e-), empty without one.
    pub em_gain: Option<f64>,
    /// Temperature (deg C), empty when not given.
    pub temperature_c: Option<f64>,
    /// Light level of a flat (the input's unit), empty for darks.
    pub light_level: Option<f64>,
    /// Frames read.
    pub frames: usize,
    /// Mean over pixels of the per-pixel mean (adu).
    pub mean_adu: f64,
    /// Total temporal noise: sqrt of the mean per-pixel variance (adu).
    pub total_rms_adu: Option<f64>,
    /// Its SE (adu).
    pub total_rms_se_adu: Option<f64>,
    /// Pixel component (adu).
    pub pixel_rms_adu: Option<f64>,
    /// Its SE (adu).
    pub pixel_rms_se_adu: Option<f64>,
    /// Row component (adu).
    pub row_rms_adu: Option<f64>,
    /// Its SE (adu).
    pub row_rms_se_adu: Option<f64>,
    /// Column component (adu).
    pub column_rms_adu: Option<f64>,
    /// Its SE (adu).
    pub column_rms_se_adu: Option<f64>,
    /// Frame component (adu).
    pub frame_rms_adu: Option<f64>,
    /// Its SE (adu).
    pub frame_rms_se_adu: Option<f64>,
    /// EM gain fitted to the histogram of an EMCCD dark (e-/e-).
    pub em_fit_gain_e_per_e: Option<f64>,
    /// Its SE (e-/e-).
    pub em_fit_gain_se_e_per_e: Option<f64>,
    /// Input electrons per pixel per frame in the fit (e-; CIC and dark current of a dark).
    pub em_fit_lambda_e_per_pixel: Option<f64>,
    /// Its SE (e-).
    pub em_fit_lambda_se_e_per_pixel: Option<f64>,
    /// Serial (in-register) CIC of the fit, events per pixel; empty when the model
    /// comparison found none.
    pub em_fit_serial_cic_e_per_pixel: Option<f64>,
    /// Its SE (events per pixel).
    pub em_fit_serial_cic_se_e_per_pixel: Option<f64>,
    /// The fit's read noise (adu).
    pub em_fit_read_noise_adu: Option<f64>,
    /// Input electrons per pixel per frame from the zero-electron peak alone (e-).
    pub em_fit_zero_peak_lambda_e_per_pixel: Option<f64>,
    /// Its SE (e-; binomial, an upper bound).
    pub em_fit_zero_peak_lambda_se_e_per_pixel: Option<f64>,
    /// CIC at this stack's EM gain: intercept at t = 0 of the fits' lambda against exposure
    /// time over the gain's darks (e- per pixel per frame).
    pub em_cic_from_fit_e_per_frame: Option<f64>,
    /// Its SE (e-).
    pub em_cic_from_fit_se_e_per_frame: Option<f64>,
    /// The same from the zero-peak lambdas (e- per pixel per frame).
    pub em_cic_from_zero_peak_e_per_frame: Option<f64>,
    /// Its SE (e-).
    pub em_cic_from_zero_peak_se_e_per_frame: Option<f64>,
    /// Why the EM fit failed, empty when it did not.
    pub em_fit_error: Option<String>,
}

impl ConditionRow {
    /// The row of `m`.
    pub fn of(m: &StackMeasurement) -> ConditionRow {
        let s = &m.stats;
        let c = &s.condition;
        let t = &s.temporal;
        let fit = m.em_fit.as_ref().and_then(|f| f.as_ref().ok());
        let zero = fit.and_then(|f| f.zero_peak.as_ref());
        let n = s.mean_adu.iter().filter(|v| v.is_finite()).count().max(1);
        ConditionRow {
            file: s.file.display().to_string(),
            kind: c.kind,
            exposure_s: c.exposure_s,
            em_gain: c.em_gain,
            temperature_c: c.temperature_c,
            light_level: c.light_level,
            frames: s.frames,
            mean_adu: s.mean_adu.iter().filter(|v| v.is_finite()).sum::<f64>() / n as f64,
            total_rms_adu: t.total_rms_adu,
            total_rms_se_adu: t.total_rms_se_adu,
            pixel_rms_adu: t.pixel_rms_adu,
            pixel_rms_se_adu: t.pixel_rms_se_adu,
            row_rms_adu: t.row_rms_adu,
            row_rms_se_adu: t.row_rms_se_adu,
            column_rms_adu: t.column_rms_adu,
            column_rms_se_adu: t.column_rms_se_adu,
            frame_rms_adu: t.frame_rms_adu,
            frame_rms_se_adu: t.frame_rms_se_adu,
            em_fit_gain_e_per_e: fit.map(|f| f.em_gain),
            em_fit_gain_se_e_per_e: fit.map(|f| f.em_gain_se),
            em_fit_lambda_e_per_pixel: fit.map(|f| f.lambda_e),
            em_fit_lambda_se_e_per_pixel: fit.map(|f| f.lambda_e_se),
            em_fit_serial_cic_e_per_pixel: fit.and_then(|f| f.serial_cic_e),
            em_fit_serial_cic_se_e_per_pixel: fit.and_then(|f| f.serial_cic_e_se),
            em_fit_read_noise_adu: fit.map(|f| f.read_noise_adu),
            em_fit_zero_peak_lambda_e_per_pixel: zero.map(|z| z.lambda_e),
            em_fit_zero_peak_lambda_se_e_per_pixel: zero.map(|z| z.lambda_e_se),
            em_cic_from_fit_e_per_frame: None,
            em_cic_from_fit_se_e_per_frame: None,
            em_cic_from_zero_peak_e_per_frame: None,
            em_cic_from_zero_peak_se_e_per_frame: None,
            em_fit_error: m.em_fit.as_ref().and_then(|f| f.as_ref().err().cloned()),
        }
    }
}

/// One stack in campaign.json.
#[derive(Clone, Debug, Serialize)]
pub struct StackSummary {
    /// Its files, in frame order.
    pub files: Vec<String>,
    /// Its condition as the input gave it.
    pub condition: Condition,
    /// Frames read.
    pub frames: usize,
    /// Mean over pixels of the per-pixel mean (adu).
    pub mean_adu: f64,
    /// The temporal noise split (adu and e-, with SEs).
    pub temporal_noise: TemporalNoiseSummary,
    /// The EM-gain histogram fit of an EMCCD dark (null otherwise or when it failed).
    pub em_fit: Option<EmGainFit>,
    /// Why the EM fit failed (null when it did not).
    pub em_fit_error: Option<String>,
    /// Its files with their checksums.
    pub inputs: Vec<InputFile>,
}

/// The content of campaign.json.
#[derive(Clone, Debug, Serialize)]
pub struct CampaignSummary {
    /// The command that wrote it.
    pub command: &'static str,
    /// detnoise's version.
    pub version: &'static str,
    /// The input the stacks came from: `manifest`, `emva1288` or `keywords`.
    pub input: &'static str,
    /// The manifest or descriptor file (null for keyword input).
    pub listing: Option<String>,
    /// Conversion gain used (e- per adu).
    pub gain_e_per_adu: f64,
    /// Frame shape (rows, cols).
    pub shape: [usize; 2],
    /// What the darks' conditions separate.
    pub design: Design,
    /// Every stack, in input order.
    pub stacks: Vec<StackSummary>,
    /// The per-pixel decomposition of the dark signal (null until it is computed).
    pub decomposition: Option<serde_json::Value>,
}

impl StackSummary {
    /// The summary of `m`.
    pub fn of(m: &StackMeasurement, files: &[std::path::PathBuf]) -> StackSummary {
        let row = ConditionRow::of(m);
        StackSummary {
            files: files.iter().map(|f| f.display().to_string()).collect(),
            condition: m.stats.condition,
            frames: m.stats.frames,
            mean_adu: row.mean_adu,
            temporal_noise: m.stats.temporal.clone(),
            em_fit: m.em_fit.as_ref().and_then(|f| f.as_ref().ok().cloned()),
            em_fit_error: row.em_fit_error,
            inputs: m.inputs.clone(),
        }
    }
}

/// Mean charge against exposure time at one EM gain: lambda = CIC + t D, a weighted straight
/// line through its darks' lambdas (e- per pixel per frame, the mean of the kept pixels).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ChargeLine {
    /// Intercept: clock-induced charge (e- per pixel per frame).
    pub cic_e_per_frame: f64,
    /// Its SE (e-).
    pub cic_se_e_per_frame: f64,
    /// Slope: dark current (e-/s).
    pub dark_current_e_per_s: f64,
    /// Its SE (e-/s).
    pub dark_current_se_e_per_s: f64,
    /// Chi-square of the line about the lambdas (their SEs).
    pub chi2: f64,
    /// Its degrees of freedom (darks - 2).
    pub degrees_of_freedom: usize,
}

impl ChargeLine {
    /// The weighted least-squares line through (t s, lambda e-, SE e-); None with fewer than
    /// two distinct times or a SE that is not positive.
    pub fn fit(points: &[(f64, f64, f64)]) -> Option<ChargeLine> {
        if points.iter().any(|p| !(p.2 > 0.0 && p.2.is_finite())) {
            return None;
        }
        let (mut s, mut sx, mut sxx, mut sy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (t, y, se) in points {
            let w = se.powi(-2);
            s += w;
            sx += w * t;
            sxx += w * t * t;
            sy += w * y;
            sxy += w * t * y;
        }
        let det = s * sxx - sx * sx;
        if points.len() < 2 || det <= 1e-12 * s * sxx {
            return None;
        }
        let a = (sxx * sy - sx * sxy) / det;
        let b = (s * sxy - sx * sy) / det;
        let chi2 = points
            .iter()
            .map(|(t, y, se)| ((y - a - b * t) / se).powi(2))
            .sum();
        Some(ChargeLine {
            cic_e_per_frame: a,
            cic_se_e_per_frame: (sxx / det).sqrt(),
            dark_current_e_per_s: b,
            dark_current_se_e_per_s: (s / det).sqrt(),
            chi2,
            degrees_of_freedom: points.len() - 2,
        })
    }
}

/// The CIC of one EM gain from its darks' histogram fits, by two routes, beside the
/// decomposition's CIC map.
#[derive(Clone, Debug, Serialize)]
pub struct EmGainCic {
    /// Commanded EM gain (e-/e-).
    pub em_gain: f64,
    /// Dark stacks at this gain with a histogram fit.
    pub stacks: usize,
    /// From the fits' lambdas (the EM tail and zero peak together).
    pub from_fit: Option<ChargeLine>,
    /// From the zero-electron peak's lambdas alone.
    pub from_zero_peak: Option<ChargeLine>,
    /// Median of the decomposition's CIC map (e- per pixel per frame), for comparison.
    pub decomposition_cic_median_e_per_frame: Option<f64>,
}

/// The CIC of each EM gain of the darks (in the order first met) from their histogram fits;
/// `cic_median` the decomposition's CIC median.
pub fn em_gain_cic(measurements: &[StackMeasurement], cic_median: Option<f64>) -> Vec<EmGainCic> {
    let mut gains: Vec<f64> = Vec::new();
    for m in measurements {
        let c = &m.stats.condition;
        if let (StackKind::Dark, Some(g), Some(Ok(_))) = (c.kind, c.em_gain, &m.em_fit) {
            if !gains.contains(&g) {
                gains.push(g);
            }
        }
    }
    gains
        .into_iter()
        .map(|g| {
            let fits: Vec<(f64, &EmGainFit)> = measurements
                .iter()
                .filter(|m| {
                    m.stats.condition.kind == StackKind::Dark
                        && m.stats.condition.em_gain == Some(g)
                })
                .filter_map(|m| match &m.em_fit {
                    Some(Ok(f)) => Some((m.stats.condition.exposure_s, f)),
                    _ => None,
                })
                .collect();
            let tail: Vec<_> = fits
                .iter()
                .map(|(t, f)| (*t, f.lambda_e, f.lambda_e_se))
                .collect();
            let zero: Option<Vec<_>> = fits
                .iter()
                .map(|(t, f)| {
                    f.zero_peak
                        .as_ref()
                        .map(|z| (*t, z.lambda_e, z.lambda_e_se))
                })
                .collect();
            EmGainCic {
                em_gain: g,
                stacks: fits.len(),
                from_fit: ChargeLine::fit(&tail),
                from_zero_peak: zero.and_then(|z| ChargeLine::fit(&z)),
                decomposition_cic_median_e_per_frame: cic_median,
            }
        })
        .collect()
}

/// campaign.json: the summary and the CIC of each EM gain (absent without EM fits).
#[derive(Serialize)]
struct CampaignJson<'a> {
    #[serde(flatten)]
    summary: &'a CampaignSummary,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    em_gain_cic: Vec<EmGainCic>,
}

/// Write conditions.csv and campaign.json into `dir`, each atomically.
pub fn write_campaign_outputs(
    dir: &Path,
    measurements: &[StackMeasurement],
    summary: &CampaignSummary,
) -> Result<()> {
    let cic_median = summary
        .decomposition
        .as_ref()
        .and_then(|d| d["cic_e_per_frame"]["median"].as_f64());
    let cic = em_gain_cic(measurements, cic_median);
    let rows: Vec<ConditionRow> = measurements
        .iter()
        .map(|m| {
            let mut row = ConditionRow::of(m);
            let c = &m.stats.condition;
            let line = cic.iter().find(|l| Some(l.em_gain) == c.em_gain);
            if let (StackKind::Dark, Some(l)) = (c.kind, line) {
                row.em_cic_from_fit_e_per_frame = l.from_fit.map(|f| f.cic_e_per_frame);
                row.em_cic_from_fit_se_e_per_frame = l.from_fit.map(|f| f.cic_se_e_per_frame);
                row.em_cic_from_zero_peak_e_per_frame = l.from_zero_peak.map(|f| f.cic_e_per_frame);
                row.em_cic_from_zero_peak_se_e_per_frame =
                    l.from_zero_peak.map(|f| f.cic_se_e_per_frame);
            }
            row
        })
        .collect();
    write_atomic(
        &dir.join(CAMPAIGN_OUTPUTS[0]),
        render(&rows, TableFormat::Csv)?.as_bytes(),
    )?;
    let json = CampaignJson {
        summary,
        em_gain_cic: cic,
    };
    write_json(&dir.join(CAMPAIGN_OUTPUTS[1]), &json)
}
