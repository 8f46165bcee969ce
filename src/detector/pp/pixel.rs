//! The pixel prior's counters: one [`PpCounter`] per pixel of a mean spot image, each built
//! for that pixel's own light level. Counters are built once per distinct level (a centred
//! spot's symmetry makes many pixels share one) and kept per image, so a frame costs one lookup.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::cache::PpCache;
use super::config::PpConfig;
use super::counter::PpCounter;
use crate::error::Result;

/// Distinct light levels kept: more than a 128 x 128 px sub-aperture's eighth (a centred
/// spot's symmetry), so a run's levels are built once.
const LEVELS: usize = 1 << 14;
/// Mean images kept (one per configuration of a run; the oldest are dropped all at once).
const IMAGES: usize = 16;

/// The counters of each mean image, one per pixel.
pub type PixelCounters = Arc<[Arc<PpCounter>]>;

/// Per-pixel counters of mean spot images (photo-electrons per pixel), built on first use.
#[derive(Debug)]
pub struct PixelPrior {
    levels: PpCache,
    images: Mutex<HashMap<Vec<u64>, PixelCounters>>,
}

impl PixelPrior {
    /// Levels below this (photo-electrons per pixel) are raised to it, as the sub-aperture
    /// mean's are.
    pub const FLOOR_E: f64 = 1e-9;

    /// Counters of `config` (whose rule should be [`super::PpRule::PixelPrior`]).
    pub fn new(config: PpConfig) -> Result<Self> {
        Ok(PixelPrior {
            levels: PpCache::new(config, LEVELS)?,
            images: Mutex::new(HashMap::new()),
        })
    }

    /// One counter per pixel of `mean_e`, each for its own level (floored at
    /// [`PixelPrior::FLOOR_E`]), spanning pixels up to `lambda_max` ([`PpConfig::spanning`]);
    /// the same `Arc` for the same image and span.
    pub fn counters(&self, mean_e: &[f64], lambda_max: f64) -> Result<PixelCounters> {
        let mut key: Vec<u64> = mean_e.iter().map(|v| v.to_bits()).collect();
        key.push(lambda_max.to_bits());
        if let Some(c) = self.lock().get(&key) {
            return Ok(Arc::clone(c));
        }
        let counters: PixelCounters = mean_e
            .iter()
            .map(|&l| self.levels.get_spanning(l.max(Self::FLOOR_E), lambda_max))
            .collect::<Result<Vec<_>>>()?
            .into();
        let mut images = self.lock();
        if images.len() >= IMAGES {
            images.clear();
        }
        images.insert(key, Arc::clone(&counters));
        Ok(counters)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<Vec<u64>, PixelCounters>> {
        // A panic while holding the lock cannot leave the map inconsistent (inserts are atomic).
        self.images.lock().unwrap_or_else(|e| e.into_inner())
    }
}
