//! The file format `synth` writes a stack in. Separate from the reader's detected
//! [`StackFormat`](crate::io::StackFormat), so that a format detnoise reads but does not
//! write (or the reverse) touches one side only.

use std::path::Path;

use serde::Serialize;

use crate::error::Result;
use crate::io::fits::Keyword;

/// File format of a synthetic stack.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum SynthFormat {
    /// FITS: one cube (NAXIS3 = frames).
    Fits,
    /// TIFF, one page per frame.
    Tiff,
    /// OpenEXR, one layer per frame.
    Exr,
}

impl SynthFormat {
    /// Every format.
    pub const ALL: [SynthFormat; 3] = [SynthFormat::Fits, SynthFormat::Tiff, SynthFormat::Exr];

    /// File extensions a stack written in this format takes (lower case, without the dot).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            SynthFormat::Fits => &["fits", "fit"],
            SynthFormat::Tiff => &["tif", "tiff"],
            SynthFormat::Exr => &["exr"],
        }
    }

    /// Write `frames` frames of `shape` (rows, cols), each from `next`, to `path` atomically,
    /// as unsigned 16-bit integers when `u16_samples` (else 32-bit floats); `keys` go into
    /// the FITS header (TIFF and OpenEXR carry none).
    pub fn write(
        self,
        path: &Path,
        shape: (usize, usize),
        frames: usize,
        u16_samples: bool,
        next: &mut dyn FnMut() -> Vec<f64>,
        keys: &[Keyword],
    ) -> Result<()> {
        match self {
            SynthFormat::Fits => {
                crate::io::fits::write_cube(path, shape, frames, u16_samples, next, keys)
            }
            SynthFormat::Tiff => {
                crate::io::tiff::write_pages(path, shape, frames, u16_samples, next)
            }
            SynthFormat::Exr => {
                crate::io::exr::write_layers(path, shape, frames, u16_samples, next)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_format_is_named_in_lower_case_as_the_manifest_and_option_spell_it() {
        let names: Vec<String> = SynthFormat::ALL
            .iter()
            .map(|f| serde_json::to_string(f).unwrap())
            .collect();
        assert_eq!(names, ["\"fits\"", "\"tiff\"", "\"exr\""]);
        for f in SynthFormat::ALL {
            assert!(f.extensions().iter().all(|e| *e == e.to_lowercase()));
        }
    }
}
