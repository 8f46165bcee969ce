//! The photon-transfer analysis: conversion gain (e per adu) from flat stacks at several
//! light levels.
//!
//! For each level and pixel, the dark-subtracted mean m = mean(flat) - offset and the
//! dark-subtracted variance v = var(flat) - var(dark) obey v = m F^2 g / K for a camera of
//! conversion gain K (e/adu), EM gain g and excess noise factor F^2 (both 1 for sCMOS and
//! for an EMCCD at unit EM gain). The global K comes from a weighted straight-line fit of the
//! pixel-averaged (m, v) over levels; the per-pixel K (Huang et al. 2013) from each pixel's
//! own points, as the inverse-variance weighted mean of v/m over levels.
//!
//! Lamp flicker (a common multiplicative change of a frame's level) would add m^2 f^2 to
//! every variance. With flicker removal each frame is divided by its own mean signal and
//! rescaled to the stack's mean signal; this also removes 1/P of each pixel's own variance
//! (P pixels), which is restored by the factor P/(P-1). Samples at the stored type's largest
//! value (or `saturation_adu`) mask that pixel at that level.
//!
//! A stack whose frames' mean signals fall into several well-separated light levels (a glob
//! over a whole series) is split into those levels ([`light_levels`]); levels that do not
//! separate cleanly are an error listing them.

use serde::Serialize;

use super::excess::{level_ratio, ExcessNoise, ExcessVerdict};
use super::levels::{clean, describe_levels, light_levels};
use crate::calib::darks::{pixel_stats_of, Clip, FrameHook, PixelStats};
use crate::calib::{Map, Unit};
use crate::error::{Error, Result};
use crate::io::FrameStack;
use crate::stats::{mean_var, median};

/// Dark reference: per-pixel offset (adu) and variance (adu^2) with the frames behind it.
#[derive(Clone, Debug)]
pub struct DarkReference {
    /// Offset per pixel (adu).
    pub offset_adu: Map,
    /// Read-noise variance per pixel (adu^2).
    pub var_adu2: Vec<f64>,
    /// Frames the dark maps came from (None when given as maps of unknown depth).
    pub frames: Option<usize>,
}

impl DarkReference {
    /// From the statistics of a dark stack.
    pub fn from_stats(s: &PixelStats) -> DarkReference {
        DarkReference {
            offset_adu: s.mean.clone(),
            var_adu2: s.rms.data.iter().map(|r| r * r).collect(),
            frames: Some(s.frames),
        }
    }

    /// From an offset map and a read-noise map (adu).
    pub fn from_maps(offset: Map, rms: &Map) -> DarkReference {
        DarkReference {
            offset_adu: offset,
            var_adu2: rms.data.iter().map(|r| r * r).collect(),
            frames: None,
        }
    }
}

/// Options of the photon-transfer analysis.
#[derive(Clone, Debug, Serialize)]
pub struct PtcOptions {
    /// Remove lamp flicker by normalising each frame to the stack's mean signal.
    pub flicker: bool,
    /// Saturation level (adu); default: the largest value of the stored integer type.
    pub saturation_adu: Option<f64>,
    /// EM gain g (1 for sCMOS and conventional CCD readout).
    pub em_gain: f64,
    /// Excess noise factor F^2 (1 without EM gain, close to 2 at high EM gain).
    pub excess_noise_factor_sq: f64,
}

impl Default for PtcOptions {
    fn default() -> Self {
        PtcOptions {
            flicker: true,
            saturation_adu: None,
            em_gain: 1.0,
            excess_noise_factor_sq: 1.0,
        }
    }
}

/// One light level.
#[derive(Clone, Debug, Serialize)]
pub struct Level {
    /// Frames in the flat stack.
    pub frames: usize,
    /// Pixels used (not saturated, finite).
    pub pixels: usize,
    /// Mean over pixels of the dark-subtracted mean (adu).
    pub mean_adu: f64,
    /// Mean over pixels of the dark-subtracted variance (adu^2).
    pub var_adu2: f64,
    /// Standard error of `var_adu2` (adu^2).
    pub var_err_adu2: f64,
    /// Frame-to-frame rms of the frame mean signal beyond what pixel noise explains,
    /// as a fraction of the mean signal (lamp flicker; 0 when none is seen).
    pub flicker_fraction: f64,
    /// Pixels masked as saturated at this level.
    pub saturated_pixels: usize,
}

