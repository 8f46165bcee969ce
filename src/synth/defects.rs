//! The non-Gaussian noise of a synthetic sCMOS: random-telegraph (RTS) pixels, row and
//! column noise and hot pixels, with known parameters.
//!
//! Which pixels are RTS or hot, and an RTS pixel's level heights and starting level, come
//! from `stream(seed, pixel, PURPOSE_DEFECTS)`; an RTS pixel's chain steps from
//! `stream(seed, pixel, PURPOSE_CHAIN)`, one draw per frame in order; row and column noise
//! (one normal draw per row and per column and frame) and hot pixels' dark-current shot noise
//! from `stream(seed, frame, purpose)` of their own. The streams of the Gaussian camera are
//! untouched: without defects a stack is the same as before.

use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;

use super::rts::RtsChain;
use crate::error::{Error, Result};
use crate::rng::{stream, SimRng};
use crate::stats::poisson;

const PURPOSE_DEFECTS: u64 = 0x4445_4645_4354; // "DEFECT"
const PURPOSE_CHAIN: u64 = 0x4348_4149_4e53; // "CHAINS"
const PURPOSE_LINES: u64 = 0x4c49_4e45_5321; // "LINES!"
const PURPOSE_HOT: u64 = 0x484f_5450_5853; // "HOTPXS"

/// RTS pixels to inject.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RtsParams {
    /// Fraction of pixels that are RTS, [0, 1].
    pub fraction: f64,
    /// Height of each level above the lowest (e-), ascending: one value for two levels, two
    /// for three.
    pub steps_e: Vec<f64>,
    /// Relative pixel-to-pixel spread of the heights (standard deviation / mean), [0, 1).
    pub step_spread: f64,
    /// Mean dwell time of each level (frames, >= 1): two or three values.
    pub dwell_frames: Vec<f64>,
    /// Occupancy of each level (sum 1); None: proportional to the dwell times.
    pub occupancy: Option<Vec<f64>>,
}

/// Non-Gaussian noise of a synthetic sCMOS (none by default).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Defects {
    /// RTS pixels, if any.
    pub rts: Option<RtsParams>,
    /// Row noise: standard deviation of one draw per row and frame shared by the row (e-).
    pub row_noise_e: f64,
    /// Column noise: standard deviation of one draw per column and frame (e-).
    pub column_noise_e: f64,
    /// Fraction of hot pixels, [0, 1].
    pub hot_fraction: f64,
    /// Dark signal of a hot pixel (e- per frame, Poisson).
    pub hot_dark_e: f64,
}

impl Defects {
    /// No defect at all (a Gaussian camera).
    pub fn is_none(&self) -> bool {
        self == &Defects::default()
    }

    /// Check every value; returns the RTS chain when there are RTS pixels.
    pub fn check(&self) -> Result<Option<RtsChain>> {
        let nonneg = |field: &str, v: f64, unit: &str| {
            if v >= 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(Error::invalid(
                    field,
                    format!("{v} must be finite and >= 0 {unit}"),
                ))
            }
        };
        let fraction = |field: &str, v: f64| {
            if (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(Error::invalid(field, format!("{v} must be in [0, 1]")))
            }
        };
        nonneg("row_noise_e", self.row_noise_e, "e-")?;
        nonneg("column_noise_e", self.column_noise_e, "e-")?;
        nonneg("hot_dark_e", self.hot_dark_e, "e- per frame")?;
        fraction("hot_fraction", self.hot_fraction)?;
        let Some(r) = &self.rts else {
            return Ok(None);
        };
        fraction("rts_fraction", r.fraction)?;
        if !(0.0..1.0).contains(&r.step_spread) {
            return Err(Error::invalid(
                "rts_step_spread",
                format!("{} must be in [0, 1)", r.step_spread),
            ));
        }
        let chain = RtsChain::new(&r.dwell_frames, r.occupancy.as_deref())?;
        let ascending = r.steps_e.windows(2).all(|w| w[0] < w[1]);
        if r.steps_e.len() + 1 != chain.levels()
            || !ascending
            || r.steps_e.iter().any(|s| !(*s > 0.0 && s.is_finite()))
        {
            return Err(Error::invalid(
                "rts_steps_e",
                format!(
                    "{:?}: give {} heights > 0 e-, ascending (one per level above the lowest, as `rts_dwell_frames` has {} levels)",
                    r.steps_e,
                    chain.levels() - 1,
                    chain.levels()
                ),
            ));
        }
        Ok(Some(chain))
    }
}

/// One RTS pixel of a synthetic stack.
#[derive(Clone, Debug, PartialEq)]
pub struct RtsPixelTruth {
    /// Pixel index (row-major).
    pub index: usize,
    /// Height of each level above the lowest (e-; 0 for the lowest).
    pub heights_e: Vec<f64>,
    /// Level in frame 0 (drawn from the stationary distribution).
    pub start: u8,
}

