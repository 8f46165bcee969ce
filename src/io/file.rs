//! One file of a stack: its format detected, its header facts read by that format's reader
//! (per-format dispatch), and its frames opened.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::checks::{check_samples, prefix_frame, utf8_path};
use super::format::{SampleType, StackFormat};
use super::frame::FileFrames;
use super::{exr, fits, tiff};
use crate::error::{Error, Result};

/// Header facts about one file of a stack.
#[derive(Clone, Debug, Serialize)]
pub struct SourceFile {
    /// Path of the file.
    pub path: PathBuf,
    /// Its format.
    pub format: StackFormat,
    /// Number of frames it holds.
    pub frames: usize,
    /// Frame shape (rows, cols).
    pub shape: (usize, usize),
    /// Sample type as stored.
    pub sample_type: SampleType,
}

/// Header facts of the file at `path` (headers only; no sample is read).
pub(crate) fn scan_file(path: &Path) -> Result<SourceFile> {
    utf8_path(path)?;
    let format = StackFormat::detect(path)?;
    let (frames, shape, sample_type) = match format {
        StackFormat::Fits => fits::scan(path)?,
        StackFormat::Tiff => tiff::scan(path)?,
        StackFormat::Exr => exr::scan(path)?,
    };
    if frames == 0 {
        return Err(Error::input(path, "file holds no image frame"));
    }
    if shape.0 == 0 || shape.1 == 0 {
        return Err(Error::input(
            path,
            format!("frame 0: empty frame shape {}x{}", shape.0, shape.1),
        ));
    }
    // The readers bound every shape by the file size; this keeps `rows * cols * 8` exact.
    if shape
        .0
        .checked_mul(shape.1)
        .and_then(|p| p.checked_mul(8))
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(Error::input(
            path,
            format!("frame 0: frame shape {}x{} is too large", shape.0, shape.1),
        ));
    }
    Ok(SourceFile {
        path: path.to_path_buf(),
        format,
        frames,
        shape,
        sample_type,
    })
}

/// The frames of a scanned file, opened with its format's reader.
pub(crate) fn open_file(src: &SourceFile) -> Result<Box<dyn FileFrames>> {
    match src.format {
        StackFormat::Fits => Ok(Box::new(fits::FitsFrames::open(&src.path)?)),
        StackFormat::Tiff => Ok(Box::new(tiff::TiffFrames::open(
            &src.path, src.shape, src.frames,
        )?)),
        StackFormat::Exr => Ok(Box::new(exr::ExrFrames::open(&src.path, src.shape)?)),
    }
}

/// One image read whole: a map or a mask.
#[derive(Clone, Debug)]
pub struct Image {
    /// Shape (rows, cols).
    pub shape: (usize, usize),
    /// Values, row-major.
    pub data: Vec<f64>,
    /// The FITS BUNIT of its HDU, if stated (TIFF and EXR state no unit).
    pub bunit: Option<String>,
}

/// Read the one frame of a FITS, TIFF or EXR file as an image (e.g. a map or a mask), with
/// the unit its FITS header states. A file of several frames is refused, naming their count:
/// a stack is not a map, and which frame would be meant cannot be told. NaN is allowed (it
/// marks masked pixels); infinities and values beyond [`MAX_SAMPLE_ABS`](super::MAX_SAMPLE_ABS)
/// are not.
pub fn read_image(path: &Path) -> Result<Image> {
    let src = scan_file(path)?;
    if src.frames != 1 {
        return Err(Error::input(
            path,
            format!(
                "holds {} frames of {}x{}, where one image (a map or a mask) is expected: a \
                 frame stack is not a map (`detnoise darks` makes the maps of a dark stack)",
                src.frames, src.shape.0, src.shape.1
            ),
        ));
    }
    let mut data = vec![0.0; src.shape.0 * src.shape.1];
    let bunit = match src.format {
        StackFormat::Fits => {
            let mut f = fits::FitsFrames::open(path)?;
            f.read_frame(0, &mut data)?;
            f.bunit().map(str::to_string)
        }
        _ => {
            open_file(&src)?.read_frame(0, &mut data)?;
            None
        }
    };
    check_samples(path, src.shape.1, &data, true).map_err(|e| prefix_frame(e, 0))?;
    Ok(Image {
        shape: src.shape,
        data,
        bunit,
    })
}
