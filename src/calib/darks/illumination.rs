//! The check that a dark stack saw no light: shot noise makes a pixel's variance grow with
//! its level across the pixels of a flat, not of a dark.

use serde::Serialize;

use super::maps::DarkMaps;
use crate::camera::CameraAt;
use crate::error::{Error, Result};
use crate::io::FrameStack;
use crate::stats::{median, percentile, robust_slope};

/// Photon-transfer slopes with fewer standard errors than this are not evidence of light.
const LIGHT_SLOPE_T: f64 = 5.0;
/// Fewest photoelectrons per pixel and frame the slope must imply for light to matter (a
/// shot noise of 2 e-, above typical sCMOS read noise).
const LIGHT_MIN_ELECTRONS: f64 = 4.0;
/// Range of the fraction of the level a photon-transfer slope attributes to signal for a
/// flat: below, the correlation comes from rare events on a dark level (EMCCD clock-induced
/// charge: ~0.3 % of the level); above, the slope is too shallow for shot noise.
const LIGHT_SIGNAL_FRACTION: (f64, f64) = (0.05, 2.0);
/// A dark level above this fraction of the stored integer range, and above
/// [`LIGHT_LEVEL_MIN_ADU`], is light (dark offsets of 12- and 16-bit cameras sit a few percent
/// above zero to keep the dynamic range).
const LIGHT_LEVEL_FRACTION: f64 = 0.25;
/// Lowest level (adu) that the level alone marks as light: the type's range must not decide by
/// itself, since an 8-bit camera's offset may sit at a third of its 255 adu (issue 31), while
/// no camera's bias reaches 1000 adu at a quarter of its range (the real EMCCD frames at EM gain
/// 300, 3x3 px and so too few for the slope, sit at 25,689 adu: 39 % of uint16).
const LIGHT_LEVEL_MIN_ADU: f64 = 1000.0;
/// Fewest pixels for the photon-transfer test across pixels.
const LIGHT_MIN_PIXELS: usize = 64;

/// The dark signal a stack is expected to hold at its operating point (a camera model's dark
/// current and CIC): the check for light looks at what is left once it is taken off, so a long
/// dark, whose dark charge's shot noise grows with its level across pixels as light's does, is
/// not read as light.
#[derive(Clone, Debug, PartialEq)]
pub struct ExpectedDark {
    /// Expected dark signal of each pixel, adu (row-major, like the stack).
    pub mean_adu: Vec<f64>,
    /// Variance of its shot noise, adu^2 (times the EM register's excess noise factor squared).
    pub variance_adu2: Vec<f64>,
    /// Median expected dark signal, e- per pixel and frame (input-referred).
    pub median_e: f64,
    /// Where it comes from (e.g. the camera model's folder), for messages.
    pub source: String,
}

impl ExpectedDark {
    /// From each pixel's dark signal `dark_e` (e- per frame, input-referred), its output adu
    /// per input e- `adu_per_e` (EM gain over conversion gain) and the register's excess
    /// noise factor squared `excess_noise_f2` (1 without one): mean dark_e x a, shot-noise
    /// variance F^2 x dark_e x a^2.
    pub fn new(
        dark_e: &[f64],
        adu_per_e: &[f64],
        excess_noise_f2: f64,
        source: impl Into<String>,
    ) -> ExpectedDark {
        let pairs = dark_e.iter().zip(adu_per_e);
        ExpectedDark {
            mean_adu: pairs.clone().map(|(d, a)| d * a).collect(),
            variance_adu2: pairs.map(|(d, a)| excess_noise_f2 * d * a * a).collect(),
            median_e: median(dark_e),
            source: source.into(),
        }
    }

    /// The dark signal of the camera `at` its operating point (its dark charge per pixel,
    /// through its per-pixel gain and register); `source` names the camera for messages.
    pub fn of_camera(at: &CameraAt, source: impl Into<String>) -> ExpectedDark {
        let adu_per_e: Vec<f64> = (0..at.pixels()).map(|i| at.adu_per_e(i)).collect();
        ExpectedDark::new(&at.dark_e, &adu_per_e, at.excess_noise_f2, source)
    }

