//! Spatial non-uniformity of the EMVA 1288 datasheet (release 4.0): DSNU and PRNU with their
//! row, column and pixel parts, spectrograms, profiles, logarithmic and accumulated
//! histograms and defect pixel counts, from the bright (about 50 % of saturation) and dark
//! spatial stacks, each read once (`image`).
//!
//! Numbers follow the standard as the reference implementation (`emva1288` 1.x) computes
//! them (`split` states the formulas). Where this differs on purpose:
//! - The PRNU spectrogram is 100 sqrt(p) / mu (%), the standard's definition; the reference
//!   plots sqrt(p / mu) under a "%" label.
//! - Spectrogram frequencies are k / N cycles per pixel; the reference's `GetFrecs` gives
//!   k / (2 (N/2 + 1)), slightly below (0.485 instead of 0.5 at the last bin of 64 columns).
//! - The histograms' normal model is scaled by the bin width W (the reference: (max-min)/Q).
//! - A part whose variance estimate is negative is `Unavailable` with the bound the image
//!   sets (the reference returns NaN, or takes the root of a negative number for PRNU).
//! - Defect pixels: the standard gives only the histograms (no threshold); the counts here
//!   are pixels beyond a stated number of robust standard deviations, the bright ones after
//!   a 5 x 5 median highpass (the box highpass would count a defect's neighbours too).

mod histogram;
mod image;
mod spectrum;
mod split;
#[cfg(test)]
mod tests;

pub use histogram::{bin1288, highpass, median_highpass, outliers, Binned, Outliers};
pub use image::{read_stack_image, StackImage};
pub use spectrum::{frequencies, line_power, profile, Profile};
pub use split::{split, Parts, VarianceSplit};

use super::dataset::SpatialStack;
use super::quantity::{Quantity, QuantityStatus};
use crate::error::{Error, Result};

/// Size of the standard's highpass filter for the PRNU histograms (pixels).
pub const HIGHPASS_SIZE: usize = 5;

/// The bright stack's signal, as a fraction of the saturation signal (both above dark),
/// inside which it counts as "about 50 % of saturation". The standard gives no tolerance;
/// this window is detnoise's.
pub const SATURATION_WINDOW: (f64, f64) = (0.35, 0.65);

/// Settings of the spatial evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialOptions {
    /// Mean gray value at saturation, mu_y.sat (DN), when known: the bright stack is checked
    /// against [`SATURATION_WINDOW`].
    pub saturation_dn: Option<f64>,
    /// Defect threshold, in robust standard deviations from the median.
    pub defect_factor: f64,
    /// Most bins of a histogram (the standard's Q_max).
    pub histogram_bins: usize,
}

impl Default for SpatialOptions {
    fn default() -> Self {
        SpatialOptions {
            saturation_dn: None,
            defect_factor: 6.0,
            histogram_bins: 256,
        }
    }
}

/// The standard's intermediate variances of one averaged image (DN^2), for comparison with
/// the reference implementation's `s_2_y_measured`, `s_2_y_cav`, `s_2_y_rav`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct VarianceTerms {
    /// mu_y: mean of the averaged image (DN).
    pub mean_dn: Quantity,
    /// sigma^2_y.stack: mean temporal variance of one frame (DN^2).
    pub temporal_var_dn2: Quantity,
    /// s^2_y.measured (DN^2).
    pub measured_dn2: f64,
    /// s^2_y.cav (DN^2).
    pub cav_dn2: f64,
    /// s^2_y.rav (DN^2).
    pub rav_dn2: f64,
    /// s^2_y and its row, column and pixel parts, corrected for temporal noise (DN^2).
    pub parts_dn2: Parts<Quantity>,
}

