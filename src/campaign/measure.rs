//! Each stack of a campaign streamed once into its [`ConditionStats`], with `darks`'
//! accumulator (`calib::darks::pixel_stats`: O(frame) memory, the checksums taken from the
//! frames it reads), and for EMCCD darks the EM-gain histogram fit (`fit::emgain`) in a second
//! pass with each pixel's offset subtracted.
//!
//! Why a second pass: a camera's per-pixel offsets (fixed pattern, column slopes) spread the
//! zero-electron peak of a raw histogram, and the fit reads that spread as EM events. On a
//! 32x32 fixture with an 8.5 adu offset spread (read noise 5 adu) the one-pass fit gave G = 209,
//! 390 and 1217 for commanded gains of 50, 200 and 800. The offsets are known only once every
//! stack has been read (the decomposition's F), so EMCCD dark stacks are read twice.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::Instant;

use super::checks::CampaignPlan;
use super::condition::{ConditionStats, StackKind};
use super::input::CampaignStack;
use crate::calib::darks::{
    mean_common_level, pixel_stats, pixel_stats_hashed, take_common_level, Clip, FrameHook,
};
use crate::calib::summary::{unhashed, Checksum, InputFile};
use crate::calib::Map;
use crate::error::{Error, Result};
use crate::fit::emgain::{
    accumulate_kept, fit_emgain, zero_peak_lambda, EmGainFit, EmGainOptions, LambdaMixture,
    SerialCic, DEFAULT_MIXTURE_GROUPS,
};
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
    /// Rejection of outlying samples per pixel (cosmic rays), as `darks --clip/--sigma-clip`.
    pub clip: Clip,
    /// Take each frame's common level (median, exact for integer data) off before
    /// accumulating, as `darks --common-mode`; the mean level taken off is added back to the
    /// per-pixel means, so the dark signal stays in them and only the frame-common noise goes.
    pub common_mode: bool,
}

/// What one stack gave.
#[derive(Debug)]
pub struct StackMeasurement {
    /// Its per-pixel moments and temporal noise split.
    pub stats: ConditionStats,
    /// Its files with their checksums.
    pub inputs: Vec<InputFile>,
    /// The EM-gain histogram fit of an EMCCD dark stack (Err: why it failed); None for other
    /// stacks, when not asked for, and until [`fit_em_gains`] has run.
    pub em_fit: Option<std::result::Result<EmGainFit, String>>,
    /// Bytes of sample data read, as stored.
    pub stored_bytes: u64,
    /// Wall-clock seconds spent reading and accumulating it.
    pub read_seconds: f64,
}

/// Stacks measured at once. A stack's tail (its sums turned into maps, its checksums
/// finished) leaves the reading thread idle, and its start waits for the first frames; with
/// two stacks in flight the next one is read meanwhile. Each stack's figures are its own
/// (the same whatever else runs), and memory is two stacks' accumulators, still O(frame).
const IN_FLIGHT: usize = 2;

/// Measure every stack of `plan` ([`IN_FLIGHT`] at a time, results in input order),
/// reporting the frames done to `observer` (one stage, `campaign`); stops starting stacks
/// when the observer cancels. On failures, the error of the first failing stack in input
/// order is returned, as if they had been measured one by one.
pub fn measure_campaign(
    plan: &CampaignPlan,
    options: &MeasureOptions,
    observer: &dyn Observer,
) -> Result<Vec<StackMeasurement>> {
    let frames: usize = plan.opened.iter().map(|s| s.frames).sum();
    let pixels = (plan.shape.0 * plan.shape.1) as u64;
    observer.begin("campaign", frames as u64, frames as u64 * pixels);
    let n = plan.stacks.len();
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let mut done: Vec<Option<Result<StackMeasurement>>> = (0..n).map(|_| None).collect();
    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel();
        for _ in 0..IN_FLIGHT.min(n) {
            let tx = tx.clone();
            let (next, stop) = (&next, &stop);
            // Stacks are taken in input order, so every stack before a failing one has been
            // started and is finished before the scope ends.
            s.spawn(move || loop {
                if stop.load(Ordering::Relaxed) || observer.cancelled() {
                    return;
                }
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= n {
                    return;
                }
                let m = measure_stack(&plan.opened[i], &plan.stacks[i], options);
                if tx.send((i, m)).is_err() {
                    return;
                }
            });
        }
        drop(tx);
        for (i, m) in rx {
            match &m {
                Ok(_) => observer.advance(plan.opened[i].frames as u64),
                Err(_) => stop.store(true, Ordering::Relaxed),
            }
            done[i] = Some(m);
        }
    });
    let mut out = Vec::with_capacity(n);
    for m in done {
        match m {
            Some(m) => out.push(m?),
            // Not started: the observer cancelled (a failure stops at a started stack).
            None => return Err(Error::Interrupted),
        }
    }
    observer.end();
    Ok(out)
}

