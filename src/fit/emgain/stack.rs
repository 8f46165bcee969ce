//! The histogram of a whole stack's pixel values, read one frame at a time with an optional
//! per-pixel bias map subtracted.

use super::histogram::ValueHistogram;
use crate::calib::Map;
use crate::error::{Error, Result};
use crate::io::FrameStack;

/// Histogram of every pixel-sample of `stack` (adu), one frame at a time, and the mean value
/// (adu). A bias map `offset` (adu) is subtracted pixel by pixel with its mean added back;
/// `width` is the bin width (adu; default 1 for integer data without a bias map, else 0.25).
/// Errors name the file of the frame (or the bias map) at fault.
pub fn accumulate(
    stack: &FrameStack,
    offset: Option<&Map>,
    width: Option<f64>,
) -> Result<(ValueHistogram, f64)> {
    accumulate_kept(stack, offset, width, None)
}

/// [`accumulate`] over the pixels whose `keep` entry is true only (row-major, one per pixel;
/// None keeps all): hot pixels' dark charge is not the one lambda the histogram model has.
pub fn accumulate_kept(
    stack: &FrameStack,
    offset: Option<&Map>,
    width: Option<f64>,
    keep: Option<&[bool]>,
) -> Result<(ValueHistogram, f64)> {
    if keep.is_some_and(|k| k.len() != stack.pixels()) {
        return Err(Error::invalid(
            "keep",
            format!(
                "the pixel mask has not the stack's {} pixels",
                stack.pixels()
            ),
        ));
    }
    let off = match offset {
        Some(m) => {
            if m.shape() != stack.shape {
                return Err(Error::input(
                    &m.source,
                    format!(
                        "frame 0: bias map {}x{} differs from the stack's {}x{}",
                        m.rows, m.cols, stack.shape.0, stack.shape.1
                    ),
                ));
            }
            // Every pixel needs a bias: a NaN would make its samples NaN, blamed on the stack.
            if let Some(i) = m.data.iter().position(|v| !v.is_finite()) {
                return Err(Error::input(
                    &m.source,
                    format!(
                        "frame 0: bias map value {} at row {}, column {}: every pixel needs a finite bias",
                        m.data[i],
                        i / m.cols,
                        i % m.cols
                    ),
                ));
            }
            let mean = m.finite_mean();
            Some(m.data.iter().map(|v| v - mean).collect::<Vec<f64>>())
        }
        None => None,
    };
    let width = match width {
        Some(w) if w > 0.0 && w.is_finite() => w,
        Some(_) => return Err(Error::invalid("bin_width_adu", "must be finite and > 0")),
        None if off.is_none() && !stack.sample_type.is_float() => 1.0,
        None => 0.25,
    };
    let mut hist = ValueHistogram::new(width);
    let mut frame = vec![0.0; stack.pixels()];
    let mut kept = Vec::new();
    let mut reader = stack.reader();
    while let Some(i) = reader.next_frame(&mut frame)? {
        if let Some(off) = &off {
            frame.iter_mut().zip(off).for_each(|(v, o)| *v -= o);
        }
        let values = match keep {
            Some(keep) => {
                kept.clear();
                kept.extend(frame.iter().zip(keep).filter(|(_, &k)| k).map(|(v, _)| *v));
                &kept
            }
            None => &frame,
        };
        hist.add_all(values)
            .map_err(|e| Error::input(stack.source_of(i), format!("stack frame {i}: {e}")))?;
    }
    let (mean, _) = hist.mean_var();
    Ok((hist, mean))
}
