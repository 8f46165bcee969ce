//! The reference families a detector's R is matched against: readouts indexed by one
//! parameter, written as an abscissa x along which R grows, so that one solver and one
//! inversion serve them all.
//!
//! - [`ConstantSigma`]: Gaussian read noise of one sigma for every pixel, x = sigma (e-); its
//!   foot is sigma = 0, the noiseless readout. Solving gives the effective read noise.
//! - [`SimpleQe`]: the paper's simple EMCCD model with QE factor q and a fixed read noise,
//!   x = -q (R falls as q grows); its foot is q = 1, every photo-electron kept. Solving gives
//!   the effective QE factor of the simple model.

use crate::detector::{EmccdSimple, Readout, ScmosConstant};

/// Points of every family's pilot grid.
pub(super) const PILOT_POINTS: usize = 8;
/// Points of every family's final grid.
pub(super) const FINAL_POINTS: usize = 4;

/// Pilot grid of the constant family: sigma = 0 (noiseless readout) and 1/4 to 4 times the
/// detector's noise scale.
const PILOT_FACTORS: [f64; PILOT_POINTS] = [0.0, 0.25, 0.397, 0.63, 1.0, 1.587, 2.52, 4.0];
/// Final grid around the pilot estimate (factors of it; the QE family runs it in reverse).
const FINAL_FACTORS: [f64; FINAL_POINTS] = [0.85, 0.95, 1.05, 1.18];
/// Fallback grid of the constant family when R is too flat in sigma for the narrow bracket: 0
/// and 0.1 to 16 times the scale.
const WIDE_FACTORS: [f64; 12] = [0.0, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0, 6.0, 16.0];
/// Pilot QE factors, descending (x ascending): all photo-electrons kept down to a tenth.
const PILOT_QE: [f64; PILOT_POINTS] = [1.0, 0.8, 0.63, 0.5, 0.4, 0.3, 0.2, 0.1];
/// Fallback QE factors, descending from 1.
const WIDE_QE: [f64; 12] = [
    1.0, 0.85, 0.7, 0.58, 0.48, 0.4, 0.32, 0.25, 0.18, 0.12, 0.07, 0.03,
];

/// A one-parameter family of reference readouts whose R grows with the abscissa x.
pub(super) trait Family {
    /// The reference readout at abscissa `x`.
    fn reference(&self, x: f64) -> Box<dyn Readout>;
    /// The pilot's abscissae, ascending, from the foot ([`PILOT_POINTS`] of them).
    fn pilot(&self) -> Vec<f64>;
    /// The final run's abscissae around the pilot's estimate `x`, ascending ([`FINAL_POINTS`]).
    fn around(&self, x: f64) -> Vec<f64>;
    /// The fallback grid given the pilot's estimate `x`, ascending from the foot.
    fn wide(&self, x: f64) -> Vec<f64>;
    /// Whether the pilot's estimate `x` is the foot, where no bracket around it is tried.
    fn at_foot(&self, x: f64) -> bool;
    /// The parameter the user reads at abscissa `x`.
    fn value(&self, x: f64) -> f64;
}

fn scaled(factors: &[f64], s: f64) -> Vec<f64> {
    factors.iter().map(|f| f * s).collect()
}

/// Constant Gaussian read noise, x = sigma (e-), grids scaled by the detector's noise scale.
pub(super) struct ConstantSigma {
    /// The detector's noise scale (e-), at least 1e-3.
    pub scale_e: f64,
}

impl Family for ConstantSigma {
    fn reference(&self, x: f64) -> Box<dyn Readout> {
        Box::new(ScmosConstant::new(x, format!("scmos-constant:{x}")))
    }

    fn pilot(&self) -> Vec<f64> {
        scaled(&PILOT_FACTORS, self.scale_e)
    }

    fn around(&self, x: f64) -> Vec<f64> {
        scaled(&FINAL_FACTORS, x)
    }

    fn wide(&self, x: f64) -> Vec<f64> {
        scaled(&WIDE_FACTORS, self.scale_e.max(x))
    }

    fn at_foot(&self, x: f64) -> bool {
        x <= 0.0
    }

    fn value(&self, x: f64) -> f64 {
        x
    }
}

/// The simple EMCCD model with QE factor q = -x and read noise `read_noise_e` (e-, referred to
/// the input).
pub(super) struct SimpleQe {
    /// Read noise of every reference (e-): the camera's output read noise over its EM gain.
    pub read_noise_e: f64,
}

impl SimpleQe {
    /// Most a final grid's centre may be: its largest factor then stays at q = 1.
    fn centre_max() -> f64 {
        1.0 / FINAL_FACTORS[FINAL_POINTS - 1]
    }
}

impl Family for SimpleQe {
    fn reference(&self, x: f64) -> Box<dyn Readout> {
        Box::new(EmccdSimple::new(-x, self.read_noise_e).expect("grid factors lie in (0, 1]"))
    }

    fn pilot(&self) -> Vec<f64> {
        PILOT_QE.iter().map(|q| -q).collect()
    }

    fn around(&self, x: f64) -> Vec<f64> {
        let q = (-x).min(Self::centre_max());
        // 1.18 x (1 / 1.18) may round above 1.
        FINAL_FACTORS
            .iter()
            .rev()
            .map(|f| -(f * q).min(1.0))
            .collect()
    }

    fn wide(&self, _x: f64) -> Vec<f64> {
        WIDE_QE.iter().map(|q| -q).collect()
    }

    fn at_foot(&self, x: f64) -> bool {
        x <= -1.0
    }

    fn value(&self, x: f64) -> f64 {
        -x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ascending(v: &[f64]) -> bool {
        v.windows(2).all(|w| w[0] < w[1])
    }

    #[test]
    fn grids_ascend_from_the_foot_and_stay_in_range() {
        let c = ConstantSigma { scale_e: 0.8 };
        let q = SimpleQe { read_noise_e: 0.1 };
        for f in [&c as &dyn Family, &q] {
            let pilot = f.pilot();
            assert_eq!(pilot.len(), PILOT_POINTS);
            assert!(ascending(&pilot) && f.at_foot(pilot[0]) && !f.at_foot(pilot[1]));
            let wide = f.wide(pilot[3]);
            assert!(ascending(&wide) && f.at_foot(wide[0]));
            for x in [pilot[1], pilot[4], pilot[7]] {
                let around = f.around(x);
                assert_eq!(around.len(), FINAL_POINTS);
                assert!(ascending(&around), "{around:?}");
            }
        }
        // A QE estimate near 1 keeps its bracket at or below q = 1; one at 0.5 is centred.
        let near_one = q.around(-0.97);
        assert_eq!(near_one[0], -1.0);
        assert!(near_one.iter().all(|&x| (-1.0..0.0).contains(&x)));
        assert_eq!(q.around(-0.5), [-0.59, -0.525, -0.475, -0.425]);
        assert_eq!((q.value(-0.4), c.value(0.4)), (0.4, 0.4));
        // The references are the family's readouts at the grid's parameters.
        assert_eq!(q.reference(-0.4).name(), "emccd-simple:0.4");
        assert_eq!(q.reference(-0.4).noise_scale_e(), 0.1);
        assert_eq!(c.reference(1.5).name(), "scmos-constant:1.5");
    }
}
