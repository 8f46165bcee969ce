//! Effective read noise: the constant sigma whose Monte-Carlo error R equals a detector's, to a
//! stated precision (`precision`, `solve`, inverting R(sigma) in `invert`), how each value was
//! settled (`status`), and its table over a grid of configurations (`table`). The same solver
//! finds the effective QE factor of the paper's simple EMCCD model (`qe`): both match R
//! against a one-parameter family of reference readouts (`family`), and its table is
//! `qe_table`.

mod family;
mod invert;
mod precision;
mod qe;
mod qe_table;
mod random;
mod solve;
mod status;
mod table;

pub(crate) use invert::{invert, Inversion, Outside};
pub use precision::Precision;
pub use qe::{effective_qe, QeFactor, QePrecision, QeStatus};
pub use qe_table::{effective_qe_table, write_qe_tables, QeRecord, QE_TABLE_NAMES};
pub use random::{random_sigma, random_sigma_unpaired, EffectiveParts, RandomSigma};
pub use solve::{
    effective_sigma, effective_sigma_with, planned_work, planned_work_with, Effective,
};
pub use status::Status;
pub use table::{
    effective_table, effective_table_with, write_tables, EffectiveRecord, TABLE_NAMES,
};