    /// Fail unless it has one value per pixel of `stack` (checked before the stack is read).
    pub fn check_shape(&self, stack: &FrameStack) -> Result<()> {
        if self.mean_adu.len() == stack.pixels() {
            return Ok(());
        }
        Err(Error::invalid(
            "camera",
            format!(
                "{}: the camera model has {} pixels, the dark stack {} ({}x{})",
                self.source,
                self.mean_adu.len(),
                stack.pixels(),
                stack.shape.0,
                stack.shape.1
            ),
        ))
    }
}

/// Evidence that a dark stack saw light, from its per-pixel offset and read-noise maps.
///
/// Shot noise makes a pixel's temporal variance grow with its signal: across the pixels of a
/// flat, variance against mean has the photon-transfer slope (1/gain for illumination
/// differences, 2/gain for gain differences; adu), while a dark's variance does not follow
/// its offset. The slope b and the median variance v then imply the photoelectrons per pixel
/// and frame (v / b^2) and the signal (v / b, adu), which for a flat is a large part of the
/// level.
#[derive(Clone, Debug, Serialize)]
pub struct Illumination {
    /// Pixels used for the slope (central 98 % of the means, variance below its 99th percentile).
    pub pixels: usize,
    /// Median per-pixel mean (adu).
    pub level_adu: f64,
    /// The level as a fraction of the stored integer type's largest value (None for floats).
    pub level_fraction_of_range: Option<f64>,
    /// Median per-pixel variance (adu^2).
    pub variance_adu2: f64,
    /// Slope of per-pixel variance against per-pixel mean across pixels (adu).
    pub slope_adu: f64,
    /// The slope in units of its (heteroscedasticity-robust) standard error.
    pub slope_t: f64,
    /// Photoelectrons per pixel and frame the slope implies: variance / slope^2 (e-).
    pub implied_electrons: f64,
    /// Signal the slope implies as a fraction of the level: variance / (slope x level).
    pub implied_signal_fraction: f64,
    /// The median expected dark signal taken off before the test (e-), when one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub expected_dark_e: Option<f64>,
    /// True when the frames look illuminated.
    pub illuminated: bool,
}

impl Illumination {
    /// Measure the evidence from per-pixel offsets (adu) and read noise (adu) of a stack whose
    /// stored type saturates at `type_max` (None for floats).
    pub fn measure(offset_adu: &[f64], rms_adu: &[f64], type_max: Option<f64>) -> Illumination {
        Self::measure_expecting(offset_adu, rms_adu, type_max, None)
    }

    /// [`Illumination::measure`] of what is left once the `expected` dark signal (its mean and
    /// its shot noise's variance, per pixel) is taken off: a dark then shows no slope, light
    /// still its photon-transfer slope. `expected` has one value per pixel.
    pub fn measure_expecting(
        offset_adu: &[f64],
        rms_adu: &[f64],
        type_max: Option<f64>,
        expected: Option<&ExpectedDark>,
    ) -> Illumination {
        let mut var: Vec<f64> = rms_adu.iter().map(|r| r * r).collect();
        let mut offset = offset_adu.to_vec();
        if let Some(e) = expected {
            offset
                .iter_mut()
                .zip(&e.mean_adu)
                .for_each(|(m, d)| *m -= d);
            var.iter_mut()
                .zip(&e.variance_adu2)
                .for_each(|(v, d)| *v -= d);
        }
        let offset_adu = &offset[..];
        let level_adu = median(offset_adu);
        let variance_adu2 = median(&var);
        let level_fraction_of_range = type_max.map(|m| level_adu / m);
        let (lo, hi, vmax) = (
            percentile(offset_adu, 1.0),
            percentile(offset_adu, 99.0),
            percentile(&var, 99.0),
        );
        let (x, y): (Vec<f64>, Vec<f64>) = offset_adu
            .iter()
            .zip(&var)
            .filter(|(m, v)| **m >= lo && **m <= hi && v.is_finite() && **v <= vmax)
            .map(|(m, v)| (*m, *v))
            .unzip();
        let (slope_adu, slope_t) = if x.len() >= LIGHT_MIN_PIXELS {
            robust_slope(&x, &y)
        } else {
            (f64::NAN, f64::NAN)
        };
        let implied_electrons = variance_adu2 / (slope_adu * slope_adu);
        let implied_signal_fraction = variance_adu2 / (slope_adu * level_adu);
        let (f_lo, f_hi) = LIGHT_SIGNAL_FRACTION;
        let follows_light = slope_t >= LIGHT_SLOPE_T
            && implied_electrons >= LIGHT_MIN_ELECTRONS
            && (f_lo..=f_hi).contains(&implied_signal_fraction);
        let too_high = level_fraction_of_range.is_some_and(|f| f >= LIGHT_LEVEL_FRACTION)
            && level_adu >= LIGHT_LEVEL_MIN_ADU;
        Illumination {
            pixels: x.len(),
            level_adu,
            level_fraction_of_range,
            variance_adu2,
            slope_adu,
            slope_t,
            implied_electrons,
            implied_signal_fraction,
            expected_dark_e: expected.map(|e| e.median_e),
            illuminated: follows_light || too_high,
        }
    }

