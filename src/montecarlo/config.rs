//! One Monte-Carlo configuration and its background grid, with the engine's limits.

use crate::spot::{Sampling, Spot};
use crate::{Error, Result};

/// Background levels to sweep.
#[derive(Debug, Clone, PartialEq)]
pub enum BgGrid {
    /// A grid sized from the signal: fine near zero, up to the brightest expected pixel.
    Auto,
    /// `start:stop:step` in e-.
    Range {
        /// First level (e-).
        start: f64,
        /// Last level (e-, inclusive).
        stop: f64,
        /// Spacing (e-).
        step: f64,
    },
}

impl BgGrid {
    /// Most levels a `start:stop:step` grid may have: every frame walks all of them.
    pub const MAX_LEVELS: f64 = 100_000.0;

    /// Parse `auto` or `start:stop:step` (e-).
    pub fn parse(text: &str) -> Result<Self> {
        if text == "auto" {
            return Ok(BgGrid::Auto);
        }
        let bad = |why: String| Error::invalid("bg_grid", format!("'{text}': {why}"));
        let form = || {
            bad(
                "expected auto or start:stop:step in e-, with 0 <= start <= stop and step > 0"
                    .into(),
            )
        };
        let parts: Vec<f64> = text
            .split(':')
            .map(|p| p.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| form())?;
        let [start, stop, step] = parts[..] else {
            return Err(form());
        };
        if !(start >= 0.0 && stop >= start && step > 0.0 && stop.is_finite()) {
            return Err(form());
        }
        let levels = ((stop - start) / step + 1e-9).floor() + 1.0;
        if levels > Self::MAX_LEVELS {
            return Err(bad(format!(
                "{levels:.0} levels; at most {:.0} are allowed (every frame is evaluated at each \
                 level): use a larger step",
                Self::MAX_LEVELS
            )));
        }
        Ok(BgGrid::Range { start, stop, step })
    }

    /// The levels (e-) for a run whose brightest expected pixel holds `peak_e`; 0 is always included.
    pub fn levels(&self, peak_e: f64) -> Vec<f64> {
        let mut levels = vec![0.0];
        match self {
            BgGrid::Range { start, stop, step } => {
                let count = ((stop - start) / step + 1e-9).floor() as usize;
                levels.extend((0..=count).map(|k| start + k as f64 * step));
            }
            BgGrid::Auto => {
                // Fine where EMCCD (photon-counting units) and low-noise sCMOS optima lie,
                // coarser above, then 5 % steps up to the brightest pixel, beyond which
                // nearly every frame would be empty.
                for (lo, hi, step) in [
                    (0.0f64, 1.0f64, 0.05f64),
                    (1.0, 3.0, 0.1),
                    (3.0, 10.0, 0.25),
                    (10.0, 20.0, 0.5),
                    (20.0, 40.0, 1.0),
                ] {
                    let count = ((hi - lo) / step + 1e-9).round() as usize;
                    levels.extend((0..count).map(|k| lo + k as f64 * step));
                }
                let mut b: f64 = 40.0;
                let top = peak_e.max(60.0);
                while b < top * 1.05 {
                    levels.push(b);
                    b *= 1.05;
                }
            }
        }
        levels.sort_by(f64::total_cmp);
        levels.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        levels
    }
}

/// One Monte-Carlo configuration.
#[derive(Debug, Clone)]
pub struct SimConfig {
    /// Sub-aperture side (px).
    pub subap_px: usize,
    /// Spot shape.
    pub spot: Spot,
    /// Pixel sampling of the spot.
    pub sampling: Sampling,
    /// Photons per sub-aperture (before QE).
    pub signal_photons: f64,
    /// Quantum efficiency (photo-electrons per photon).
    pub qe: f64,
    /// Iterations (frames).
    pub iters: u64,
    /// Seed of all random streams.
    pub seed: u64,
    /// Background levels to sweep.
    pub bg_grid: BgGrid,
    /// Spot offsets are uniform in [-h, h) px in each axis, h = this half-width.
    pub position_half_range_px: f64,
    /// A level is eligible for the optimum when at most this fraction of frames is empty.
    pub max_empty_frac: f64,
}

impl SimConfig {
    /// The paper's defaults for one sub-aperture size: D = 2 px Airy, S = 50, QE 1, 10,000 frames.
    pub fn paper(subap_px: usize) -> Self {
        SimConfig {
            subap_px,
            spot: Spot::Airy { diameter_px: 2.0 },
            sampling: Sampling::Integrated,
            signal_photons: 50.0,
            qe: 1.0,
            iters: 10_000,
            seed: 1,
            bg_grid: BgGrid::Auto,
            position_half_range_px: 0.5,
            max_empty_frac: 0.01,
        }
    }

    /// Smallest sub-aperture side (px): a centroid inside one pixel carries no information.
    pub const MIN_SUBAP_PX: usize = 2;
    /// Largest sub-aperture side (px): the pixel-integrated spot table grows as the square of
    /// the side (about 21 MB kept at 128 px, at most 128 MiB while it is built), and
    /// Shack-Hartmann sub-apertures are far smaller.
    pub const MAX_SUBAP_PX: usize = 128;
    /// Largest signal x QE (photo-electrons per sub-aperture). Photo-electron counts are 32-bit
    /// per pixel (at most 4.29e9) and the whole signal can fall into one pixel: the bound keeps a
    /// 4x margin. At 1e9 photons R is at its shot-noise limit, near 1e-5 px.
    pub const MAX_PHOTO_E: f64 = 1e9;
    /// Most iterations per configuration (1e9 frames of a 16x16 sub-aperture take days).
    pub const MAX_ITERS: u64 = 1_000_000_000;

