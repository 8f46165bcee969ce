//! `detnoise emgain` as one library call: EMCCD frames in (with optional bias, read-noise,
//! conversion-gain maps and a unity-gain reference), the fit with its cross-checks written
//! as emgain.json and emgain.png to an output directory that appears only on success.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::chart::chart;
use super::fit::fit_emgain_of_stack;
use super::histogram::ValueHistogram;
use super::options::{EmGainOptions, EmLaw, EmShape, SerialCic, DEFAULT_STAGES};
use super::result::{gain_from_mean_ratio, EmGainFit, SerialCicTest};
use super::signature::require_em_signature;
use super::stack::accumulate;
use crate::calib::{Map, Unit};
use crate::error::{Error, Result};
use crate::io::FrameStack;
use crate::output::{DirPlan, OutputDir};
use crate::stats::{finite_mean, median};

/// An EM-gain fit to run.
#[derive(Clone, Debug, Default)]
pub struct EmgainRun {
    /// EMCCD dark or low-light frames: files, directories or glob patterns.
    pub stack: Vec<PathBuf>,
    /// Output directory: emgain.json and emgain.png (replaced only if detnoise wrote it).
    pub out: PathBuf,
    /// Write into an existing `out` that holds other files (never replacing them).
    pub force: bool,
    /// Conversion gain (e- per adu): the EM gain is then reported in e-/e-.
    pub gain_e_per_adu: Option<f64>,
    /// Conversion-gain map (e- per adu) whose median is used as `gain_e_per_adu`.
    pub gain_map: Option<PathBuf>,
    /// Per-pixel bias map (adu), subtracted pixel by pixel (its mean added back).
    pub offset: Option<PathBuf>,
    /// Read-noise map (adu rms) of no-signal frames at the same gain (needs `offset`): bias
    /// and read noise are then held fixed, as bright frames need.
    pub read_noise: Option<PathBuf>,
    /// Stages of the register (default [`DEFAULT_STAGES`]).
    pub stages: Option<u32>,
    /// Law of the register output; default the exact register when the conversion gain is
    /// known, else the Gamma law with the register's F^2.
    pub law: Option<EmLaw>,
    /// Always model serial clock-induced charge (default: fit with and without, keep the
    /// better by BIC).
    pub serial_cic: bool,
    /// Never model serial clock-induced charge.
    pub no_serial_cic: bool,
    /// Exclude values above this (adu); default from the start values.
    pub max_value_adu: Option<f64>,
    /// Histogram bin width (adu); default 1 for integer data without `offset`, else 0.25.
    pub bin_width_adu: Option<f64>,
    /// Frames at unity EM gain under the same light, for the ratio-of-means cross-check.
    pub reference_stack: Vec<PathBuf>,
    /// Bias map (adu) of the reference stack (required with `reference_stack`).
    pub reference_offset: Option<PathBuf>,
}

/// The ratio-of-means cross-check.
#[derive(Debug, Serialize)]
pub struct RatioCheck {
    /// Reference stack files.
    pub reference_stack: Vec<String>,
    /// Mean signal above bias of the reference (adu).
    pub reference_signal_adu: f64,
    /// Mean signal above the fitted bias of the stack (adu).
    pub signal_adu: f64,
    /// EM gain relative to the reference (e-/e-).
    pub em_gain_ratio: f64,
}

/// Contents of emgain.json: the fit with its inputs and cross-checks.
#[derive(Debug, Serialize)]
pub struct EmgainReport {
    /// Tool and version.
    pub tool: String,
    /// Input files.
    pub stack: Vec<String>,
    /// Frames read.
    pub frames: usize,
    /// Frame shape [rows, cols].
    pub shape: [usize; 2],
    /// Bias map subtracted, if any.
    pub offset_map: Option<String>,
    /// The fit (em_gain, em_gain_se, em_gain_units, bias_adu, read_noise_adu, lambda_e, ...).
    #[serde(flatten)]
    pub fit: EmGainFit,
    /// Ratio of mean signals against a unity-gain reference, if given.
    pub ratio_check: Option<RatioCheck>,
}

/// What an EM-gain run produced.
#[derive(Debug)]
pub struct EmgainRunResult {
    /// The content of emgain.json.
    pub report: EmgainReport,
    /// The output directory written.
    pub out: PathBuf,
}