    /// What was seen, in numbers (one sentence).
    pub fn describe(&self) -> String {
        let range = self
            .level_fraction_of_range
            .map(|f| format!(" ({:.1} % of the stored type's range)", 100.0 * f))
            .unwrap_or_default();
        let slope = if self.slope_t.is_finite() {
            format!(
                "across {} pixels the variance grows with the mean at {:.3} adu ({:.1} standard errors; darks show no such slope, flats about 1/gain to 2/gain): shot noise of {} photoelectrons per pixel and frame, a signal of {:.0} % of the level",
                self.pixels,
                self.slope_adu,
                self.slope_t,
                significant(self.implied_electrons),
                100.0 * self.implied_signal_fraction
            )
        } else {
            format!(
                "too few pixels ({}) to compare variance with mean",
                self.pixels
            )
        };
        let expected = self
            .expected_dark_e
            .map(|e| {
                format!(
                    " after the expected dark signal ({} e- per pixel) and its shot noise are taken off",
                    significant(e)
                )
            })
            .unwrap_or_default();
        format!(
            "median level {:.1} adu{range}, median variance {} adu^2{expected}; {slope}",
            self.level_adu,
            significant(self.variance_adu2)
        )
    }
}

/// `x` with three significant digits, without exponent for everyday magnitudes.
fn significant(x: f64) -> String {
    let digits = if x.abs() >= 100.0 || !x.is_finite() {
        0
    } else {
        (2 - x.abs().log10().floor() as i32).clamp(0, 6) as usize
    };
    format!("{x:.digits$}")
}

/// Refuse a dark stack that looks illuminated (naming the file and what was seen) unless
/// `accept_illuminated`; when illuminated frames are accepted, returns a warning to print.
pub fn require_dark(
    stack: &FrameStack,
    maps: &DarkMaps,
    accept_illuminated: bool,
) -> Result<Option<String>> {
    require_dark_expecting(stack, maps, accept_illuminated, None)
}

