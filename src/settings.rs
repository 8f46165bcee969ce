//! Every readout, run, centroider, precision and report setting defined once: the field it
//! fills, its Python keyword and command-line flag, unit, allowed values, default and one-line
//! help.
//!
//! The command line builds its options from these entries (`cli::settings`), Python checks its
//! keywords with the same [`Setting::check`], and errors name a setting by its field, which
//! each front end translates to the flag or keyword the user typed. Adding a setting is one
//! entry here, one line in its group, and its use. Tests hold every option of every command
//! (`cli::settings::tests`), the Python stubs (`tests/python_stubs.rs`) and Python's keywords
//! and signatures (`python/tests/test_settings.py`) to these entries.

mod entries;
mod setting;
mod value;

pub use entries::*;
pub use setting::{describe, parse_list, parse_real, parse_whole, Kind, Setting};
pub use value::{Value, Values};

/// Every setting of every group, each once.
pub fn all() -> impl Iterator<Item = &'static Setting> {
    GROUPS.iter().flat_map(|(_, group)| group.iter().copied())
}

/// The setting that fills library field `field`, if it is one of the registry's.
pub fn by_field(field: &str) -> Option<&'static Setting> {
    all().find(|s| s.field == field)
}

#[cfg(test)]
pub(crate) mod tests;
