//! The stacks of a campaign and the condition of each, read from one of three inputs: a CSV
//! manifest (`manifest`), FITS header keywords (`keywords`) or an EMVA 1288 descriptor file
//! (`emva`). Reading an input opens no frames; `checks` then refuses an inconsistent campaign.

mod emva;
mod keywords;
mod manifest;
mod stack;

use std::path::{Path, PathBuf};

use crate::error::Result;

pub use emva::{parse_emva, read_emva_descriptor, EmvaFormat};
pub use keywords::{read_keywords, KeywordOptions};
pub use manifest::{parse_manifest, read_manifest, MANIFEST_COLUMNS};
pub use stack::{CampaignStack, Listed};

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
