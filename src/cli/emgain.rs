//! `detnoise emgain`: EM gain, bias, read noise and light level from EMCCD frames.

use std::ops::Bound::{Excluded, Unbounded};
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::args::{real, whole};
use crate::detector::register::MAX_STAGES;
use crate::error::{Error, Result};
use crate::fit::em_signature::require_em_signature;
use crate::fit::emgain::{
    fit_emgain_of_stack, gain_from_mean_ratio, model_curve, CurveBin, EmGainFit, EmGainOptions,
    EmShape, ValueHistogram,
};
use crate::io::FrameStack;
use crate::maps::{read_map, write_json, Map};
use crate::output::{DirPlan, OutputDir};
use crate::plot::{LineChart, Series, SeriesStyle};

/// Options of `detnoise emgain`.
#[derive(clap::Args, Debug)]
pub struct EmgainArgs {
    /// EMCCD dark or low-light frames: FITS/TIFF/EXR files, directories or glob patterns.
    #[arg(required = true)]
    pub stack: Vec<PathBuf>,
    /// Output directory: emgain.json and emgain.png, written only when the fit succeeds; an
    /// existing directory is replaced only if detnoise wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Write into an existing --out that holds other files (they are never replaced or deleted).
    #[arg(long)]
    pub force: bool,
    /// Conversion gain (e per adu): the EM gain is then reported in e-/e-. Default: none (adu/e-).
    #[arg(long, conflicts_with = "gain_map", value_parser = real(Excluded(0.0), Unbounded, "e- per adu"))]
    pub gain_e_per_adu: Option<f64>,
    /// Conversion-gain map (e per adu); its median is used as --gain-e-per-adu. Default: none.
    #[arg(long)]
    pub gain_map: Option<PathBuf>,
    /// Per-pixel bias map (adu), subtracted pixel by pixel (its mean is added back). Default: none.
    #[arg(long)]
    pub offset: Option<PathBuf>,
    /// Read-noise map (adu rms) from no-signal frames at the same gain (needs --offset): bias
    /// and read noise are then held fixed (bias = mean of the offset map, read noise = rms
    /// of this map), which bright frames need because their zero-electron peak is empty.
    /// Default: both fitted.
    #[arg(long, requires = "offset")]
    pub read_noise: Option<PathBuf>,
    /// Model the exact EM register with this many stages, 1 to 2000 (needs the conversion
    /// gain). Default: the Gamma/Erlang model of the paper (Eq. 2).
    #[arg(long, value_parser = whole::<u32>(1, MAX_STAGES as u64, "stages"))]
    pub stages: Option<u32>,
    /// Also fit serial clock-induced charge (electrons born inside the register; needs --stages).
    /// Default: off (parallel CIC is always part of lambda).
    #[arg(long, requires = "stages")]
    pub serial_cic: bool,
    /// Exclude values above this (adu; cosmics, hot pixels). Default: bias + 40 G (1 + lambda + 5 sqrt(lambda)) from the start values.
    #[arg(long, value_parser = real(Unbounded, Unbounded, "adu"))]
    pub max_value_adu: Option<f64>,
    /// Histogram bin width (adu). Default: 1 for integer data without --offset, else 0.25.
    #[arg(long, value_parser = real(Excluded(0.0), Unbounded, "adu"))]
    pub bin_width_adu: Option<f64>,
    /// Frames at unity EM gain under the same light, for the ratio-of-means cross-check. Default: none.
    #[arg(long, num_args = 1..)]
    pub reference_stack: Vec<PathBuf>,
    /// Bias map (adu) of the reference stack (required with --reference-stack).
    #[arg(long)]
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

impl EmgainArgs {
    /// Check the options together before any frame is read (single values are range-checked
    /// while parsing).
    pub fn validate(&self) -> Result<()> {
        if !self.reference_stack.is_empty() && self.reference_offset.is_none() {
            return Err(Error::invalid(
                "--reference-offset",
                "the ratio-of-means check of --reference-stack needs the reference stack's bias map",
            ));
        }
        if self.stages.is_some() && self.gain_e_per_adu.is_none() && self.gain_map.is_none() {
            return Err(Error::invalid(
                "--stages",
                "the exact register model needs the conversion gain (--gain-e-per-adu or --gain-map)",
            ));
        }
        if self.reference_stack.is_empty() && self.reference_offset.is_some() {
            return Err(Error::invalid(
                "--reference-offset",
                "applies only with --reference-stack",
            ));
        }
        Ok(())
    }
}

/// Run `detnoise emgain`.
pub fn run(args: &EmgainArgs) -> Result<()> {
    args.validate()?;
    let inputs: Vec<PathBuf> = args
        .stack
        .iter()
        .chain(&args.reference_stack)
        .chain(&args.gain_map)
        .chain(&args.offset)
        .chain(&args.read_noise)
        .chain(&args.reference_offset)
        .cloned()
        .collect();
    let dir = OutputDir::prepare(
        &args.out,
        DirPlan {
            command: "emgain",
            force: args.force,
            inputs: &inputs,
            names: &["emgain.json", "emgain.png"],
        },
    )?;
    let conv = match (&args.gain_map, args.gain_e_per_adu) {
        (Some(p), _) => Some(median_of_map(p)?),
        (None, g) => g,
    };
    let shape = match args.stages {
        Some(stages) => EmShape::Register { stages },
        None => EmShape::Gamma,
    };
    let stack = FrameStack::open(&args.stack)?;
    if args.read_noise.is_none() {
        // Without a known bias the fit needs the register's tail: refuse in seconds if absent.
        require_em_signature(&stack)?;
    }
    let (hist, mean) = accumulate(&stack, args.offset.as_deref(), args.bin_width_adu)?;
    let (fixed_bias_adu, fixed_read_noise_adu) = match (&args.read_noise, &args.offset) {
        (Some(rn), Some(off)) => {
            let r = read_map(rn)?;
            let ms = map_mean(&Map::new(
                r.rows,
                r.cols,
                r.data.iter().map(|v| v * v).collect(),
            ));
            (Some(map_mean(&read_map(off)?)), Some(ms.sqrt()))
        }
        _ => (None, None),
    };
    let opts = EmGainOptions {
        shape,
        gain_e_per_adu: conv,
        max_value_adu: args.max_value_adu,
        fixed_bias_adu,
        fixed_read_noise_adu,
        serial_cic: args.serial_cic,
    };
    let fit = fit_emgain_of_stack(&stack, &hist, &opts)?;
    let ratio_check = if args.reference_stack.is_empty() {
        None
    } else {
        let off = args.reference_offset.as_deref().ok_or_else(|| {
            Error::invalid(
                "--reference-offset",
                "the ratio-of-means check needs the reference stack's bias map",
            )
        })?;
        let rstack = FrameStack::open(&args.reference_stack)?;
        let (_, rmean) = accumulate(&rstack, Some(off), args.bin_width_adu)?;
        let rbias = map_mean(&read_map(off)?);
        let signal = mean - fit.bias_adu;
        Some(RatioCheck {
            reference_stack: paths(&rstack),
            reference_signal_adu: rmean - rbias,
            signal_adu: signal,
            em_gain_ratio: gain_from_mean_ratio(signal, rmean - rbias),
        })
    };
    chart(&hist, &fit, &dir.path("emgain.png"))?;
    let report = EmgainReport {
        tool: format!("detnoise {}", env!("CARGO_PKG_VERSION")),
        stack: paths(&stack),
        frames: stack.frames,
        shape: [stack.shape.0, stack.shape.1],
        offset_map: args.offset.as_ref().map(|p| p.display().to_string()),
        fit,
        ratio_check,
    };
    write_json(&dir.path("emgain.json"), &report)?;
    dir.commit()?;
    print_summary(&report);
    Ok(())
}

fn paths(stack: &FrameStack) -> Vec<String> {
    stack
        .paths()
        .iter()
        .map(|p| p.display().to_string())
        .collect()
}

fn map_mean(m: &Map) -> f64 {
    let v: Vec<f64> = m.data.iter().copied().filter(|v| v.is_finite()).collect();
    v.iter().sum::<f64>() / v.len() as f64
}

fn median_of_map(path: &Path) -> Result<f64> {
    let m = read_map(path)?;
    let mut v: Vec<f64> = m
        .data
        .into_iter()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if v.is_empty() {
        return Err(Error::input(
            path,
            "frame 0: no positive finite conversion gain",
        ));
    }
    v.sort_by(f64::total_cmp);
    Ok(v[v.len() / 2])
}

/// Histogram of every pixel-sample (adu), bias-map subtracted if given, one frame at a
/// time; also the mean value (adu). Errors name the file of the frame at fault.
pub fn accumulate(
    stack: &FrameStack,
    offset: Option<&Path>,
    width: Option<f64>,
) -> Result<(ValueHistogram, f64)> {
    let off = match offset {
        Some(p) => {
            let m = read_map(p)?;
            if (m.rows, m.cols) != stack.shape {
                return Err(Error::input(
                    p,
                    format!(
                        "frame 0: bias map {}x{} differs from the stack's {}x{}",
                        m.rows, m.cols, stack.shape.0, stack.shape.1
                    ),
                ));
            }
            // Every pixel needs a bias: a NaN would make its samples NaN, blamed on the stack.
            if let Some(i) = m.data.iter().position(|v| !v.is_finite()) {
                return Err(Error::input(
                    p,
                    format!(
                        "frame 0: bias map value {} at row {}, column {}: every pixel needs a finite bias",
                        m.data[i],
                        i / m.cols,
                        i % m.cols
                    ),
                ));
            }
            let mean = map_mean(&m);
            Some(m.data.iter().map(|v| v - mean).collect::<Vec<f64>>())
        }
        None => None,
    };
    let width = match width {
        Some(w) if w > 0.0 && w.is_finite() => w,
        Some(_) => return Err(Error::invalid("--bin-width-adu", "must be finite and > 0")),
        None if off.is_none() && !stack.sample_type.is_float() => 1.0,
        None => 0.25,
    };
    let mut hist = ValueHistogram::new(width);
    let mut frame = vec![0.0; stack.pixels()];
    let mut reader = stack.reader();
    while let Some(i) = reader.next_frame(&mut frame)? {
        if let Some(off) = &off {
            frame.iter_mut().zip(off).for_each(|(v, o)| *v -= o);
        }
        hist.add_all(&frame)
            .map_err(|e| Error::input(stack.source_of(i), format!("stack frame {i}: {e}")))?;
    }
    let (mean, _) = hist.mean_var();
    Ok((hist, mean))
}

/// Histogram (log y) with the fitted model and its components.
pub(crate) fn chart(h: &ValueHistogram, fit: &EmGainFit, path: &Path) -> Result<()> {
    let curve = model_curve(h, fit, 160);
    let width = curve.get(1).map_or(h.width(), |c| c.x_adu - curve[0].x_adu);
    let mut c = LineChart::new(
        format!(
            "EM gain {:.2} +- {:.2} {}, read noise {:.2} adu, lambda {:.3} e-",
            fit.em_gain, fit.em_gain_se, fit.em_gain_units, fit.read_noise_adu, fit.lambda_e
        ),
        "pixel value (adu)",
        format!("pixel-samples per {width:.3} adu bin"),
    );
    c.log_y = true;
    let pts = |f: fn(&CurveBin) -> f64| {
        curve
            .iter()
            .map(move |c| (c.x_adu, f(c)))
            .collect::<Vec<_>>()
    };
    c.series = vec![
        Series::new("data", pts(|c| c.data)).styled(SeriesStyle::Markers),
        Series::new("model", pts(|c| c.model)).styled(SeriesStyle::Line),
        Series::new("no input electron", pts(|c| c.zero_electron)).styled(SeriesStyle::Line),
        Series::new(">= 1 input electron", pts(|c| c.model - c.zero_electron))
            .styled(SeriesStyle::Line),
    ];
    let ymin = 0.3;
    let ymax = curve
        .iter()
        .map(|c| c.data.max(c.model))
        .fold(1.0, f64::max)
        * 2.0;
    c.y_range = Some((ymin, ymax));
    c.save(path)
}

fn print_summary(r: &EmgainReport) {
    let f = &r.fit;
    println!(
        "{} frames of {}x{}: {} pixel-samples fitted ({} excluded above {:.0} adu)",
        r.frames, r.shape[0], r.shape[1], f.n_samples, f.n_excluded, f.max_value_adu
    );
    println!(
        "em_gain        {:.4} +- {:.4} {}",
        f.em_gain, f.em_gain_se, f.em_gain_units
    );
    println!(
        "gain           {:.4} +- {:.4} adu/e-",
        f.gain_adu_per_e, f.gain_adu_per_e_se
    );
    println!(
        "bias           {:.3} +- {:.3} adu",
        f.bias_adu, f.bias_adu_se
    );
    println!(
        "read noise     {:.3} +- {:.3} adu",
        f.read_noise_adu, f.read_noise_adu_se
    );
    println!(
        "lambda         {:.5} +- {:.5} e-/pixel",
        f.lambda_e, f.lambda_e_se
    );
    if let (Some(c), Some(se)) = (f.serial_cic_e, f.serial_cic_e_se) {
        println!("serial CIC     {c:.5} +- {se:.5} e-/pixel");
    }
    let cc = &f.cross_checks;
    println!(
        "cross-check: mean-variance / F^2 ({:.3}) = {:.4} adu/e- (without F^2: {:.4})",
        cc.excess_noise_factor_sq,
        cc.mean_variance_gain_adu_per_e,
        cc.mean_variance_gain_no_enf_adu_per_e
    );
    if let Some(rc) = &r.ratio_check {
        println!(
            "cross-check: ratio of mean signals to the unity-gain reference = {:.4} e-/e-",
            rc.em_gain_ratio
        );
    }
}
