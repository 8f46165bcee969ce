//! Library field names -> command-line flags, so that errors name the option the user typed.
//!
//! The library names its settings by field (`emccd_read_noise_e`); the command line spells them
//! as flags (`--emccd-read-noise`). A setting with two spellings across commands maps to one
//! field per meaning, so each field has exactly one flag.

use crate::Error;

/// Every library field that an error can name, with the flag that sets it on the command line.
pub const FIELD_FLAGS: &[(&str, &str)] = &[
    ("out", "--out"),
    ("force", "--force"),
    ("qe", "--qe"),
    ("stacks", "STACK"),
    // Monte-Carlo configurations, spots, output files (montecarlo, spot, output).
    ("subap_px", "--subap"),
    ("spot", "--spot"),
    ("signal_photons", "--signal"),
    ("iters", "--iters"),
    ("bg_grid", "--bg-grid"),
    ("position_half_range_px", "--position-range"),
    ("max_empty_frac", "--max-empty-frac"),
    ("plot", "--plot"),
];

/// Fields of library-only settings (chart building blocks) that no option sets: errors about
/// them are programming errors of a caller and keep the library's name.
pub const LIBRARY_ONLY_FIELDS: &[&str] = &[
    "axis_range",
    "heatmap_values",
    "hist_range",
    "hist_edges",
    "image_grid",
    "chart_path",
    "chart_size_px",
];

/// The flag of library field `field`, if it has one.
pub fn flag_of(field: &str) -> Option<&'static str> {
    FIELD_FLAGS
        .iter()
        .find(|(f, _)| *f == field)
        .map(|(_, flag)| *flag)
}

/// `message` with every `` `field` `` mention replaced by its flag.
pub fn flags_in(message: &str) -> String {
    FIELD_FLAGS
        .iter()
        .fold(message.to_string(), |m, (field, flag)| {
            m.replace(&format!("`{field}`"), flag)
        })
}

/// The error as the command line shows it: library fields replaced by their flags.
pub fn to_cli(e: Error) -> Error {
    match e {
        Error::Usage { field, message } => Error::Usage {
            field: flag_of(&field).map(str::to_string).unwrap_or(field),
            message: flags_in(&message),
        },
        Error::Input { path, message } => Error::Input {
            path,
            message: flags_in(&message),
        },
        Error::Numeric(message) => Error::Numeric(flags_in(&message)),
        io @ Error::Io { .. } => io,
    }
}

#[cfg(test)]
mod tests;
