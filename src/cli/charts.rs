pub use crate::report::charts::*;