/// Result of a photon-transfer analysis.
#[derive(Clone, Debug)]
pub struct PtcResult {
    /// Levels, in the order given.
    pub levels: Vec<Level>,
    /// Global conversion gain (e per adu).
    pub gain_e_per_adu: f64,
    /// Its standard error (e per adu).
    pub gain_err_e_per_adu: f64,
    /// Fitted slope of dark-subtracted variance vs mean (adu): em_gain x F^2 / gain.
    pub slope: f64,
    /// Fitted intercept of variance vs mean (adu^2; near 0 after dark subtraction).
    pub intercept_adu2: f64,
    /// Reduced chi-square of the global fit; None with 1 or 2 levels (no degrees of freedom:
    /// the straight line cannot be checked against the points).
    pub reduced_chi2: Option<f64>,
    /// The flats' excess-noise signature: whether an EM register amplified them.
    pub excess_noise: ExcessNoise,
    /// Per-pixel conversion gain (e per adu; NaN where no level is usable).
    pub gain_map: Map,
    /// Per-pixel standard error of the gain (e per adu).
    pub gain_err_map: Map,
    /// Per-pixel read noise (e-): dark rms (adu) x per-pixel gain.
    pub read_noise_e_map: Map,
    /// Median dark read noise (adu) x global gain (e-).
    pub read_noise_e_median: f64,
    /// What was done to the input beyond the plain analysis (stacks split into light levels).
    pub notes: Vec<String>,
    /// Results to distrust: EM gain missing or not seen, a fit that cannot be checked.
    pub warnings: Vec<String>,
}

/// Statistics of one flat stack with optional flicker removal, relative to `dark`, with each
/// frame's mean signal above the dark (adu).
pub fn flat_stats(
    stack: &FrameStack,
    dark: &DarkReference,
    opts: &PtcOptions,
) -> Result<(PixelStats, Vec<f64>)> {
    flat_stats_of(stack, dark, opts, None)
}

/// As [`flat_stats`] for the frames flagged in `select` (one flag per frame; all when None).
pub fn flat_stats_of(
    stack: &FrameStack,
    dark: &DarkReference,
    opts: &PtcOptions,
    select: Option<&[bool]>,
) -> Result<(PixelStats, Vec<f64>)> {
    if stack.shape != (dark.offset_adu.rows, dark.offset_adu.cols) {
        return Err(Error::input(
            &stack.sources[0].path,
            format!(
                "frame 0: flat shape {}x{} differs from dark shape {}x{}",
                stack.shape.0, stack.shape.1, dark.offset_adu.rows, dark.offset_adu.cols
            ),
        ));
    }
    let off = &dark.offset_adu.data;
    let mean_signal =
        |f: &[f64]| f.iter().zip(off).map(|(x, o)| x - o).sum::<f64>() / f.len() as f64;
    let normalise = |_k: usize, f: &mut [f64]| {
        let m = mean_signal(f);
        let s = if m > 0.0 { 1.0 / m } else { 1.0 };
        f.iter_mut()
            .zip(off)
            .for_each(|(x, o)| *x = o + (*x - o) * s);
        m
    };
    let record = |_k: usize, f: &mut [f64]| mean_signal(f);
    let hook: FrameHook = if opts.flicker { &normalise } else { &record };
    let mut stats = pixel_stats_of(stack, Clip::None, Some(hook), select)?;
    let frame_means = stats.per_frame.clone();
    if opts.flicker {
        let big_m = frame_means.iter().sum::<f64>() / frame_means.len() as f64;
        if big_m.is_nan() || big_m <= 0.0 {
            return Err(Error::input(
                &stack.sources[0].path,
                "frame 0: flat stack has no signal above the dark offset",
            ));
        }
        let p = stack.pixels() as f64;
        let restore = if p > 1.0 { p / (p - 1.0) } else { 1.0 };
        for (i, m) in stats.mean.data.iter_mut().enumerate() {
            *m = off[i] + (*m - off[i]) * big_m;
        }
        let scale = big_m * restore.sqrt();
        for r in stats
            .rms
            .data
            .iter_mut()
            .chain(stats.rms_even.data.iter_mut())
            .chain(stats.rms_odd.data.iter_mut())
        {
            *r *= scale;
        }
    }
    Ok((stats, frame_means))
}

