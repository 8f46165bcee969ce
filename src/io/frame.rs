//! One frame as the per-format readers deliver it: decoded values, or stored integer bytes
//! with the layout that decodes them later, where the values are used.

use std::path::Path;

use super::checks::frame_error;
use crate::error::{Error, Result};

/// Reads the frames of one file in order; implemented per format.
pub(crate) trait FileFrames {
    /// Read frame `k` (0-based within the file) into `out` (row-major, rows*cols values).
    /// Frames are requested in increasing order.
    fn read_frame(&mut self, k: usize, out: &mut [f64]) -> Result<()>;

    /// Whether frame `k` can hold NaN/Inf or values beyond [`MAX_SAMPLE_ABS`](super::MAX_SAMPLE_ABS) (false for
    /// plain integer storage, which skips the check).
    fn may_be_out_of_range(&self, _k: usize) -> bool {
        true
    }

    /// Layout of frame `k` when its stored bytes can be handed over undecoded (plain integers).
    fn raw_layout(&self, _k: usize) -> Option<RawLayout> {
        None
    }

    /// Read the stored bytes of frame `k` (only when `raw_layout(k)` is Some); returns their
    /// byte offset in the file.
    fn read_raw(&mut self, k: usize, _bytes: &mut Vec<u8>) -> Result<u64> {
        Err(Error::Numeric(format!(
            "frame {k}: no raw read for this format"
        )))
    }
}

/// Integer storage of raw frame bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawKind {
    /// Unsigned 8-bit.
    U8,
    /// Signed 16-bit.
    I16,
    /// Signed 32-bit.
    I32,
    /// Signed 64-bit.
    I64,
}

/// How stored frame bytes map to values: value = stored x scale + zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawLayout {
    /// Integer type of a sample.
    pub kind: RawKind,
    /// Big-endian byte order (FITS).
    pub big_endian: bool,
    /// Multiplier (FITS BSCALE).
    pub scale: f64,
    /// Offset (FITS BZERO).
    pub zero: f64,
}

impl RawLayout {
    /// Bytes per sample.
    pub fn width(&self) -> usize {
        match self.kind {
            RawKind::U8 => 1,
            RawKind::I16 => 2,
            RawKind::I32 => 4,
            RawKind::I64 => 8,
        }
    }

    /// Decode `bytes` (a whole number of samples) into `out`, as many samples as both hold.
    /// Always inlined, so that callers compiled for wider vectors decode with them.
    #[inline(always)]
    pub fn decode(&self, bytes: &[u8], out: &mut [f64]) {
        let (scale, zero) = (self.scale, self.zero);
        // One loop per type and byte order: each vectorises (byte swap and conversion of a
        // vector of samples at a time).
        macro_rules! dec {
            ($t:ty, $n:expr) => {
                if self.big_endian {
                    fill::<$n>(out, bytes, scale, zero, |a| <$t>::from_be_bytes(a) as f64)
                } else {
                    fill::<$n>(out, bytes, scale, zero, |a| <$t>::from_le_bytes(a) as f64)
                }
            };
        }
        match self.kind {
            RawKind::U8 => dec!(u8, 1),
            RawKind::I16 => dec!(i16, 2),
            RawKind::I32 => dec!(i32, 4),
            RawKind::I64 => dec!(i64, 8),
        }
    }
}

/// `out[i] = stored(sample i of bytes) x scale + zero`. Multiplying by a scale of 1 is exact,
/// so that case skips it and gives the same values.
#[inline(always)]
fn fill<const N: usize>(
    out: &mut [f64],
    bytes: &[u8],
    scale: f64,
    zero: f64,
    stored: impl Fn([u8; N]) -> f64,
) {
    let samples = bytes
        .chunks_exact(N)
        .map(|c| <[u8; N]>::try_from(c).expect("N bytes"));
    if scale == 1.0 {
        for (o, a) in out.iter_mut().zip(samples) {
            *o = stored(a) + zero;
        }
    } else {
        for (o, a) in out.iter_mut().zip(samples) {
            *o = stored(a) * scale + zero;
        }
    }
}

/// Where a frame came from: its index in the stack, the file holding it, and for stored bytes
/// handed over undecoded, their byte offset in that file (so the bytes can be checksummed
/// without reading them again).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameOrigin {
    /// Frame index in the stack (0-based).
    pub index: usize,
    /// Index of its file in the stack's `sources`.
    pub source: usize,
    /// Byte offset of the stored bytes in the file (raw frames only).
    pub offset: Option<u64>,
}

/// One frame as a stack reader delivers it
/// ([`next_frame_data`](super::StackReader::next_frame_data)): decoded values, or stored
/// integer bytes with their layout (decoded later, where the values are used).
#[derive(Clone, Debug)]
pub enum FrameData {
    /// Row-major values.
    Values(Vec<f64>),
    /// Row-major stored bytes and how to decode them.
    Raw(Vec<u8>, RawLayout),
}

impl FrameData {
    /// Turn a raw frame into values in place.
    pub fn decode_in_place(&mut self) {
        if let FrameData::Raw(bytes, layout) = self {
            let mut v = vec![0.0; bytes.len() / layout.width()];
            layout.decode(bytes, &mut v);
            *self = FrameData::Values(v);
        }
    }

