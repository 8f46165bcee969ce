//! The stacks of a campaign and the condition of each, read from one of three inputs: a CSV
//! manifest (`manifest`), FITS header keywords (`keywords`) or an EMVA 1288 descriptor file
//! (`emva`). Reading an input opens no frames; `checks` then refuses an inconsistent campaign.

mod emva;
mod keywords;
mod manifest;

use std::path::{Path, PathBuf};

use super::condition::Condition;
use crate::error::Result;

pub use emva::{parse_emva, read_emva_descriptor, EmvaFormat};
pub use keywords::{read_keywords, KeywordOptions};
pub use manifest::{parse_manifest, read_manifest, MANIFEST_COLUMNS};

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

/// What an input lists.
#[derive(Clone, Debug, PartialEq)]
pub struct Listing {
    /// The stacks, in the input's order.
    pub stacks: Vec<CampaignStack>,
    /// The frame shape (rows, cols) the input declares (an EMVA 1288 `n` line), if any.
    pub declared_shape: Option<(usize, usize)>,
}

/// Where a campaign's stacks and conditions come from.
#[derive(Clone, Debug)]
pub enum CampaignInput {
    /// A CSV manifest, one row per stack (columns [`MANIFEST_COLUMNS`]).
    Manifest(PathBuf),
    /// An EMVA 1288 descriptor file as the EMVA reference implementation reads it.
    Emva(PathBuf),
    /// FITS stacks whose headers give their conditions.
    Keywords {
        /// The FITS files, one stack each.
        files: Vec<PathBuf>,
        /// Which keywords hold the condition.
        options: KeywordOptions,
    },
}

impl CampaignInput {
    /// The stacks and conditions the input lists (FITS headers at most; no frame is read).
    pub fn read(&self) -> Result<Listing> {
        let (stacks, declared_shape) = match self {
            CampaignInput::Manifest(p) => (read_manifest(p)?, None),
            CampaignInput::Emva(p) => {
                let (format, stacks) = read_emva_descriptor(p)?;
                (stacks, format.map(|f| (f.height, f.width)))
            }
            CampaignInput::Keywords { files, options } => (read_keywords(files, options)?, None),
        };
        Ok(Listing {
            stacks,
            declared_shape,
        })
    }

    /// The file that lists the stacks (manifest or descriptor), if any.
    pub fn listing(&self) -> Option<&Path> {
        match self {
            CampaignInput::Manifest(p) | CampaignInput::Emva(p) => Some(p),
            CampaignInput::Keywords { .. } => None,
        }
    }
}

/// `path` as a list file names it: relative paths are relative to the list's folder.
fn beside(list: &Path, path: &Path) -> PathBuf {
    if path.is_absolute() {
        return path.to_path_buf();
    }
    match list.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(path),
        _ => path.to_path_buf(),
    }
}

/// A finite number from `text`, or why not (`what` names the value).
fn number(text: &str, what: &str) -> std::result::Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("{what} {text:?} is not a finite number")),
    }
}
