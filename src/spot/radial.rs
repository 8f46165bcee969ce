//! The Airy intensity against radius, tabulated on a fine grid: point sampling interpolates it
//! linearly, the pixel table's quadrature cubically.

use super::airy::{airy_intensity, J1_FIRST_ZERO};
use super::cache::Footprint;

/// Grid steps per first-zero radius.
const STEPS_PER_RADIUS: f64 = 400.0;

/// Airy intensity (peak 1) against radius (px) at 1/400 of the first-zero radius per step.
#[derive(Clone)]
pub(super) struct RadialTable {
    inv_step: f64,
    values: Vec<f64>,
}

impl std::fmt::Debug for RadialTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RadialTable")
            .field("step_px", &(1.0 / self.inv_step))
            .field("len", &self.values.len())
            .finish()
    }
}

impl Footprint for RadialTable {
    fn bytes(&self) -> usize {
        self.values.len() * std::mem::size_of::<f64>()
    }
}

impl RadialTable {
    /// Table for a spot of first-dark-ring diameter `diameter_px`, radii up to `max_r_px`.
    pub(super) fn new(diameter_px: f64, max_r_px: f64) -> Self {
        let step = diameter_px / 2.0 / STEPS_PER_RADIUS;
        let count = (max_r_px / step).ceil() as usize + 2;
        let scale = J1_FIRST_ZERO / (diameter_px / 2.0);
        let values = (0..count)
            .map(|k| airy_intensity(k as f64 * step * scale))
            .collect();
        RadialTable {
            inv_step: 1.0 / step,
            values,
        }
    }

    /// Linear interpolation, 0 past the end. The error is at most h^2/8 max|I''| with h the step
    /// in v = 3.8317 r / (D/2): (3.8317/400)^2/8 x 1/2 = 5.7e-6 of the peak (|I''| <= 1/2, at
    /// the centre).
    pub(super) fn at(&self, r: f64) -> f64 {
        let t = r * self.inv_step;
        // As u32 (saturating: far radii stay past the end): one conversion each way, where
        // usize takes several on x86-64 without AVX-512.
        let k = t as u32;
        let i = k as usize;
        if i + 1 >= self.values.len() {
            return 0.0;
        }
        let f = t - f64::from(k);
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }

    /// Cubic (4-point Lagrange) interpolation, 0 past the end; the node before r = 0 is the
    /// one after it (the intensity is even). Error at most (9/16)/24 h^4 max|I''''| = 1.2e-10 of
    /// the peak (|I''''| <= 5/8).
    pub(super) fn at_cubic(&self, r: f64) -> f64 {
        let t = r * self.inv_step;
        let k = t as usize;
        if k + 2 >= self.values.len() {
            return 0.0;
        }
        let w = lagrange4(t - k as f64);
        let before = if k == 0 { 1 } else { k - 1 };
        w[0] * self.values[before]
            + w[1] * self.values[k]
            + w[2] * self.values[k + 1]
            + w[3] * self.values[k + 2]
    }
}

/// Weights of the cubic Lagrange interpolation at `t` in [0, 1] from nodes -1, 0, 1, 2: exact
/// for cubics, with error (t+1) t (t-1) (t-2) f''''/24 (at most 9/16 x h^4 max|f''''| / 24).
pub(super) fn lagrange4(t: f64) -> [f64; 4] {
    const SIXTH: f64 = 1.0 / 6.0;
    let (a, b, c, d) = (t + 1.0, t, t - 1.0, t - 2.0);
    [
        -b * c * d * SIXTH,
        a * c * d * 0.5,
        -a * b * d * 0.5,
        a * b * c * SIXTH,
    ]
}
