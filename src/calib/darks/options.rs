//! Options of a dark calibration: sample rejection per pixel and the flag thresholds.

use serde::Serialize;

use crate::error::{Error, Result};

/// Rejection of outlying samples per pixel (cosmic rays).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Clip {
    /// Keep every sample.
    None,
    /// Reject the N highest and the N lowest samples of each pixel.
    Extremes(usize),
    /// Reject samples more than K standard deviations from the pixel mean of a first pass
    /// (one iteration; the stack is read twice).
    Sigma(f64),
}

/// Largest [`Clip::Extremes`] (samples rejected at each end of every pixel).
pub const MAX_CLIP: usize = 100_000;
/// Largest [`Clip::Sigma`] (standard deviations): Chebyshev's inequality bounds the fraction
/// of any distribution's samples beyond it at 1e-6, so a larger K rejects nothing.
pub const MAX_SIGMA_CLIP: f64 = 1e3;

impl Clip {
    /// Check the value (the frame count is checked when a stack is read): at most
    /// [`MAX_CLIP`] samples, K in (0, [`MAX_SIGMA_CLIP`]]; the error names `clip` or
    /// `sigma_clip`.
    pub fn check(&self) -> Result<()> {
        match *self {
            Clip::None => Ok(()),
            Clip::Extremes(n) if n <= MAX_CLIP => Ok(()),
            Clip::Extremes(n) => Err(Error::invalid(
                "clip",
                format!("{n} samples: must be at most {MAX_CLIP}"),
            )),
            Clip::Sigma(k) if k > 0.0 && k <= MAX_SIGMA_CLIP => Ok(()),
            Clip::Sigma(k) => Err(Error::invalid(
                "sigma_clip",
                format!("{k} must be > 0 and at most {MAX_SIGMA_CLIP} standard deviations"),
            )),
        }
    }
}

/// Options of the dark-stack statistics.
#[derive(Clone, Debug, Serialize)]
pub struct DarkOptions {
    /// Outlier rejection per pixel.
    pub clip: Clip,
    /// Subtract each frame's median (a per-frame common-mode offset) before accumulating.
    pub common_mode: bool,
    /// Hot threshold: offset above median + this many robust sigmas of the offset map.
    pub hot_sigma: f64,
    /// Dead threshold: rms below this fraction of the median rms.
    pub dead_fraction: f64,
    /// RTS threshold: von Neumann ratio below 1 - this many standard errors (1/sqrt(n)).
    pub rts_sigma: f64,
}

impl Default for DarkOptions {
    fn default() -> Self {
        DarkOptions {
            clip: Clip::None,
            common_mode: false,
            hot_sigma: 5.0,
            dead_fraction: 0.1,
            rts_sigma: 5.0,
        }
    }
}

impl DarkOptions {
    /// Check every value (the command line checks them while parsing; library callers get
    /// the same limits here): thresholds finite and positive, `dead_fraction` in [0, 1].
    pub fn check(&self) -> Result<()> {
        let positive = |field: &str, v: f64, unit: &str| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(Error::invalid(field, format!("{v} must be > 0 {unit}")))
            }
        };
        positive("hot_sigma", self.hot_sigma, "robust sigmas")?;
        positive("rts_sigma", self.rts_sigma, "standard errors")?;
        self.clip.check()?;
        if !(0.0..=1.0).contains(&self.dead_fraction) {
            return Err(Error::invalid(
                "dead_fraction",
                format!("{} must be in [0, 1]", self.dead_fraction),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_name_the_field_at_fault() {
        assert!(DarkOptions::default().check().is_ok());
        let field = |o: DarkOptions| match o.check() {
            Err(Error::Usage { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        let bad = |f: fn(&mut DarkOptions)| {
            let mut o = DarkOptions::default();
            f(&mut o);
            o
        };
        assert_eq!(field(bad(|o| o.hot_sigma = 0.0)), "hot_sigma");
        assert_eq!(field(bad(|o| o.rts_sigma = f64::NAN)), "rts_sigma");
        assert_eq!(field(bad(|o| o.clip = Clip::Sigma(-1.0))), "sigma_clip");
        assert_eq!(field(bad(|o| o.clip = Clip::Sigma(1e4))), "sigma_clip");
        assert_eq!(
            field(bad(|o| o.clip = Clip::Extremes(MAX_CLIP + 1))),
            "clip"
        );
        assert_eq!(field(bad(|o| o.dead_fraction = 1.5)), "dead_fraction");
    }
}
