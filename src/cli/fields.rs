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
    // report (crate::report::ReportOptions)
    ("darks_paths", "--darks"),
    ("flats_paths", "--flats"),
    ("gain_e_per_adu", "--gain-e-per-adu"),
    ("subaps_px", "--subap"),
    ("spots", "--spot"),
    ("signals_photons", "--signal"),
    ("qe_emccd", "--qe-emccd"),
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
fn flags_in(message: &str) -> String {
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
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// Every long flag of every subcommand.
    fn all_flags() -> BTreeSet<String> {
        let cmd = super::super::command();
        std::iter::once(&cmd)
            .chain(cmd.get_subcommands())
            .flat_map(|c| c.get_arguments())
            .flat_map(|a| {
                let long = a.get_long().map(|l| format!("--{l}"));
                let value_names = a.get_value_names().unwrap_or_default().iter();
                let positional = a
                    .is_positional()
                    .then(|| value_names.map(|v| v.to_string()));
                long.into_iter().chain(positional.into_iter().flatten())
            })
            .collect()
    }

    #[test]
    fn every_mapped_flag_exists_and_fields_are_unique() {
        let flags = all_flags();
        let mut seen = BTreeSet::new();
        for (field, flag) in FIELD_FLAGS {
            assert!(
                flags.contains(*flag),
                "{field} maps to {flag}, no such option"
            );
            assert!(seen.insert(*field), "{field} listed twice");
        }
    }

    #[test]
    fn every_field_the_library_names_has_a_flag() {
        // Scan the library for `Error::invalid("field"` and `` `field` `` mentions of settings.
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut missing = BTreeSet::new();
        let mut stack = vec![root.clone()];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    if !path.ends_with("cli") {
                        stack.push(path);
                    }
                    continue;
                }
                let text = std::fs::read_to_string(&path).unwrap();
                for call in text.split("Error::invalid(").skip(1) {
                    let arg = call.trim_start();
                    if let Some(rest) = arg.strip_prefix('"') {
                        let field = &rest[..rest.find('"').unwrap()];
                        if !field.starts_with('-')
                            && flag_of(field).is_none()
                            && !LIBRARY_ONLY_FIELDS.contains(&field)
                        {
                            missing.insert(format!("{}: {field}", path.display()));
                        }
                    }
                }
            }
        }
        assert!(missing.is_empty(), "fields without a flag: {missing:?}");
    }

    #[test]
    fn errors_are_shown_with_flags() {
        let e = to_cli(Error::invalid(
            "out",
            "refused; choose another `out` or `force`",
        ));
        assert_eq!(
            e.to_string(),
            "invalid option --out: refused; choose another --out or --force"
        );
        let lib = Error::invalid("out", "x");
        assert_eq!(lib.to_string(), "invalid `out`: x");
    }
}