/// Photon-transfer analysis of `flats` (one stack per light level) against `dark`.
pub fn photon_transfer(
    flats: &[FrameStack],
    dark: &DarkReference,
    opts: &PtcOptions,
) -> Result<PtcResult> {
    if flats.is_empty() {
        return Err(Error::invalid("flats", "need at least one flat stack"));
    }
    let (rows, cols) = (dark.offset_adu.rows, dark.offset_adu.cols);
    let gain_factor = opts.em_gain * opts.excess_noise_factor_sq;
    let (levels, points, ratios, notes) = flat_levels(flats, dark, opts)?;
    let (slope, slope_err, intercept, chi2) = fit_line(&levels)?;
    let excess_noise = ExcessNoise::combine(&ratios);
    if slope.is_nan() || slope <= 0.0 {
        return Err(Error::Numeric(format!(
            "photon transfer slope {slope} adu is not positive: flats brighter than darks?"
        )));
    }
    let gain = gain_factor / slope;
    let gain_err = gain * slope_err / slope;
    let (gain_map, gain_err_map) = pixel_gains(&points, dark, slope, gain_factor);
    let rn: Vec<f64> = (0..rows * cols)
        .map(|i| dark.var_adu2[i].sqrt() * gain_map[i])
        .collect();
    let dark_rms: Vec<f64> = dark.var_adu2.iter().map(|v| v.sqrt()).collect();
    let warnings = warnings(levels.len(), chi2, &excess_noise, opts, gain);
    Ok(PtcResult {
        levels,
        gain_e_per_adu: gain,
        gain_err_e_per_adu: gain_err,
        slope,
        intercept_adu2: intercept,
        reduced_chi2: chi2,
        excess_noise,
        gain_map: Map::new(rows, cols, gain_map, Unit::EPerAdu),
        gain_err_map: Map::new(rows, cols, gain_err_map, Unit::EPerAdu),
        read_noise_e_map: Map::new(rows, cols, rn, Unit::Electrons),
        read_noise_e_median: median(&dark_rms) * gain,
        notes,
        warnings,
    })
}

/// Warnings on a result: flats amplified by an EM register but no `em_gain` given (the gain is
/// then G F^2 too small), `em_gain` given but no register seen, or too few levels to check
/// the fit.
fn warnings(
    levels: usize,
    chi2: Option<f64>,
    excess: &ExcessNoise,
    opts: &PtcOptions,
    gain: f64,
) -> Vec<String> {
    let mut w = Vec::new();
    let r = format!("{:.2} +/- {:.2}", excess.ratio, excess.ratio_se);
    match excess.verdict {
        ExcessVerdict::EmRegister if opts.em_gain == 1.0 => w.push(format!(
            "WARNING: these flats show an EM register's excess noise (third-moment ratio {r}; 1 for plain shot noise, 1.5 for EM-multiplied light) but no --em-gain was given: the conversion gain {gain:.5} e/adu is too small by the EM gain x F^2 (about 200 at G = 100). Give --em-gain G and --excess-noise-factor-sq 2"
        )),
        ExcessVerdict::ShotNoise if opts.em_gain > 1.0 => w.push(format!(
            "WARNING: --em-gain {} was given but these flats show plain shot noise (third-moment ratio {r}; an EM register gives 1.5): the conversion gain is too large by the EM gain x F^2 if the register was off",
            opts.em_gain
        )),
        _ => {}
    }
    if chi2.is_none() {
        w.push(format!(
            "WARNING: {levels} light level(s) leave the photon-transfer fit no degrees of freedom: its reduced chi-square is not available and the straight line cannot be checked (give 3 or more levels)"
        ));
    }
    w
}

