//! Effective read noise: the constant sigma whose Monte-Carlo error R equals a detector's, to a
//! stated precision (`precision`, `solve`, inverting R(sigma) in `invert`), how each value was settled (`status`), and its
//! table over a grid of configurations (`table`).

mod invert;
mod precision;
mod solve;
mod status;
mod table;

pub use precision::Precision;
pub use solve::{effective_sigma, effective_sigma_with, planned_work, Effective};
pub use status::Status;
pub use table::{
    effective_table, effective_table_with, write_tables, EffectiveRecord, TABLE_NAMES,
};