impl EmgainRun {
    /// Check the settings together before any frame is read.
    pub fn validate(&self) -> Result<()> {
        if !self.reference_stack.is_empty() && self.reference_offset.is_none() {
            return Err(Error::invalid(
                "reference_offset",
                "the ratio-of-means check of `reference_stack` needs the reference stack's bias map",
            ));
        }
        if self.gain_e_per_adu.is_some() && self.gain_map.is_some() {
            return Err(Error::invalid(
                "gain_map",
                "give the conversion gain once: `gain_e_per_adu` or `gain_map`, not both",
            ));
        }
        if self.law == Some(EmLaw::Register)
            && self.gain_e_per_adu.is_none()
            && self.gain_map.is_none()
        {
            return Err(Error::invalid(
                "gain_e_per_adu",
                "the exact register law needs the conversion gain (`gain_e_per_adu` or `gain_map`)",
            ));
        }
        if self.serial_cic && self.no_serial_cic {
            return Err(Error::invalid(
                "serial_cic",
                "serial CIC is either always or never modelled, not both",
            ));
        }
        if self.serial_cic && self.law == Some(EmLaw::Exponential) {
            return Err(Error::invalid(
                "serial_cic",
                "serial CIC has partial gain, modelled only with a register law, not the exponential law",
            ));
        }
        if self.read_noise.is_some() && self.offset.is_none() {
            return Err(Error::invalid(
                "read_noise",
                "holds the bias and read noise fixed: it needs the bias map of the same no-signal frames (`offset`)",
            ));
        }
        if self.reference_stack.is_empty() && self.reference_offset.is_some() {
            return Err(Error::invalid(
                "reference_offset",
                "applies only with `reference_stack`",
            ));
        }
        Ok(())
    }

    /// Every file the run reads (for the output-directory checks).
    fn inputs(&self) -> Vec<PathBuf> {
        self.stack
            .iter()
            .chain(&self.reference_stack)
            .chain(&self.gain_map)
            .chain(&self.offset)
            .chain(&self.read_noise)
            .chain(&self.reference_offset)
            .cloned()
            .collect()
    }
}

/// The conversion gain (e- per adu) as the median of the positive finite values of a map.
fn median_gain(path: &Path) -> Result<f64> {
    let m = Map::read(path, Unit::EPerAdu)?;
    let v: Vec<f64> = m.data.into_iter().filter(|v| *v > 0.0).collect();
    let g = median(&v);
    if g.is_nan() {
        return Err(Error::input(
            path,
            "frame 0: no positive finite conversion gain",
        ));
    }
    Ok(g)
}

fn paths(stack: &FrameStack) -> Vec<String> {
    stack
        .paths()
        .iter()
        .map(|p| p.display().to_string())
        .collect()
}

/// Run an EM-gain fit and write its outputs.
pub fn run(job: &EmgainRun) -> Result<EmgainRunResult> {
    job.validate()?;
    let dir = OutputDir::prepare(
        &job.out,
        DirPlan {
            command: "emgain",
            force: job.force,
            inputs: &job.inputs(),
            names: &["emgain.json", "emgain.png"],
        },
    )?;
    let (report, hist) = fit_report(job)?;
    chart(&hist, &report.fit, &dir.path("emgain.png"))?;
    crate::output::write_json(&dir.path("emgain.json"), &report)?;
    Ok(EmgainRunResult {
        report,
        out: dir.commit()?,
    })
}

