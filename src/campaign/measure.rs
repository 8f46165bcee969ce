//! Each stack of a campaign streamed once into its [`ConditionStats`], with `darks`'
//! accumulator (`calib::darks::pixel_stats`: O(frame) memory, the checksums taken from the
//! frames it reads), and for EMCCD darks the EM-gain histogram fit (`fit::emgain`) on a
//! histogram filled from the same pass.

use std::sync::Mutex;
use std::time::Instant;

use super::checks::CampaignPlan;
use super::condition::{ConditionStats, StackKind};
use super::input::CampaignStack;
use crate::calib::darks::{pixel_stats, pixel_stats_hashed, Clip, FrameHook};
use crate::calib::summary::{unhashed, Checksum, InputFile};
use crate::error::{Error, Result};
use crate::fit::emgain::{fit_emgain, EmGainFit, EmGainOptions, ValueHistogram};
use crate::io::FrameStack;
use crate::progress::Observer;

/// How to measure the stacks.
#[derive(Clone, Copy, Debug)]
pub struct MeasureOptions {
    /// Conversion gain (e- per adu): the noise figures in e- and the EM fit's gain in e-/e-.
    pub gain_e_per_adu: f64,
    /// Digest of every input file, taken from the frames read (None: no checksums).
    pub checksum: Option<Checksum>,
    /// Fit the EM-gain histogram model to each EMCCD dark stack.
    pub em_fit: bool,
}

/// What one stack gave.
#[derive(Debug)]
pub struct StackMeasurement {
    /// Its per-pixel moments and temporal noise split.
    pub stats: ConditionStats,
    /// Its files with their checksums.
    pub inputs: Vec<InputFile>,
    /// The EM-gain histogram fit of an EMCCD dark stack (Err: why it failed); None for other
    /// stacks or when not asked for.
    pub em_fit: Option<std::result::Result<EmGainFit, String>>,
    /// Bytes of sample data read, as stored.
    pub stored_bytes: u64,
    /// Wall-clock seconds spent reading and accumulating it.
    pub read_seconds: f64,
}

/// Measure every stack of `plan` in order, reporting the frames done to `observer` (one
/// stage, `campaign`); stops between stacks when the observer cancels.
pub fn measure_campaign(
    plan: &CampaignPlan,
    options: &MeasureOptions,
    observer: &dyn Observer,
) -> Result<Vec<StackMeasurement>> {
    let frames: usize = plan.opened.iter().map(|s| s.frames).sum();
    let pixels = (plan.shape.0 * plan.shape.1) as u64;
    observer.begin("campaign", frames as u64, frames as u64 * pixels);
    let mut out = Vec::with_capacity(plan.stacks.len());
    for (entry, stack) in plan.stacks.iter().zip(&plan.opened) {
        if observer.cancelled() {
            return Err(Error::Interrupted);
        }
        out.push(measure_stack(stack, entry, options)?);
        observer.advance(stack.frames as u64);
        if let Some(Err(why)) = &out.last().and_then(|m| m.em_fit.as_ref()) {
            observer.warn(&format!(
                "{}: EM-gain histogram fit failed ({why}); its gain and CIC are left empty",
                entry.files[0].display()
            ));
        }
    }
    observer.end();
    Ok(out)
}

/// Measure one stack (`entry`, opened as `stack`) in one pass over its files.
pub fn measure_stack(
    stack: &FrameStack,
    entry: &CampaignStack,
    options: &MeasureOptions,
) -> Result<StackMeasurement> {
    let wants_em = options.em_fit
        && entry.condition.kind == StackKind::Dark
        && entry.condition.em_gain.is_some();
    // The histogram is filled by the accumulator's frame hook, so the stack is read once.
    let width = if stack.sample_type.is_float() {
        0.25
    } else {
        1.0
    };
    let histogram = Mutex::new((ValueHistogram::new(width), None::<String>));
    let fill = |k: usize, frame: &mut [f64]| {
        let mut h = histogram.lock().expect("histogram lock");
        if h.1.is_none() {
            if let Err(e) = h.0.add_all(frame) {
                h.1 = Some(format!("stack frame {k}: {e}"));
            }
        }
        0.0
    };
    let hook: Option<FrameHook> = if wants_em { Some(&fill) } else { None };
    let t = Instant::now();
    let (stats, inputs) = match options.checksum {
        Some(algorithm) => pixel_stats_hashed(stack, Clip::None, hook, algorithm)?,
        None => (pixel_stats(stack, Clip::None, hook)?, unhashed(stack)),
    };
    let read_seconds = t.elapsed().as_secs_f64();
    let em_fit = wants_em.then(|| {
        let (h, failed) = histogram.into_inner().expect("histogram lock");
        match failed {
            Some(why) => Err(why),
            None => fit_emgain(
                &h,
                &EmGainOptions {
                    gain_e_per_adu: Some(options.gain_e_per_adu),
                    ..EmGainOptions::default()
                },
            )
            .map_err(|e| e.to_string()),
        }
    });
    let (rows, cols) = stack.shape;
    Ok(StackMeasurement {
        stats: ConditionStats {
            file: entry.files[0].clone(),
            condition: entry.condition,
            frames: stats.frames,
            rows,
            cols,
            var_adu2: stats.rms.data.iter().map(|s| s * s).collect(),
            mean_adu: stats.mean.data,
            temporal: stats.temporal.summary(Some(options.gain_e_per_adu)),
        },
        inputs,
        em_fit,
        stored_bytes: stack.stored_bytes(),
        read_seconds,
    })
}