    /// Pixels of the frame.
    pub fn pixels(&self) -> usize {
        match self {
            FrameData::Values(v) => v.len(),
            FrameData::Raw(bytes, layout) => bytes.len() / layout.width(),
        }
    }

    /// Values `start..end`: a slice of a decoded frame, or a raw frame's bytes decoded into
    /// `buf` (at least `end - start` long), so that a block stays in cache.
    #[inline(always)]
    pub fn block<'a>(&'a self, start: usize, end: usize, buf: &'a mut [f64]) -> &'a [f64] {
        match self {
            FrameData::Values(v) => &v[start..end],
            FrameData::Raw(bytes, layout) => {
                let w = layout.width();
                let out = &mut buf[..end - start];
                layout.decode(&bytes[start * w..end * w], out);
                out
            }
        }
    }

    /// The values of a decoded frame (panics on a raw frame: call `decode_in_place` first).
    pub fn values(&self) -> &[f64] {
        match self {
            FrameData::Values(v) => v,
            FrameData::Raw(..) => panic!("frame not decoded"),
        }
    }

    /// Mutable values of a decoded frame (panics on a raw frame).
    pub fn values_mut(&mut self) -> &mut [f64] {
        match self {
            FrameData::Values(v) => v,
            FrameData::Raw(..) => panic!("frame not decoded"),
        }
    }
}

/// Copy any numeric slice into an f64 buffer, checking the length.
pub(crate) fn widen<T: Copy + Into<f64>>(
    path: &Path,
    k: usize,
    src: &[T],
    out: &mut [f64],
) -> Result<()> {
    if src.len() != out.len() {
        return Err(frame_error(
            path,
            k,
            format!("{} samples decoded, {} expected", src.len(), out.len()),
        ));
    }
    for (o, s) in out.iter_mut().zip(src) {
        *o = (*s).into();
    }
    Ok(())
}

/// Round and clamp to the u16 range (the writers' integer storage).
pub(crate) fn to_u16(x: f64) -> u16 {
    x.round().clamp(0.0, u16::MAX as f64) as u16
}

/// Define `fn NAME(ARGS) -> RET { BODY }` compiled three times (AVX-512F, AVX2, the
/// baseline) and dispatched at run time on the CPU's features: loops in the body, and those
/// inlined into it (such as [`RawLayout::decode`], always inlined), are vectorised with the
/// widest registers. Every version does the same IEEE operations in the same order (no fused
/// multiply-add is enabled), so the results do not depend on the CPU.
macro_rules! widest {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn baseline($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f")]
                unsafe fn avx512($($arg: $ty),*) $(-> $ret)? {
                    baseline($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                unsafe fn avx2($($arg: $ty),*) $(-> $ret)? {
                    baseline($($arg),*)
                }
                if std::arch::is_x86_feature_detected!("avx512f") {
                    // SAFETY: the CPU supports AVX-512F (checked just above).
                    return unsafe { avx512($($arg),*) };
                }
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU supports AVX2 (checked just above).
                    return unsafe { avx2($($arg),*) };
                }
            }
            baseline($($arg),*)
        }
    };
}
pub(crate) use widest;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_layouts_decode_both_byte_orders_with_scale_and_zero() {
        // FITS unsigned 16-bit: int16 with BZERO 32768, big-endian.
        let be = RawLayout {
            kind: RawKind::I16,
            big_endian: true,
            scale: 1.0,
            zero: 32768.0,
        };
        let mut out = [0.0; 2];
        be.decode(&[0x80, 0x00, 0x7f, 0xff], &mut out);
        assert_eq!(out, [0.0, 65535.0]);
        let le = RawLayout {
            kind: RawKind::I32,
            big_endian: false,
            scale: 0.5,
            zero: -1.0,
        };
        let mut out = [0.0; 1];
        le.decode(&(-6i32).to_le_bytes(), &mut out);
        assert_eq!(out, [-4.0]);
        let widths = [RawKind::U8, RawKind::I16, RawKind::I32, RawKind::I64]
            .map(|kind| RawLayout { kind, ..be }.width());
        assert_eq!(widths, [1, 2, 4, 8]);
        let u8s = RawLayout {
            kind: RawKind::U8,
            scale: 2.0,
            zero: 1.0,
            ..be
        };
        let mut f = FrameData::Raw(vec![1, 2], u8s);
        f.decode_in_place();
        assert_eq!(f.values(), [3.0, 5.0]);
    }

    #[test]
    fn stored_integers_round_and_clamp() {
        let got = [-3.0, 1.5, 2.4, 70000.0].map(to_u16);
        assert_eq!(got, [0, 2, 2, 65535]);
        let mut out = [0.0; 2];
        assert!(widen(Path::new("a.tif"), 3, &[1u16], &mut out).is_err());
        widen(Path::new("a.tif"), 3, &[1u16, 7], &mut out).unwrap();
        assert_eq!(out, [1.0, 7.0]);
    }
}