/// A spectrogram pair (dark and bright) in one direction.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Spectrogram {
    /// Frequency of each bin (cycles per pixel, 0 to 0.5).
    pub frequency_cycles_per_px: Vec<f64>,
    /// Dark image: standard deviation per frequency, sqrt of the power (DN).
    pub dsnu_dn: Vec<f64>,
    /// Bright minus dark image: standard deviation per frequency relative to its mean (%).
    pub prnu_percent: Vec<f64>,
    /// The standard's temporal noise line of the dark plot, sigma_y.stack.dark (DN).
    pub temporal_dark_dn: f64,
    /// The standard's temporal noise line of the bright plot, 100 sigma_y.stack / mu (%).
    pub temporal_bright_percent: f64,
    /// The white floor the dark plot cannot go below, temporal noise left after averaging
    /// L frames, sigma_y.stack.dark / sqrt(L) (DN).
    pub floor_dark_dn: f64,
    /// The same floor of the bright plot (%).
    pub floor_bright_percent: f64,
}

/// A logarithmic histogram (pixels per bin; plotted on a log axis).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Histogram {
    /// Lower edge of each bin: deviation from the mean (DN).
    pub bins_dn: Vec<f64>,
    /// The same, relative to the mean signal above dark (%; PRNU histograms only).
    pub bins_percent: Option<Vec<f64>>,
    /// Pixels per bin.
    pub counts: Vec<u64>,
    /// Pixels per bin of a normal distribution of the same mean and deviation.
    pub model_counts: Vec<f64>,
}

/// An accumulated histogram: the share of pixels deviating from the mean by at least each
/// bin's lower edge.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AccumulatedHistogram {
    /// Lower edge of each bin: absolute deviation from the mean (DN).
    pub bins_dn: Vec<f64>,
    /// The same, relative to the mean signal above dark (%; PRNU histograms only).
    pub bins_percent: Option<Vec<f64>>,
    /// Pixels at or beyond the bin's lower edge (% of pixels).
    pub pixels_percent: Vec<f64>,
}

/// The spatial part of the datasheet.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SpatialResult {
    /// Image rows (M).
    pub rows: usize,
    /// Image columns (N).
    pub cols: usize,
    /// Frames of the bright stack (L).
    pub frames_bright: usize,
    /// Frames of the dark stack.
    pub frames_dark: usize,
    /// The bright stack's signal above dark as a fraction of saturation's (unavailable
    /// without a saturation level).
    pub saturation_fraction: Quantity,
    /// The dark image's variances.
    pub dark: VarianceTerms,
    /// The bright image's variances.
    pub bright: VarianceTerms,
    /// DSNU_1288 and its row, column and pixel parts (DN).
    pub dsnu_dn: Parts<Quantity>,
    /// DSNU_1288 and its parts (e-), through the system gain.
    pub dsnu_e: Parts<Quantity>,
    /// PRNU_1288 and its parts (% of the mean signal above dark).
    pub prnu_percent: Parts<Quantity>,
    /// Horizontal spectrograms (along rows: frequency across columns).
    pub spectrogram_horizontal: Spectrogram,
    /// Vertical spectrograms (along columns: frequency across rows).
    pub spectrogram_vertical: Spectrogram,
    /// Horizontal profile of the dark image (per column).
    pub profile_horizontal_dark: Profile,
    /// Horizontal profile of the bright minus dark image (per column).
    pub profile_horizontal_bright: Profile,
    /// Vertical profile of the dark image (per row).
    pub profile_vertical_dark: Profile,
    /// Vertical profile of the bright minus dark image (per row).
    pub profile_vertical_bright: Profile,
    /// Logarithmic histogram of the dark image.
    pub histogram_dsnu: Histogram,
    /// Accumulated histogram of the dark image.
    pub histogram_dsnu_accumulated: AccumulatedHistogram,
    /// Logarithmic histogram of the highpass-filtered bright minus dark image.
    pub histogram_prnu: Histogram,
    /// Accumulated histogram of the highpass-filtered bright minus dark image.
    pub histogram_prnu_accumulated: AccumulatedHistogram,
    /// Dark image pixels far from the median (hot: above; cold: below), in DN.
    pub defects_dark: Outliers,
    /// Bright minus dark pixels far from the median of their 5 x 5 neighbourhood (bright:
    /// above; dead or dim: below), in % of the mean signal above dark.
    pub defects_bright: Outliers,
}

