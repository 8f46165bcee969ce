//! Tests of the field -> flag map against the real parser and the library's sources.

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
    for (field, flag) in all_field_flags() {
        assert!(
            flags.contains(flag),
            "{field} maps to {flag}, no such option"
        );
        // A field of the registry is listed there alone.
        assert!(seen.insert(field), "{field} listed twice");
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