/// The light levels of `flats` with their per-pixel points: a stack per level, or a stack
/// whose frames fall into several cleanly separated levels split into them (with a note
/// saying so).
fn flat_levels(
    flats: &[FrameStack],
    dark: &DarkReference,
    opts: &PtcOptions,
) -> Result<FlatLevels> {
    let mut levels = Vec::new();
    // Per level: each pixel's dark-subtracted (mean, variance), NaN where masked; frames.
    let mut points: Vec<LevelPoints> = Vec::new();
    let mut ratios = Vec::new();
    let mut notes = Vec::new();
    for stack in flats {
        stack.require_frames(2, "a flat variance")?;
        let (stats, frame_means) = flat_stats(stack, dark, opts)?;
        let groups = light_levels(&frame_means);
        if groups.len() == 1 {
            let (level, p) = level_of(stack, &stats, &frame_means, dark, opts)?;
            ratios.push(third_moment(
                stack,
                None,
                &stats,
                &frame_means,
                dark,
                opts,
                &level,
                &p,
            )?);
            levels.push(level);
            points.push(p);
            continue;
        }
        // Frames at several light levels in one stack: one level per group, when clean.
        let path = &stack.sources[0].path;
        let listing = describe_levels(stack, &groups);
        if !clean(&groups) {
            return Err(Error::input(
                path,
                format!(
                    "the frames' mean signals fall into {} light levels that are not cleanly separated ({listing}): each level needs at least 2 frames, a mean signal above the dark, and a gap to its neighbours more than twice its own spread. Give one --flats per light level",
                    groups.len()
                ),
            ));
        }
        for g in &groups {
            let mut select = vec![false; stack.frames];
            g.frames.iter().for_each(|k| select[*k] = true);
            let (stats, means) = flat_stats_of(stack, dark, opts, Some(&select))?;
            let (level, p) = level_of(stack, &stats, &means, dark, opts)?;
            ratios.push(third_moment(
                stack,
                Some(&select),
                &stats,
                &means,
                dark,
                opts,
                &level,
                &p,
            )?);
            levels.push(level);
            points.push(p);
        }
        notes.push(format!(
            "{}: split {} frames into {} light levels ({listing})",
            path.display(),
            stack.frames,
            groups.len()
        ));
    }
    Ok((levels, points, ratios, notes))
}

/// The excess-noise ratio (and its SE) of one level: its frames read again, flicker removed
/// as for the variances, centred on each pixel's mean.
#[allow(clippy::too_many_arguments)]
fn third_moment(
    stack: &FrameStack,
    select: Option<&[bool]>,
    stats: &PixelStats,
    frame_means: &[f64],
    dark: &DarkReference,
    opts: &PtcOptions,
    level: &Level,
    (pm, _, _): &LevelPoints,
) -> Result<(f64, f64)> {
    let big_m = frame_means.iter().sum::<f64>() / frame_means.len() as f64;
    let scale: Vec<f64> = frame_means
        .iter()
        .map(|m| {
            if opts.flicker && *m > 0.0 {
                big_m / m
            } else {
                1.0
            }
        })
        .collect();
    let usable: Vec<bool> = pm.iter().map(|m| m.is_finite()).collect();
    level_ratio(
        stack,
        select,
        &scale,
        &dark.offset_adu.data,
        &stats.mean.data,
        &usable,
        (level.mean_adu, level.var_adu2),
    )
}

/// Per-pixel conversion gain and its standard error (e per adu; NaN where no level counts).
///
/// Huang et al. 2013: the inverse-variance weighted mean of r = v/m over levels. The weights
/// use the variance the global fit (`slope`) predicts, not the pixel's own noisy estimate,
/// which would favour low variance draws and bias r low. A sample variance has standard
/// error var * sqrt(2 / (n - 1)) (Gaussian approximation).
fn pixel_gains(
    points: &[LevelPoints],
    dark: &DarkReference,
    slope: f64,
    gain_factor: f64,
) -> (Vec<f64>, Vec<f64>) {
    let npix = dark.offset_adu.rows * dark.offset_adu.cols;
    let mut gain_map = vec![f64::NAN; npix];
    let mut gain_err_map = vec![f64::NAN; npix];
    for i in 0..npix {
        let (mut sw, mut swr) = (0.0, 0.0);
        for (pm, pv, n) in points {
            let (m, v) = (pm[i], pv[i]);
            let expected = dark.var_adu2[i] + slope * m;
            if m > 0.0 && expected > 0.0 && v.is_finite() {
                let w = (m / (expected * (2.0 / (n - 1.0)).sqrt())).powi(2);
                sw += w;
                swr += w * v / m;
            }
        }
        if sw > 0.0 && swr > 0.0 {
            let r = swr / sw;
            gain_map[i] = gain_factor / r;
            gain_err_map[i] = gain_map[i] / (r * sw.sqrt());
        }
    }
    (gain_map, gain_err_map)
}

/// Levels, their per-pixel points, their excess-noise ratios (R, SE) and notes.
type FlatLevels = (Vec<Level>, Vec<LevelPoints>, Vec<(f64, f64)>, Vec<String>);