/// The per-pixel truth of the defects.
#[derive(Clone, Debug, Default)]
pub struct DefectTruth {
    /// The RTS chain every RTS pixel follows, if any.
    pub chain: Option<RtsChain>,
    /// RTS pixels, ascending index.
    pub rts: Vec<RtsPixelTruth>,
    /// Dark signal per pixel (e- per frame; 0 except hot pixels), empty without hot pixels.
    pub hot_dark_e: Vec<f64>,
}

impl DefectTruth {
    /// Draw which of `npix` pixels are RTS or hot, with `seed`.
    pub fn draw(d: &Defects, chain: Option<RtsChain>, npix: usize, seed: u64) -> DefectTruth {
        let mut rts = Vec::new();
        let mut hot = vec![0.0; if d.hot_fraction > 0.0 { npix } else { 0 }];
        for i in 0..npix {
            let mut rng = stream(seed, i as u64, PURPOSE_DEFECTS);
            let (u_rts, u_hot): (f64, f64) = (rng.random(), rng.random());
            if let (Some(r), Some(c)) = (&d.rts, &chain) {
                if u_rts < r.fraction {
                    let scale = 1.0 + r.step_spread * normal(&mut rng);
                    let heights_e = std::iter::once(0.0)
                        .chain(r.steps_e.iter().map(|s| s * scale.max(0.05)))
                        .collect();
                    rts.push(RtsPixelTruth {
                        index: i,
                        heights_e,
                        start: c.start(&mut rng),
                    });
                }
            }
            if u_hot < d.hot_fraction {
                if let Some(h) = hot.get_mut(i) {
                    *h = d.hot_dark_e;
                }
            }
        }
        DefectTruth {
            chain,
            rts,
            hot_dark_e: hot,
        }
    }

    /// The level of every RTS pixel in frame `k`, replayed from frame 0 (O(k) per pixel; the
    /// writer steps the chains frame by frame with [`ChainStates`] instead).
    pub fn levels_at(&self, seed: u64, k: usize) -> Vec<u8> {
        let mut s = ChainStates::new(self, seed);
        for _ in 0..k {
            s.advance(self);
        }
        s.levels
    }
}

fn normal(rng: &mut SimRng) -> f64 {
    StandardNormal.sample(rng)
}

/// The current level of every RTS pixel, stepped one frame at a time.
#[derive(Clone, Debug)]
pub struct ChainStates {
    /// Level of each RTS pixel (order of `DefectTruth::rts`).
    pub levels: Vec<u8>,
    rngs: Vec<SimRng>,
}

impl ChainStates {
    /// The levels in frame 0.
    pub fn new(t: &DefectTruth, seed: u64) -> ChainStates {
        ChainStates {
            levels: t.rts.iter().map(|p| p.start).collect(),
            rngs: t
                .rts
                .iter()
                .map(|p| stream(seed, p.index as u64, PURPOSE_CHAIN))
                .collect(),
        }
    }

    /// Step every chain to the next frame.
    pub fn advance(&mut self, t: &DefectTruth) {
        let Some(c) = &t.chain else { return };
        for (l, rng) in self.levels.iter_mut().zip(&mut self.rngs) {
            *l = c.step(*l, rng);
        }
    }
}

/// Add the defects of frame `k` (RTS levels `levels`, in e-) to `electrons`, a frame of
/// `shape` (rows, cols) in e- per pixel, from the frame's own streams (`purpose` tells light
/// levels apart).
pub fn add_defects(
    d: &Defects,
    t: &DefectTruth,
    levels: &[u8],
    shape: (usize, usize),
    (seed, k, purpose): (u64, usize, u64),
    electrons: &mut [f64],
) {
    for (p, l) in t.rts.iter().zip(levels) {
        electrons[p.index] += p.heights_e[*l as usize];
    }
    let (rows, cols) = shape;
    if d.row_noise_e > 0.0 || d.column_noise_e > 0.0 {
        let mut rng = stream(seed, k as u64, PURPOSE_LINES ^ purpose);
        let row: Vec<f64> = (0..rows)
            .map(|_| d.row_noise_e * normal(&mut rng))
            .collect();
        let col: Vec<f64> = (0..cols)
            .map(|_| d.column_noise_e * normal(&mut rng))
            .collect();
        for (i, e) in electrons.iter_mut().enumerate() {
            *e += row[i / cols] + col[i % cols];
        }
    }
    if !t.hot_dark_e.is_empty() {
        let mut rng = stream(seed, k as u64, PURPOSE_HOT ^ purpose);
        for (e, dark) in electrons.iter_mut().zip(&t.hot_dark_e) {
            if *dark > 0.0 {
                *e += poisson(*dark, &mut rng) as f64;
            }
        }
    }
}
