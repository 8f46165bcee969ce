//! Statistics shared by the simulation and the calibration: exact samplers (`samplers`),
//! moments and regressions of samples (`moments`) and order statistics (`order`).
//!
//! Every median of the crate is [`median`] (the interpolating one), every percentile
//! [`percentile`].

mod moments;
mod order;
mod samplers;

pub use moments::{correlation, finite_mean, mean_var, robust_slope};
#[cfg(test)]
pub(crate) use order::AWKWARD;
pub use order::{
    from_total_order_key, median, median_and_robust_sigma, percentile, percentile_sorted,
    robust_sigma, total_order_key,
};
pub use samplers::{binomial_half, exp_neg, poisson, poisson_each};