/// [`require_dark`] with the dark signal the stack is `expected` to hold taken off first.
pub fn require_dark_expecting(
    stack: &FrameStack,
    maps: &DarkMaps,
    accept_illuminated: bool,
    expected: Option<&ExpectedDark>,
) -> Result<Option<String>> {
    let seen = Illumination::measure_expecting(
        &maps.offset_adu.data,
        &maps.rms_adu.data,
        stack.saturation_value(),
        expected,
    );
    let path = &stack.sources[0].path;
    match (seen.illuminated, accept_illuminated) {
        (false, _) => Ok(None),
        (true, true) => Ok(Some(format!(
            "{}: these frames look illuminated ({}); used as darks because of --accept-illuminated",
            path.display(),
            seen.describe()
        ))),
        (true, false) => Err(Error::input(
            path,
            format!(
                "these frames look illuminated, not dark: {}. Give frames taken without light (shutter closed, same exposure){}, or --accept-illuminated to use these anyway",
                seen.describe(),
                if expected.is_some() {
                    ""
                } else {
                    ", the camera model whose dark current they hold (--camera with --exposure-s)"
                }
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use rand_distr::{Distribution, Normal};

    /// Maps of a dark on `pixels` pixels at `offset_adu` (spread 2 adu) with 1.5 adu of noise.
    fn dark_maps(pixels: usize, offset_adu: f64) -> (Vec<f64>, Vec<f64>) {
        let mut rng = stream(31, 8, 0);
        let spread = Normal::new(offset_adu, 2.0).unwrap();
        let offsets = (0..pixels).map(|_| spread.sample(&mut rng)).collect();
        let rms = (0..pixels)
            .map(|_| 1.5 + 0.1 * Normal::new(0.0, 1.0).unwrap().sample(&mut rng))
            .collect();
        (offsets, rms)
    }

    /// Maps of a long sCMOS dark (K = 0.5 e-/adu, 1.6 e- read noise, offsets 100 +/- 6 adu)
    /// whose pixels hold a lognormal dark charge of median `dark_e` (log SD 0.6), plus
    /// `light_e` of light per pixel (10 % spread); with the expected dark signal.
    fn long_dark(dark_e: f64, light_e: f64) -> (Vec<f64>, Vec<f64>, ExpectedDark) {
        let k = 0.5;
        let mut rng = stream(31, 9, 0);
        let unit = Normal::new(0.0f64, 1.0).unwrap();
        let (mut off, mut rms, mut q) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..4096 {
            let d = dark_e * (0.6 * unit.sample(&mut rng)).exp();
            let l = light_e * (1.0 + 0.1 * unit.sample(&mut rng));
            off.push(100.0 + 6.0 * unit.sample(&mut rng) + (d + l) / k);
            rms.push((1.6f64.powi(2) + d + l).sqrt() / k);
            q.push(d);
        }
        let expected = ExpectedDark::new(&q, &vec![1.0 / k; q.len()], 1.0, "test");
        (off, rms, expected)
    }

    #[test]
    fn an_expected_dark_signal_is_not_light_and_light_beyond_it_still_is() {
        // 20 e- of dark charge: its shot noise follows the level across pixels as light's does.
        let (off, rms, expected) = long_dark(20.0, 0.0);
        let seen = Illumination::measure(&off, &rms, Some(65_535.0));
        assert!(seen.illuminated, "was refused: {}", seen.describe());
        let seen = Illumination::measure_expecting(&off, &rms, Some(65_535.0), Some(&expected));
        assert!(!seen.illuminated, "{}", seen.describe());
        // 50 e- of light on top: still light.
        let (off, rms, expected) = long_dark(20.0, 50.0);
        let seen = Illumination::measure_expecting(&off, &rms, Some(65_535.0), Some(&expected));
        assert!(seen.illuminated, "{}", seen.describe());
        assert!(seen.describe().contains("expected dark signal"));
    }

    #[test]
    fn the_types_range_alone_does_not_make_a_dark_light() {
        // An 8-bit camera with its offset at 80 adu (31 % of 255): dark (was refused).
        let (off, rms) = dark_maps(4096, 80.0);
        let seen = Illumination::measure(&off, &rms, Some(255.0));
        assert!(seen.level_fraction_of_range.unwrap() > LIGHT_LEVEL_FRACTION);
        assert!(!seen.illuminated, "{}", seen.describe());
        // A 16-bit stack of 9 px (too few for the slope) at 39 % of its range: light.
        let (off, rms) = dark_maps(9, 25_689.0);
        let seen = Illumination::measure(&off, &rms, Some(65_535.0));
        assert!(!seen.slope_t.is_finite());
        assert!(seen.illuminated, "{}", seen.describe());
    }
}
