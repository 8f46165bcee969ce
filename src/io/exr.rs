//! OpenEXR frames through the `exr` crate: one frame per channel of each layer, in file
//! order (layers in order, channels sorted by name as EXR stores them).
//!
//! `exr` hands back each channel in its stored type (F16, F32, U32); reading a U32 channel
//! as f32 would reinterpret bits, so every channel is converted according to its own type.
//! A multi-layer file is decoded whole on the first frame request (memory O(file)); use
//! one file per frame for long stacks.

use std::path::{Path, PathBuf};

use exr::meta::attribute::SampleType as ExrType;
use exr::meta::MetaData;
use exr::prelude::*;

use super::checks::{compressed_size_error, frame_error, MAX_EXPANSION};
use super::format::SampleType;
use super::frame::{to_u16, widen, FileFrames};
use crate::error::{Error, Result};

fn map_type(t: ExrType) -> SampleType {
    match t {
        ExrType::F16 => SampleType::F16,
        ExrType::F32 => SampleType::F32,
        ExrType::U32 => SampleType::U32,
    }
}

/// Decoded bytes of the largest level of one layer (every channel at its sampling), or
/// None on overflow.
fn layer_bytes(h: &exr::meta::header::Header) -> Option<u64> {
    let (w, ht) = (h.layer_size.width() as u64, h.layer_size.height() as u64);
    h.channels.list.iter().try_fold(0u64, |acc, c| {
        let (sx, sy) = (c.sampling.x().max(1) as u64, c.sampling.y().max(1) as u64);
        let samples = (w / sx).checked_mul(ht / sy)?;
        acc.checked_add(samples.checked_mul(c.sample_type.bytes_per_sample() as u64)?)
    })
}

/// Frame count, shape and sample type of an EXR file (headers only). The decoded size of
/// all layers (decoded together on the first frame) must fit in the file: in full when
/// uncompressed, within [`MAX_EXPANSION`] otherwise; so must the chunk offset tables.
pub fn scan(path: &Path) -> Result<(usize, (usize, usize), SampleType)> {
    let meta = MetaData::read_from_file(path, false)
        .map_err(|e| frame_error(path, 0, format!("cannot read EXR header: {e}")))?;
    let len = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    let mut frames = 0;
    let mut shape = None;
    let mut sample_type = SampleType::F32;
    let mut decoded = Some(0u64);
    let mut chunks = 0u64;
    let mut compressed = false;
    for (i, h) in meta.headers.iter().enumerate() {
        if h.deep {
            return Err(frame_error(
                path,
                frames,
                format!("layer {i} holds deep data, which is not supported"),
            ));
        }
        let s = (h.layer_size.height(), h.layer_size.width());
        match shape {
            None => {
                shape = Some(s);
                if let Some(c) = h.channels.list.first() {
                    sample_type = map_type(c.sample_type);
                }
            }
            Some(s0) if s0 != s => {
                return Err(frame_error(
                    path,
                    frames,
                    format!(
                        "layer {i} has shape {}x{}, earlier layers {}x{}",
                        s.0, s.1, s0.0, s0.1
                    ),
                ));
            }
            _ => {}
        }
        decoded = decoded
            .zip(layer_bytes(h))
            .and_then(|(a, b)| a.checked_add(b));
        chunks = chunks.saturating_add(h.chunk_count as u64);
        compressed |= h.compression != Compression::Uncompressed;
        frames += h.channels.list.len();
    }
    if chunks.saturating_mul(8) > len {
        return Err(frame_error(
            path,
            0,
            format!("file truncated or corrupt: the headers describe {chunks} chunks, whose offset tables alone need more than the file's {len} bytes"),
        ));
    }
    let limit = if compressed {
        len.saturating_mul(MAX_EXPANSION)
    } else {
        len
    };
    if decoded.is_none_or(|d| d > limit) {
        if compressed {
            return Err(compressed_size_error(path, 0, "the layers", decoded, len));
        }
        return Err(frame_error(
            path,
            0,
            format!(
                "file truncated or corrupt: the uncompressed layers need {} bytes, the file has {len}",
                decoded.map_or("more than 2^64".to_string(), |d| d.to_string())
            ),
        ));
    }
    Ok((frames, shape.unwrap_or((0, 0)), sample_type))
}

/// The frames of one EXR file.
pub struct ExrFrames {
    path: PathBuf,
    channels: Option<Vec<FlatSamples>>,
}

impl ExrFrames {
    /// Open `path` (decoding is deferred to the first frame request).
    pub fn open(path: &Path, _shape: (usize, usize)) -> Result<ExrFrames> {
        Ok(ExrFrames {
            path: path.to_path_buf(),
            channels: None,
        })
    }

    fn load(&mut self) -> Result<&[FlatSamples]> {
        if self.channels.is_none() {
            let image = read()
                .no_deep_data()
                .largest_resolution_level()
                .all_channels()
                .all_layers()
                .all_attributes()
                .from_file(&self.path)
                .map_err(|e| frame_error(&self.path, 0, format!("cannot decode EXR: {e}")))?;
            let channels = image
                .layer_data
                .into_iter()
                .flat_map(|l| l.channel_data.list.into_iter().map(|c| c.sample_data))
                .collect();
            self.channels = Some(channels);
        }
        Ok(self.channels.as_deref().expect("loaded above"))
    }
}

impl FileFrames for ExrFrames {
    fn read_frame(&mut self, k: usize, out: &mut [f64]) -> Result<()> {
        let path = self.path.clone();
        let channels = self.load()?;
        let Some(samples) = channels.get(k) else {
            return Err(frame_error(&path, k, "no such channel"));
        };
        match samples {
            FlatSamples::F16(v) => widen(&path, k, v, out),
            FlatSamples::F32(v) => widen(&path, k, v, out),
            FlatSamples::U32(v) => widen(&path, k, v, out),
        }
    }
}

/// Write frames as one EXR file with one layer per frame (`frame0000`, ...), each with one
/// channel `Y`: U32 for integer data (rounded, clamped to u16), F32 otherwise. Holds the
/// whole stack in memory: for small stacks.
pub fn write_layers(
    path: &Path,
    shape: (usize, usize),
    frames: usize,
    u16_samples: bool,
    next: &mut dyn FnMut() -> Vec<f64>,
) -> Result<()> {
    use crate::error::Error;
    let size = Vec2(shape.1, shape.0);
    let layers: Vec<_> = (0..frames)
        .map(|k| {
            let frame = next();
            let samples = if u16_samples {
                FlatSamples::U32(frame.iter().map(|x| to_u16(*x) as u32).collect())
            } else {
                FlatSamples::F32(frame.iter().map(|x| *x as f32).collect())
            };
            let channels =
                AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new("Y", samples)]));
            Layer::new(
                size,
                LayerAttributes::named(format!("frame{k:04}").as_str()),
                Encoding::SMALL_LOSSLESS,
                channels,
            )
        })
        .collect();
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions(size)),
        layers,
    );
    crate::output::write_atomic_with(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .map_err(|e| Error::io(tmp, std::io::Error::other(e.to_string())))
    })
}
