//! The standard's spectrograms: the power spectrum of each line of an image (its overall
//! mean removed), averaged over the lines; and the profiles across an image.

use rustfft::{num_complex::Complex64, FftPlanner};

/// Power spectrum (DN^2, one-sided bins 0..=len/2) of the rows of `image` (`shape` rows x
/// columns, row-major), or of its columns when `vertical`. Normalised by the line length, so
/// white noise of variance v gives v at every frequency.
pub fn line_power(image: &[f64], shape: (usize, usize), vertical: bool) -> Vec<f64> {
    let (rows, cols) = shape;
    let (lines, len) = if vertical { (cols, rows) } else { (rows, cols) };
    if lines == 0 || len == 0 {
        return Vec::new();
    }
    let mean = image.iter().sum::<f64>() / image.len() as f64;
    let fft = FftPlanner::<f64>::new().plan_fft_forward(len);
    let mut buf = vec![Complex64::new(0.0, 0.0); len];
    let mut power = vec![0.0; len / 2 + 1];
    for line in 0..lines {
        for (i, b) in buf.iter_mut().enumerate() {
            let y = if vertical {
                image[i * cols + line]
            } else {
                image[line * cols + i]
            };
            *b = Complex64::new(y - mean, 0.0);
        }
        fft.process(&mut buf);
        for (p, b) in power.iter_mut().zip(&buf) {
            *p += b.norm_sqr();
        }
    }
    let scale = 1.0 / (lines as f64 * len as f64);
    power.iter_mut().for_each(|p| *p *= scale);
    power
}

/// The frequencies (cycles per pixel) of [`line_power`]'s bins for lines of `len` pixels:
/// k / len, k = 0..=len/2.
pub fn frequencies(len: usize) -> Vec<f64> {
    (0..=len / 2).map(|k| k as f64 / len as f64).collect()
}

/// Profiles of an image along one direction (DN).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Profile {
    /// Mean over the lines crossed, per position.
    pub mean_dn: Vec<f64>,
    /// Minimum, per position.
    pub min_dn: Vec<f64>,
    /// Maximum, per position.
    pub max_dn: Vec<f64>,
    /// The middle line (row M/2 for the horizontal profile, column N/2 for the vertical).
    pub middle_dn: Vec<f64>,
}

/// The horizontal profile (per column, over the rows) or, when `vertical`, the vertical one
/// (per row, over the columns) of `image`.
pub fn profile(image: &[f64], shape: (usize, usize), vertical: bool) -> Profile {
    let (rows, cols) = shape;
    let (lines, len) = if vertical { (cols, rows) } else { (rows, cols) };
    let at = |line: usize, i: usize| {
        if vertical {
            image[i * cols + line]
        } else {
            image[line * cols + i]
        }
    };
    let mut p = Profile {
        mean_dn: vec![0.0; len],
        min_dn: vec![f64::INFINITY; len],
        max_dn: vec![f64::NEG_INFINITY; len],
        middle_dn: (0..len).map(|i| at(lines / 2, i)).collect(),
    };
    for line in 0..lines {
        for i in 0..len {
            let y = at(line, i);
            p.mean_dn[i] += y;
            p.min_dn[i] = p.min_dn[i].min(y);
            p.max_dn[i] = p.max_dn[i].max(y);
        }
    }
    p.mean_dn.iter_mut().for_each(|v| *v /= lines as f64);
    p
}