/// Read the bright and dark spatial stacks (once each) and compute the spatial datasheet,
/// with the system gain `k_dn_per_e` (DN/e-) for DSNU in electrons.
pub fn spatial_from_stacks(
    bright: &SpatialStack,
    dark: &SpatialStack,
    k_dn_per_e: &Quantity,
    options: &SpatialOptions,
) -> Result<SpatialResult> {
    let b = read_stack_image(&bright.files)?;
    let d = read_stack_image(&dark.files)?;
    if b.shape != d.shape {
        return Err(Error::input(
            &dark.files[0],
            format!(
                "dark spatial stack frames are {}x{}, the bright stack's {}x{} ({})",
                d.shape.0,
                d.shape.1,
                b.shape.0,
                b.shape.1,
                bright.files[0].display()
            ),
        ));
    }
    spatial_from_images(&b, &d, k_dn_per_e, options)
}

/// The spatial datasheet from the reduced bright and dark stacks (same shape).
pub fn spatial_from_images(
    bright: &StackImage,
    dark: &StackImage,
    k_dn_per_e: &Quantity,
    options: &SpatialOptions,
) -> Result<SpatialResult> {
    if bright.shape != dark.shape {
        return Err(Error::Numeric(format!(
            "spatial stacks of different shapes ({:?} bright, {:?} dark)",
            bright.shape, dark.shape
        )));
    }
    let shape = bright.shape;
    let (mb, md) = (bright.mean_dn(), dark.mean_dn());
    let diff: Vec<f64> = mb.iter().zip(&md).map(|(b, d)| b - d).collect();
    let (sb, sd) = (stack_split(bright, &mb), stack_split(dark, &md));
    let residual_b = residual(bright);
    let residual_d = residual(dark);
    let sdiff = split(
        &diff,
        shape,
        residual_b.0 + residual_d.0,
        residual_b.1 + residual_d.1,
    );
    let signal = sb.mean_dn - sd.mean_dn;
    let signal_se = sdiff.mean_var.sqrt();
    let parts_ok = parts_resolvable(shape);

    let dsnu_dn = sd
        .parts
        .zip(sd.parts_var)
        .map(|name, (v, var)| std_from_variance(name, v, var, "DN", parts_ok));
    let dsnu_e = dsnu_dn.clone().map(|_, q| divide(&q, k_dn_per_e));
    let saturation_fraction =
        saturation_fraction(options.saturation_dn, sd.mean_dn, signal, signal_se);
    let prnu_percent = prnu(&sb, &sd, &sdiff, parts_ok).map(|_, q| {
        let q = percent_of(q, signal, signal_se);
        match &saturation_fraction.status {
            QuantityStatus::OutOfRules(rule) => q.out_of_rules(rule.clone()),
            _ => q,
        }
    });

    let temporal_b = bright.temporal_var_mean_dn2();
    let temporal_d = dark.temporal_var_mean_dn2();
    let spectrogram = |vertical: bool| {
        let len = if vertical { shape.0 } else { shape.1 };
        Spectrogram {
            frequency_cycles_per_px: frequencies(len),
            dsnu_dn: line_power(&md, shape, vertical)
                .iter()
                .map(|p| p.sqrt())
                .collect(),
            prnu_percent: line_power(&diff, shape, vertical)
                .iter()
                .map(|p| 100.0 * p.sqrt() / signal)
                .collect(),
            temporal_dark_dn: temporal_d.sqrt(),
            temporal_bright_percent: 100.0 * temporal_b.sqrt() / signal,
            floor_dark_dn: residual_d.0.sqrt(),
            floor_bright_percent: 100.0 * residual_b.0.sqrt() / signal,
        }
    };

    // The spectrograms, the histograms and the defect counts are independent: in parallel.
    let ((spectrogram_horizontal, spectrogram_vertical), (histograms, defects)) = rayon::join(
        || rayon::join(|| spectrogram(false), || spectrogram(true)),
        || {
            rayon::join(
                || histograms(bright, dark, signal, options.histogram_bins),
                || defects(&md, &diff, shape, signal, options.defect_factor),
            )
        },
    );
    let (histogram_dsnu, histogram_dsnu_accumulated, histogram_prnu, histogram_prnu_accumulated) =
        histograms;
    let (defects_dark, defects_bright) = defects;

    Ok(SpatialResult {
        rows: shape.0,
        cols: shape.1,
        frames_bright: bright.frames,
        frames_dark: dark.frames,
        saturation_fraction,
        dark: terms(&sd, dark, parts_ok),
        bright: terms(&sb, bright, parts_ok),
        dsnu_dn,
        dsnu_e,
        prnu_percent,
        spectrogram_horizontal,
        spectrogram_vertical,
        profile_horizontal_dark: profile(&md, shape, false),
        profile_horizontal_bright: profile(&diff, shape, false),
        profile_vertical_dark: profile(&md, shape, true),
        profile_vertical_bright: profile(&diff, shape, true),
        histogram_dsnu,
        histogram_dsnu_accumulated,
        histogram_prnu,
        histogram_prnu_accumulated,
        defects_dark,
        defects_bright,
    })
}