/// Whether `entry` gets the EM-gain histogram fit under `options`.
pub(super) fn wants_em_fit(entry: &CampaignStack, options: &MeasureOptions) -> bool {
    options.em_fit && entry.condition.kind == StackKind::Dark && entry.condition.em_gain.is_some()
}

/// Fit the EM-gain histogram model to every EMCCD dark stack of `plan` (a second pass over
/// each), with `offset_adu` (each pixel's fixed offset, NaN where unknown: the stack's own
/// mean is used there) subtracted, over the pixels `keep` marks (warm and hot pixels hold a
/// dark charge far from the rest); failures are warnings kept in `em_fit`.
///
/// The kept pixels' dark charges differ (dark current varies from pixel to pixel): the light
/// term is the mixture of their mean signals in the stack ([`LambdaMixture`], the signals'
/// sampling noise drawn in), which a single lambda would read as gain. Serial CIC belongs to
/// the register's clocking at a gain, not to one stack: when the model comparison finds it in
/// a stack, the stacks of that EM gain where it did not are fitted again with it (a fit
/// without it reads its events as charge of a lower gain), unless that fit's rate comes out
/// negative (serial events hidden in the read noise, at low gain). Each fit carries the
/// zero-electron peak's estimate of the mean charge beside its own (`zero_peak`).
pub fn fit_em_gains(
    plan: &CampaignPlan,
    stacks: &mut [StackMeasurement],
    offset_adu: &[f64],
    keep: &[bool],
    options: &MeasureOptions,
    observer: &dyn Observer,
) -> Result<()> {
    let todo: Vec<usize> = (0..stacks.len())
        .filter(|&i| wants_em_fit(&plan.stacks[i], options))
        .collect();
    let frames: usize = todo.iter().map(|&i| plan.opened[i].frames).sum();
    let pixels = (plan.shape.0 * plan.shape.1) as u64;
    observer.begin("EM gain fits", frames as u64, frames as u64 * pixels);
    let mut fits = Vec::with_capacity(todo.len());
    for &i in &todo {
        if observer.cancelled() {
            return Err(Error::Interrupted);
        }
        let (stack, m) = (&plan.opened[i], &stacks[i]);
        let bias = bias_map(offset_adu, &m.stats);
        let opts = EmGainOptions {
            gain_e_per_adu: Some(options.gain_e_per_adu),
            lambda_mixture: charge_mixture(&m.stats, &bias, keep),
            ..EmGainOptions::default()
        };
        let fit = accumulate_kept(stack, Some(&bias), None, Some(keep))
            .and_then(|(h, _)| fit_emgain(&h, &opts).map(|f| (h, f)));
        fits.push((opts, fit));
        observer.advance(stack.frames as u64);
    }
    observer.end();
    let gain = |i: usize| plan.stacks[i].condition.em_gain;
    let serial_at: Vec<Option<f64>> = todo
        .iter()
        .zip(&fits)
        .filter(|(_, (_, f))| f.as_ref().is_ok_and(|f| serial_present(&f.1)))
        .map(|(&i, _)| gain(i))
        .collect();
    for (&i, (opts, fit)) in todo.iter().zip(fits) {
        let name = plan.stacks[i].files[0].display();
        let fit = fit.map(|(h, mut f)| {
            if serial_at.contains(&gain(i)) && !serial_present(&f) {
                let on = EmGainOptions {
                    serial_cic: SerialCic::On,
                    ..opts
                };
                match fit_emgain(&h, &on) {
                    Ok(with) if with.serial_cic_e.is_some_and(|r| r >= 0.0) => f = with,
                    Ok(with) => observer.warn(&format!(
                        "{name}: the fit with the serial CIC found at its EM gain gives a rate of {:.4} e-; kept the fit without",
                        with.serial_cic_e.unwrap_or(f64::NAN)
                    )),
                    Err(why) => observer.warn(&format!(
                        "{name}: no fit with the serial CIC found at its EM gain ({why}); kept the fit without"
                    )),
                }
            }
            match zero_peak_lambda(&h, &f) {
                Ok(z) => f.zero_peak = Some(z),
                Err(why) => observer.warn(&format!(
                    "{name}: no zero-peak estimate of the mean charge ({why})"
                )),
            }
            f
        });
        if let Err(why) = &fit {
            observer.warn(&format!(
                "{name}: EM-gain histogram fit failed ({why}); its gain and CIC are left empty"
            ));
        }
        stacks[i].em_fit = Some(fit.map_err(|e| e.to_string()));
    }
    Ok(())
}

