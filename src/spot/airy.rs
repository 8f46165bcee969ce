//! The Airy pattern: its intensity and the first zero of J1 that scales it.

/// First zero of J1: the Airy intensity (2 J1(v)/v)^2 vanishes first at v = 3.8317.
pub const J1_FIRST_ZERO: f64 = 3.831_705_970_207_512;

/// Normalised Airy intensity (2 J1(v)/v)^2, 1 at v = 0.
pub fn airy_intensity(v: f64) -> f64 {
    if v.abs() < 1e-8 {
        return 1.0;
    }
    let a = 2.0 * libm::j1(v) / v;
    a * a
}