/// One level's pixels: dark-subtracted mean (adu) and variance (adu^2), NaN where masked,
/// and the frame count.
type LevelPoints = (Vec<f64>, Vec<f64>, f64);

/// The level summary and per-pixel points of one flat stack (or selection of its frames).
fn level_of(
    stack: &FrameStack,
    stats: &PixelStats,
    frame_means: &[f64],
    dark: &DarkReference,
    opts: &PtcOptions,
) -> Result<(Level, LevelPoints)> {
    let npix = dark.offset_adu.data.len();
    let sat = opts.saturation_adu.or(stack.saturation_value());
    let n = stats.frames as f64;
    let (mut ms, mut vs, mut tot, mut used, mut saturated) = (0.0, 0.0, 0.0, 0usize, 0usize);
    let (mut pm, mut pv) = (vec![f64::NAN; npix], vec![f64::NAN; npix]);
    for i in 0..npix {
        if sat.is_some_and(|s| stats.max[i] >= s) {
            saturated += 1;
            continue;
        }
        let m = stats.mean.data[i] - dark.offset_adu.data[i];
        let vt = stats.rms.data[i].powi(2);
        let v = vt - dark.var_adu2[i];
        if !(m.is_finite() && v.is_finite()) {
            continue;
        }
        ms += m;
        vs += v;
        tot += vt;
        used += 1;
        pm[i] = m;
        pv[i] = v;
    }
    if used == 0 {
        return Err(Error::input(
            &stack.sources[0].path,
            "frame 0: every pixel is saturated or invalid at this level",
        ));
    }
    let u = used as f64;
    let (mean_adu, var_adu2) = (ms / u, vs / u);
    // Averaging `used` independent sample variances divides their error by sqrt(used).
    let var_err_adu2 = (tot / u) * (2.0 / (n - 1.0)).sqrt() / u.sqrt();
    let big_m = frame_means.iter().sum::<f64>() / frame_means.len() as f64;
    let expected = (tot / u) / npix as f64;
    let excess = mean_var(frame_means).1 - expected;
    let flicker_fraction = if big_m > 0.0 && excess > 0.0 {
        excess.sqrt() / big_m
    } else {
        0.0
    };
    let level = Level {
        frames: stats.frames,
        pixels: used,
        mean_adu,
        var_adu2,
        var_err_adu2,
        flicker_fraction,
        saturated_pixels: saturated,
    };
    Ok((level, (pm, pv, n)))
}

/// Weighted fit v = a + b m over levels: (b, se(b), a, reduced chi2). One level: a = 0.
/// The reduced chi2 is None without degrees of freedom (1 or 2 levels).
fn fit_line(levels: &[Level]) -> Result<(f64, f64, f64, Option<f64>)> {
    let w: Vec<f64> = levels
        .iter()
        .map(|l| 1.0 / l.var_err_adu2.powi(2))
        .collect();
    if levels.len() == 1 {
        let l = &levels[0];
        return Ok((
            l.var_adu2 / l.mean_adu,
            l.var_err_adu2 / l.mean_adu,
            0.0,
            None,
        ));
    }
    let (mut s, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (l, w) in levels.iter().zip(&w) {
        s += w;
        sx += w * l.mean_adu;
        sy += w * l.var_adu2;
        sxx += w * l.mean_adu * l.mean_adu;
        sxy += w * l.mean_adu * l.var_adu2;
    }
    let det = s * sxx - sx * sx;
    if det.is_nan() || det <= 0.0 {
        return Err(Error::Numeric(
            "photon transfer fit is singular: the flat levels have equal means".into(),
        ));
    }
    let b = (s * sxy - sx * sy) / det;
    let a = (sxx * sy - sx * sxy) / det;
    let mut se_b = (s / det).sqrt();
    let chi2: f64 = levels
        .iter()
        .zip(&w)
        .map(|(l, w)| w * (l.var_adu2 - a - b * l.mean_adu).powi(2))
        .sum();
    let dof = levels.len() as f64 - 2.0;
    let red = (dof > 0.0).then(|| chi2 / dof);
    // Scatter beyond the stated errors (nonlinearity, residual flicker) widens the error.
    if let Some(r) = red.filter(|r| *r > 1.0) {
        se_b *= r.sqrt();
    }
    Ok((b, se_b, a, red))
}