/// Whether a fit kept serial CIC in its model.
fn serial_present(fit: &EmGainFit) -> bool {
    fit.serial_cic_test.as_ref().is_some_and(|t| t.present)
}

/// The kept pixels' spread of mean charge in one stack: their mean signals above `bias`
/// (adu), whose sampling noise (the mean variance / frames) is drawn in.
fn charge_mixture(stats: &ConditionStats, bias: &Map, keep: &[bool]) -> Option<LambdaMixture> {
    let kept = || (0..keep.len()).filter(|&i| keep[i] && stats.mean_adu[i].is_finite());
    let signal: Vec<f64> = kept().map(|i| stats.mean_adu[i] - bias.data[i]).collect();
    let var: Vec<f64> = kept().map(|i| stats.var_adu2[i]).collect();
    let noise = var.iter().sum::<f64>() / var.len().max(1) as f64 / stats.frames as f64;
    LambdaMixture::from_estimates(&signal, noise, DEFAULT_MIXTURE_GROUPS)
}

/// Each pixel's offset (adu) as a map: `offset_adu`, or the stack's own mean where that is
/// not finite (a pixel the decomposition did not fit).
fn bias_map(offset_adu: &[f64], stats: &ConditionStats) -> Map {
    let data = offset_adu
        .iter()
        .zip(&stats.mean_adu)
        .map(|(&f, &m)| if f.is_finite() { f } else { m })
        .collect();
    let mut map = Map::new(stats.rows, stats.cols, data, crate::calib::Unit::Adu);
    map.source = format!("the offset map fitted for {}", stats.file.display());
    map
}

/// Measure one stack (`entry`, opened as `stack`) in one pass over its files.
pub fn measure_stack(
    stack: &FrameStack,
    entry: &CampaignStack,
    options: &MeasureOptions,
) -> Result<StackMeasurement> {
    let t = Instant::now();
    let hook: Option<FrameHook> = options.common_mode.then_some(&take_common_level);
    let (stats, inputs) = match options.checksum {
        Some(algorithm) => pixel_stats_hashed(stack, options.clip, hook, algorithm)?,
        None => (pixel_stats(stack, options.clip, hook)?, unhashed(stack)),
    };
    let common = mean_common_level(&stats.per_frame);
    let read_seconds = t.elapsed().as_secs_f64();
    let (rows, cols) = stack.shape;
    Ok(StackMeasurement {
        stats: ConditionStats {
            file: entry.files[0].clone(),
            condition: entry.condition,
            frames: stats.frames,
            rows,
            cols,
            var_adu2: stats.rms.data.iter().map(|s| s * s).collect(),
            mean_adu: stats.mean.data.iter().map(|m| m + common).collect(),
            temporal: stats.temporal.summary(Some(options.gain_e_per_adu)),
        },
        inputs,
        em_fit: None,
        stored_bytes: stack.stored_bytes(),
        read_seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::{check_campaign, CampaignInput};
    use crate::progress::Silent;

    #[test]
    fn stacks_measured_at_once_give_each_stack_its_own_figures_in_input_order() {
        let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/campaign/scmos/manifest.csv");
        let plan = check_campaign(CampaignInput::Manifest(manifest).read().unwrap()).unwrap();
        assert!(
            plan.stacks.len() > IN_FLIGHT,
            "more stacks than measured at once"
        );
        let options = MeasureOptions {
            gain_e_per_adu: 1.0,
            checksum: Some(Checksum::Blake3),
            em_fit: false,
            // The frame hook runs on the measuring threads too.
            clip: Clip::None,
            common_mode: true,
        };
        let all = measure_campaign(&plan, &options, &Silent).unwrap();
        assert_eq!(all.len(), plan.stacks.len());
        for ((m, entry), stack) in all.iter().zip(&plan.stacks).zip(&plan.opened) {
            let one = measure_stack(stack, entry, &options).unwrap();
            assert_eq!(m.stats.file, entry.files[0]);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&m.stats.mean_adu), bits(&one.stats.mean_adu));
            assert_eq!(bits(&m.stats.var_adu2), bits(&one.stats.var_adu2));
            assert_eq!(m.stats.temporal, one.stats.temporal);
            assert!(m.inputs[0].blake3.is_some());
            assert_eq!(m.inputs[0].blake3, one.inputs[0].blake3);
        }
    }
}