/// The standard's histograms: DSNU of the dark image, PRNU of the highpassed bright less dark
/// image (each plain and accumulated), `qmax` bins at most; `signal` (DN) for PRNU in %.
fn histograms(
    bright: &StackImage,
    dark: &StackImage,
    signal: f64,
    qmax: usize,
) -> (
    Histogram,
    AccumulatedHistogram,
    Histogram,
    AccumulatedHistogram,
) {
    // The histograms bin sums of L frames, as the standard does, so that integer samples give
    // integer values and bins of whole DN / L.
    let lb = bright.frames as f64;
    let ld = dark.frames as f64;
    let dsnu_bins = bin1288(&dark.sum_dn, qmax);
    let dark_mean_sum = dsnu_bins.mean;
    let histogram_dsnu = Histogram {
        bins_dn: dsnu_bins
            .lower
            .iter()
            .map(|b| (b - dark_mean_sum) / ld)
            .collect(),
        bins_percent: None,
        model_counts: dsnu_bins.normal_model(),
        counts: dsnu_bins.counts,
    };
    let dsnu_acc = bin1288(&histogram::abs_deviation(&dark.sum_dn), qmax);
    let histogram_dsnu_accumulated = AccumulatedHistogram {
        bins_dn: dsnu_acc.lower.iter().map(|b| b / ld).collect(),
        bins_percent: None,
        pixels_percent: dsnu_acc.accumulated_percent(),
    };
    let diff_sum: Vec<f64> = bright
        .sum_dn
        .iter()
        .zip(&dark.sum_dn)
        .map(|(b, d)| b - d * lb / ld)
        .collect();
    let (filtered, _) = highpass(&diff_sum, bright.shape, HIGHPASS_SIZE);
    let hp_scale = lb * (HIGHPASS_SIZE * HIGHPASS_SIZE) as f64;
    let to_percent = |dn: &[f64]| Some(dn.iter().map(|v| 100.0 * v / signal).collect());
    let prnu_bins = bin1288(&filtered, qmax);
    let bins_dn: Vec<f64> = prnu_bins.lower.iter().map(|b| b / hp_scale).collect();
    let histogram_prnu = Histogram {
        bins_percent: to_percent(&bins_dn),
        bins_dn,
        model_counts: prnu_bins.normal_model(),
        counts: prnu_bins.counts,
    };
    let prnu_acc = bin1288(&histogram::abs_deviation(&filtered), qmax);
    let bins_dn: Vec<f64> = prnu_acc.lower.iter().map(|b| b / hp_scale).collect();
    let histogram_prnu_accumulated = AccumulatedHistogram {
        bins_percent: to_percent(&bins_dn),
        bins_dn,
        pixels_percent: prnu_acc.accumulated_percent(),
    };
    (
        histogram_dsnu,
        histogram_dsnu_accumulated,
        histogram_prnu,
        histogram_prnu_accumulated,
    )
}