/// The EM-gain fit of `job` without writing anything (its `out` and `force` are not used):
/// the content of emgain.json, and the histogram fitted (for [`chart`]).
pub fn fit_report(job: &EmgainRun) -> Result<(EmgainReport, ValueHistogram)> {
    job.validate()?;
    let conv = match (&job.gain_map, job.gain_e_per_adu) {
        (Some(p), _) => Some(median_gain(p)?),
        (None, g) => g,
    };
    let stages = job.stages.unwrap_or(DEFAULT_STAGES);
    let shape = match job.law {
        Some(law) => law.shape(stages),
        None => EmShape::default_for(conv).with_stages(stages),
    };
    let stack = FrameStack::open(&job.stack)?;
    if job.read_noise.is_none() {
        // Without a known bias the fit needs the register's tail: refuse in seconds if absent.
        require_em_signature(&stack)?;
    }
    let offset = job
        .offset
        .as_ref()
        .map(|p| Map::read(p, Unit::Adu))
        .transpose()?;
    let (hist, mean) = accumulate(&stack, offset.as_ref(), job.bin_width_adu)?;
    let (fixed_bias_adu, fixed_read_noise_adu) = match (&job.read_noise, &offset) {
        (Some(rn), Some(off)) => {
            let r = Map::read(rn, Unit::Adu)?;
            let squares: Vec<f64> = r.data.iter().map(|v| v * v).collect();
            (Some(off.finite_mean()), Some(finite_mean(&squares).sqrt()))
        }
        _ => (None, None),
    };
    let opts = EmGainOptions {
        shape: Some(shape),
        gain_e_per_adu: conv,
        max_value_adu: job.max_value_adu,
        fixed_bias_adu,
        fixed_read_noise_adu,
        serial_cic: match (job.serial_cic, job.no_serial_cic) {
            (true, _) => SerialCic::On,
            (_, true) => SerialCic::Off,
            _ => SerialCic::Auto,
        },
        lambda_mixture: None,
    };
    let fit = fit_emgain_of_stack(&stack, &hist, &opts)?;
    let ratio_check = if job.reference_stack.is_empty() {
        None
    } else {
        let off = job.reference_offset.as_ref().ok_or_else(|| {
            Error::invalid(
                "reference_offset",
                "the ratio-of-means check needs the reference stack's bias map",
            )
        })?;
        let rstack = FrameStack::open(&job.reference_stack)?;
        let roff = Map::read(off, Unit::Adu)?;
        let (_, rmean) = accumulate(&rstack, Some(&roff), job.bin_width_adu)?;
        let rbias = roff.finite_mean();
        let signal = mean - fit.bias_adu;
        Some(RatioCheck {
            reference_stack: paths(&rstack),
            reference_signal_adu: rmean - rbias,
            signal_adu: signal,
            em_gain_ratio: gain_from_mean_ratio(signal, rmean - rbias),
        })
    };
    let report = EmgainReport {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        stack: paths(&stack),
        frames: stack.frames,
        shape: [stack.shape.0, stack.shape.1],
        offset_map: job.offset.as_ref().map(|p| p.display().to_string()),
        fit,
        ratio_check,
    };
    Ok((report, hist))
}

impl EmgainReport {
    /// A plain-text summary of the fit and its cross-checks, one figure per line.
    pub fn summary_text(&self) -> String {
        let f = &self.fit;
        let mut s = format!(
            "{} frames of {}x{}: {} pixel-samples fitted ({} excluded above {:.0} adu)\n",
            self.frames, self.shape[0], self.shape[1], f.n_samples, f.n_excluded, f.max_value_adu
        );
        s += &format!(
            "em_gain        {:.4} +- {:.4} {}\n",
            f.em_gain, f.em_gain_se, f.em_gain_units
        );
        s += &format!(
            "gain           {:.4} +- {:.4} adu/e-\n",
            f.gain_adu_per_e, f.gain_adu_per_e_se
        );
        s += &format!(
            "bias           {:.3} +- {:.3} adu\n",
            f.bias_adu, f.bias_adu_se
        );
        s += &format!(
            "read noise     {:.3} +- {:.3} adu\n",
            f.read_noise_adu, f.read_noise_adu_se
        );
        s += &format!(
            "lambda         {:.5} +- {:.5} e-/pixel\n",
            f.lambda_e, f.lambda_e_se
        );
        if let (Some(c), Some(se)) = (f.serial_cic_e, f.serial_cic_e_se) {
            s += &format!("serial CIC     {c:.5} +- {se:.5} e-/pixel\n");
        }
        s += &format!("law: {}\n", f.law);
        if let Some(t) = &f.serial_cic_test {
            s += &serial_cic_line(t);
        }
        let cc = &f.cross_checks;
        s += &format!(
            "cross-check: mean-variance / F^2 ({:.3}) = {:.4} adu/e- (without F^2: {:.4})\n",
            cc.excess_noise_factor_sq,
            cc.mean_variance_gain_adu_per_e,
            cc.mean_variance_gain_no_enf_adu_per_e
        );
        if let Some(rc) = &self.ratio_check {
            s += &format!(
                "cross-check: ratio of mean signals to the unity-gain reference = {:.4} e-/e-\n",
                rc.em_gain_ratio
            );
        }
        s
    }
}

/// The serial-CIC comparison in one line: the verdict, the figures it rests on.
fn serial_cic_line(t: &SerialCicTest) -> String {
    let verdict = match (t.mode, t.present) {
        (SerialCic::On, _) => "modelled (--serial-cic on)",
        (_, true) => "present",
        (_, false) => "absent",
    };
    let figures = match (t.likelihood_ratio, t.delta_bic, t.serial_cic_e, t.serial_cic_e_se) {
        (Some(lr), Some(db), Some(c), Some(se)) => format!(
            ": likelihood ratio {lr:.1}, BIC without - with {db:+.1} (> 0 favours serial CIC), rate if fitted {c:.5} +- {se:.5} e-/pixel"
        ),
        _ => String::new(),
    };
    let note = t.note.as_ref().map_or(String::new(), |n| format!(" ({n})"));
    format!("serial CIC {verdict}{figures}{note}\n")
}
