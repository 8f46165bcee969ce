//! Effective read noise: the constant sigma whose Monte-Carlo error R equals a detector's
//! (`solve`), and its table over a grid of configurations (`table`).

mod solve;
mod table;

pub use solve::{effective_sigma, Effective, Status};
pub use table::{effective_table, write_tables, EffectiveRecord, TABLE_NAMES};