/// Defect counts of the dark image `md` (DN) and of the bright less dark image `diff` (DN,
/// each pixel less its neighbourhood's median, in % of `signal`).
fn defects(
    md: &[f64],
    diff: &[f64],
    shape: (usize, usize),
    signal: f64,
    factor: f64,
) -> (Outliers, Outliers) {
    let defects_percent: Vec<f64> = median_highpass(diff, shape, HIGHPASS_SIZE)
        .iter()
        .map(|v| 100.0 * v / signal)
        .collect();
    rayon::join(
        || outliers(md, factor),
        || outliers(&defects_percent, factor),
    )
}

/// The temporal variance left in a stack's averaged image, sigma^2_y.stack / L, and its
/// sampling variance (each pixel's variance has L - 1 degrees of freedom).
fn residual(stack: &StackImage) -> (f64, f64) {
    let l = stack.frames as f64;
    let t = stack.temporal_var_mean_dn2();
    let pixels = stack.sum_dn.len() as f64;
    (t / l, 2.0 * t * t / (pixels * (l - 1.0)) / (l * l))
}

fn stack_split(stack: &StackImage, mean: &[f64]) -> VarianceSplit {
    let (r, var) = residual(stack);
    split(mean, stack.shape, r, var)
}

/// Whether the row / column / pixel split is defined: the standard's system has the factor
/// M N / (M N - M - N), and a part needs at least two lines to have a variance.
fn parts_resolvable(shape: (usize, usize)) -> bool {
    let (m, n) = shape;
    m >= 3 && n >= 3
}

fn terms(s: &VarianceSplit, stack: &StackImage, parts_ok: bool) -> VarianceTerms {
    let (m, n) = s.shape;
    let l = stack.frames as f64;
    let t = stack.temporal_var_mean_dn2();
    VarianceTerms {
        mean_dn: Quantity::ok(s.mean_dn, s.mean_var.sqrt()),
        temporal_var_dn2: Quantity::ok(t, t * (2.0 / ((m * n) as f64 * (l - 1.0))).sqrt()),
        measured_dn2: s.measured_dn2,
        cav_dn2: s.cav_dn2,
        rav_dn2: s.rav_dn2,
        parts_dn2: s.parts.zip(s.parts_var).map(|name, (v, var)| {
            if name != "total" && !parts_ok {
                return Quantity::unavailable(too_small(s.shape));
            }
            Quantity::ok(v, var.sqrt())
        }),
    }
}

fn too_small(shape: (usize, usize)) -> String {
    format!(
        "a {}x{} image has too few rows or columns for the row / column / pixel split \
         (at least 3 of each)",
        shape.0, shape.1
    )
}

/// PRNU's variances s^2_y - s^2_y.dark per part (DN^2) as standard deviations (DN). Their
/// sampling variance is the difference image's (bright minus dark: the photo-response pattern
/// alone) plus that of twice the sample covariance of the difference and dark images, which
/// the standard's difference of variances carries: 4 A B / dof per part, A and B the two
/// images' per-unit variances.
fn prnu(
    sb: &VarianceSplit,
    sd: &VarianceSplit,
    sdiff: &VarianceSplit,
    parts_ok: bool,
) -> Parts<Quantity> {
    let cross: Vec<f64> = sdiff
        .units
        .iter()
        .zip(&sd.units)
        .map(|(&(a, dof), &(b, _))| 4.0 * a * b / dof)
        .collect();
    let cross = Parts {
        total: cross.iter().sum(),
        row: cross[0],
        col: cross[1],
        pixel: cross[2],
    };
    let diff = Parts {
        total: sb.parts.total - sd.parts.total,
        row: sb.parts.row - sd.parts.row,
        col: sb.parts.col - sd.parts.col,
        pixel: sb.parts.pixel - sd.parts.pixel,
    };
    diff.zip(sdiff.parts_var.zip(cross))
        .map(|name, (v, (var, c))| std_from_variance(name, v, var + c, "DN", parts_ok))
}

