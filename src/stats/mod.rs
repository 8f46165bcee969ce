//! Statistics shared by the simulation and the calibration: exact samplers (`samplers`),
//! moments and regressions of samples (`moments`) and order statistics (`order`).
//!
//! Every median of the crate is [`median`] (the interpolating one), every percentile
//! [`percentile`].

mod moments;
mod order;
mod samplers;

pub use moments::{correlation, finite_mean, mean_var, robust_slope};
pub use order::{median, percentile, percentile_sorted, robust_sigma};
pub use samplers::{binomial_half, exp_neg, poisson, poisson_each};