    /// Largest spot offset half-range (px) for `subap_px`: a quarter of the side, so the spot
    /// centre stays in the central half of the sub-aperture and the spot mostly inside it.
    pub fn max_position_half_range_px(subap_px: usize) -> f64 {
        subap_px as f64 / 4.0
    }

    /// Check every value; the error names the field and its allowed range.
    pub fn validate(&self) -> Result<()> {
        let check = |ok: bool, field: &str, msg: String| {
            if ok {
                Ok(())
            } else {
                Err(Error::invalid(field, msg))
            }
        };
        self.spot.validate()?;
        let n = self.subap_px;
        check(
            (Self::MIN_SUBAP_PX..=Self::MAX_SUBAP_PX).contains(&n),
            "subap_px",
            format!(
                "{n} px: sub-aperture sizes must be {} to {} px per side (a centroid inside one \
                 pixel carries no position information)",
                Self::MIN_SUBAP_PX,
                Self::MAX_SUBAP_PX
            ),
        )?;
        check(
            self.signal_photons.is_finite() && self.signal_photons > 0.0,
            "signal_photons",
            format!("{}: signals must be > 0 photons", self.signal_photons),
        )?;
        check(
            self.qe.is_finite() && self.qe > 0.0 && self.qe <= 1.0,
            "qe",
            format!("{}: QE must be in (0, 1]", self.qe),
        )?;
        let photo_e = self.signal_photons * self.qe;
        check(
            photo_e <= Self::MAX_PHOTO_E,
            "signal_photons",
            format!(
                "{} photons x QE {} = {photo_e:e} photo-electrons per sub-aperture; at most {:e} \
                 are simulated: counts are 32-bit per pixel (4.29e9) and the whole signal can fall \
                 in one pixel, so above this R would silently go wrong (at 1e9, R is already at its \
                 shot-noise limit, about 1e-5 px)",
                self.signal_photons,
                self.qe,
                Self::MAX_PHOTO_E
            ),
        )?;
        check(
            (2..=Self::MAX_ITERS).contains(&self.iters),
            "iters",
            format!(
                "{}: must be 2 to {:e} (a standard error needs two iterations)",
                self.iters,
                Self::MAX_ITERS as f64
            ),
        )?;
        let h_max = Self::max_position_half_range_px(n);
        check(
            self.position_half_range_px.is_finite()
                && (0.0..=h_max).contains(&self.position_half_range_px),
            "position_half_range_px",
            format!(
                "{} px: the half-range must be 0 to {h_max} px for {n}x{n} px sub-apertures (a \
                 quarter of the side: the spot centre stays in the central half, so the spot stays \
                 mostly inside the sub-aperture)",
                self.position_half_range_px
            ),
        )?;
        check(
            (0.0..=1.0).contains(&self.max_empty_frac),
            "max_empty_frac",
            format!("{}: must be in [0, 1]", self.max_empty_frac),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configurations_outside_the_engine_limits_are_refused() {
        type Spoil = fn(&mut SimConfig);
        let cases: [(&str, Spoil); 6] = [
            ("subap_px", |c| c.subap_px = 1),
            ("subap_px", |c| c.subap_px = SimConfig::MAX_SUBAP_PX + 1),
            ("position_half_range_px", |c| {
                c.position_half_range_px = 2.01
            }),
            ("position_half_range_px", |c| c.position_half_range_px = 1e9),
            ("iters", |c| c.iters = 1),
            ("max_empty_frac", |c| c.max_empty_frac = 1.5),
        ];
        for (field, spoil) in cases {
            let mut cfg = SimConfig::paper(8);
            spoil(&mut cfg);
            let err = cfg.validate().unwrap_err();
            assert_eq!(err.exit_code(), 2);
            assert!(err.to_string().contains(&format!("`{field}`")), "{err}");
        }
        let mut cfg = SimConfig::paper(8);
        cfg.position_half_range_px = 2.0;
        cfg.validate().unwrap();
        SimConfig::paper(2).validate().unwrap();
    }

    #[test]
    fn bg_grid_parsing() {
        assert_eq!(
            BgGrid::parse("0:1:0.5").unwrap().levels(10.0),
            vec![0.0, 0.5, 1.0]
        );
        assert_eq!(
            BgGrid::parse("2:3:1").unwrap().levels(10.0),
            vec![0.0, 2.0, 3.0]
        );
        for bad in ["1:0:1", "0:1:0", "a:b:c", "0:1", "-1:2:1"] {
            assert!(BgGrid::parse(bad).is_err(), "{bad}");
        }
        // A well-formed grid with too many levels says so: the limit and its level count.
        let msg = BgGrid::parse("0:1000:0.001").unwrap_err().to_string();
        assert!(
            msg.contains("1000001 levels") && msg.contains("100000"),
            "{msg}"
        );
        assert_eq!(
            BgGrid::parse("0:99999:1").unwrap().levels(1.0).len(),
            100_000
        );
        let auto = BgGrid::Auto.levels(500.0);
        assert!(auto[0] == 0.0 && *auto.last().unwrap() >= 500.0);
        assert!(auto.windows(2).all(|w| w[0] < w[1]));
    }
}
