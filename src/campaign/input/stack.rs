//! One stack as an input lists it, and what the three inputs share: paths beside their list,
//! numbers, kinds, and the check of a condition.

use std::path::{Path, PathBuf};

use crate::campaign::condition::{Condition, StackKind};

/// One stack of a campaign as its input lists it: its files (one stack, in order) and the
/// condition it was taken at.
#[derive(Clone, Debug, PartialEq)]
pub struct CampaignStack {
    /// The stack's files, in frame order (one for a manifest or keyword entry; the images of
    /// one measurement point for an EMVA 1288 descriptor).
    pub files: Vec<PathBuf>,
    /// Its operating condition.
    pub condition: Condition,
    /// Where the input listed it: the manifest or descriptor and its line (1-based), or the
    /// stack file itself for keyword input, for messages.
    pub listed_in: Listed,
}

/// Where a stack was listed, for messages.
#[derive(Clone, Debug, PartialEq)]
pub struct Listed {
    /// The manifest, descriptor or stack file.
    pub source: PathBuf,
    /// Line of `source` (1-based), None for keyword input.
    pub line: Option<usize>,
}

impl Listed {
    /// " (manifest.csv line 3)", or "" for a stack that lists itself.
    pub fn describe(&self) -> String {
        match self.line {
            Some(l) => format!(" ({} line {l})", self.source.display()),
            None => String::new(),
        }
    }
}

/// `path` as a list file names it: relative paths are relative to the list's folder.
pub(crate) fn beside(list: &Path, path: &Path) -> PathBuf {
    if path.is_absolute() {
        return path.to_path_buf();
    }
    match list.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(path),
        _ => path.to_path_buf(),
    }
}

/// A finite number from `text`, or why not (`what` names the value).
pub(crate) fn number(text: &str, what: &str) -> std::result::Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("{what} {text:?} is not a finite number")),
    }
}

/// `dark` or `flat` (any case), or why not.
pub(crate) fn parse_kind(text: &str) -> std::result::Result<StackKind, String> {
    match text.trim().to_ascii_lowercase().as_str() {
        "dark" => Ok(StackKind::Dark),
        "flat" => Ok(StackKind::Flat),
        "" => Err("the 'kind' cell is empty: each stack is `dark` or `flat`".into()),
        other => Err(format!("kind {other:?} is neither `dark` nor `flat`")),
    }
}

/// Why `c` cannot be a condition (a negative exposure, an EM gain below 1, a dark with a light
/// level), if it cannot.
pub(crate) fn check_condition(c: &Condition) -> std::result::Result<(), String> {
    if c.exposure_s < 0.0 {
        return Err(format!("exposure_s {} is negative", c.exposure_s));
    }
    if let Some(g) = c.em_gain.filter(|g| *g < 1.0) {
        return Err(format!(
            "em_gain {g} is below 1 (the EM register multiplies)"
        ));
    }
    if let Some(l) = c.light_level.filter(|l| *l < 0.0) {
        return Err(format!("light_level {l} is negative"));
    }
    if c.kind == StackKind::Dark && c.light_level.is_some_and(|l| l != 0.0) {
        return Err(format!(
            "a dark with light_level {}: conflicting (a dark has no light; leave the cell empty)",
            c.light_level.unwrap_or(0.0)
        ));
    }
    Ok(())
}
