//! A characterisation campaign: dark (and flat) stacks of one camera at several exposure
//! times, EM gains and temperatures, each streamed once to per-pixel moments
//! ([`ConditionStats`]), and the per-pixel decomposition of the mean dark into a fixed offset,
//! clock-induced charge and dark current with their standard errors.

mod condition;
pub mod fit;

pub use condition::{Condition, ConditionStats, StackKind};