/// A variance estimate `v` (unit^2) with sampling variance `var` as a standard deviation:
/// sqrt(v) +- SE(v) / (2 sqrt(v)). A negative estimate has no root: the part is below what
/// the image resolves, e.g. a row part on 64 rows where the reference implementation gives
/// NaN (an absent row pattern estimates as often below zero as above); the reason says the
/// bound. An estimate within 2 SE of zero is `Imprecise`.
fn std_from_variance(name: &str, v: f64, var: f64, unit: &str, parts_ok: bool) -> Quantity {
    if name != "total" && !parts_ok {
        return Quantity::unavailable("too few rows or columns for the row / column / pixel split");
    }
    let se_v = var.sqrt();
    if !v.is_finite() {
        return Quantity::unavailable(format!("the {name} variance is not finite"));
    }
    if v <= 0.0 {
        return Quantity::unavailable(format!(
            "the {name} part's variance estimate is not positive ({v:.3e} +- {se_v:.2e} \
             {unit}^2): below what this image resolves, at most about {:.3e} {unit} (2 SE)",
            (2.0 * se_v).sqrt()
        ));
    }
    let value = v.sqrt();
    let se = se_v / (2.0 * value);
    if v < 2.0 * se_v {
        return Quantity {
            value,
            se,
            status: QuantityStatus::Imprecise,
        };
    }
    Quantity::ok(value, se)
}

/// `q` (DN) / `k` (DN/e-): relative SEs add in quadrature; an unavailable or out-of-rules
/// gain passes its status on.
fn divide(q: &Quantity, k: &Quantity) -> Quantity {
    if let QuantityStatus::Unavailable(why) = &q.status {
        return Quantity::unavailable(why.clone());
    }
    if let QuantityStatus::Unavailable(why) = &k.status {
        return Quantity::unavailable(format!("no system gain K: {why}"));
    }
    if k.value.is_nan() || k.value <= 0.0 {
        return Quantity::unavailable(format!("system gain K is {} DN/e-", k.value));
    }
    let value = q.value / k.value;
    let rel = ((q.se / q.value).powi(2) + (k.se / k.value).powi(2)).sqrt();
    let out = Quantity {
        value,
        se: value * rel,
        status: q.status.clone(),
    };
    match &k.status {
        QuantityStatus::OutOfRules(rule) => out.out_of_rules(format!("system gain K: {rule}")),
        QuantityStatus::Imprecise => Quantity {
            status: QuantityStatus::Imprecise,
            ..out
        },
        _ => out,
    }
}

/// A standard deviation `q` (DN) as a percentage of `signal` (DN, SE `signal_se`).
fn percent_of(q: Quantity, signal: f64, signal_se: f64) -> Quantity {
    if matches!(q.status, QuantityStatus::Unavailable(_)) {
        return q;
    }
    if signal.is_nan() || signal <= 0.0 {
        return Quantity::unavailable(format!(
            "the bright stack is not above the dark one ({signal:.3} DN)"
        ));
    }
    let value = 100.0 * q.value / signal;
    let rel = ((q.se / q.value).powi(2) + (signal_se / signal).powi(2)).sqrt();
    Quantity {
        value,
        se: value * rel,
        ..q
    }
}

/// The bright stack's signal above dark as a fraction of saturation's, out of rules outside
/// [`SATURATION_WINDOW`].
fn saturation_fraction(
    saturation_dn: Option<f64>,
    dark_dn: f64,
    signal: f64,
    signal_se: f64,
) -> Quantity {
    let Some(sat) = saturation_dn else {
        return Quantity::unavailable("no saturation level given");
    };
    let full = sat - dark_dn;
    if full.is_nan() || full <= 0.0 {
        return Quantity::unavailable(format!(
            "saturation ({sat} DN) is not above the dark level ({dark_dn:.3} DN)"
        ));
    }
    let f = signal / full;
    let q = Quantity::ok(f, signal_se / full);
    let (lo, hi) = SATURATION_WINDOW;
    if (lo..=hi).contains(&f) {
        q
    } else {
        q.out_of_rules(format!(
            "the bright spatial stack is at {:.0} % of saturation, not about 50 % \
             ({:.0}-{:.0} %)",
            100.0 * f,
            100.0 * lo,
            100.0 * hi
        ))
    }
}
