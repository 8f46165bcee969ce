//! A thread-safe cache of PP counters keyed by reference light level, for readouts whose
//! reference changes per frame.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::config::{PpConfig, PpRule};
use super::counter::PpCounter;
use crate::error::Result;

/// Thread-safe cache of [`PpCounter`]s keyed by the exact reference light level, for readouts whose
/// reference changes per frame. It is cleared when it exceeds `capacity` entries.
#[derive(Debug)]
pub struct PpCache {
    config: PpConfig,
    capacity: usize,
    map: Mutex<HashMap<(u64, u64), Arc<PpCounter>>>,
}

impl PpCache {
    /// A cache for `config` holding at most `capacity` counters.
    pub fn new(config: PpConfig, capacity: usize) -> Result<Self> {
        config.validate()?;
        Ok(PpCache {
            config,
            capacity: capacity.max(1),
            map: Mutex::new(HashMap::new()),
        })
    }

    /// The counter for `lambda_ref` photo-electrons per pixel, built on first use.
    pub fn get(&self, lambda_ref: f64) -> Result<Arc<PpCounter>> {
        self.get_spanning(lambda_ref, self.config.lambda_max)
    }

    /// The counter for `lambda_ref` photo-electrons per pixel whose thresholds and correction
    /// span pixels up to `lambda_max` ([`PpConfig::spanning`]), built on first use.
    pub fn get_spanning(&self, lambda_ref: f64, lambda_max: f64) -> Result<Arc<PpCounter>> {
        // Rule B does not depend on the light level: one entry serves all.
        let level = match self.config.rule {
            PpRule::EqualDensity => 0,
            PpRule::PoissonPrior | PpRule::PixelPrior => lambda_ref.to_bits(),
        };
        let key = (level, lambda_max.to_bits());
        if let Some(c) = self.lock().get(&key) {
            return Ok(Arc::clone(c));
        }
        let config = PpConfig {
            lambda_max,
            ..self.config
        };
        let counter = Arc::new(config.counter(lambda_ref)?);
        let mut map = self.lock();
        if map.len() >= self.capacity {
            map.clear();
        }
        map.insert(key, Arc::clone(&counter));
        Ok(counter)
    }

    /// The configuration the counters are made from.
    pub fn config(&self) -> &PpConfig {
        &self.config
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<(u64, u64), Arc<PpCounter>>> {
        // A panic while holding the lock cannot leave the map inconsistent (inserts are atomic).
        self.map.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cache_reuses_counters() {
        let cache =
            PpCache::new(PpConfig::new(PpRule::PoissonPrior, 500.0, 50.0).unwrap(), 8).unwrap();
        let a = cache.get(1.5).unwrap();
        let b = cache.get(1.5).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        let c = cache.get(2.0).unwrap();
        assert_eq!(c.thresholds.t_over_g[1], 1.0);
    }

    #[test]
    fn equal_density_shares_one_counter_and_a_full_cache_starts_over() {
        // Rule B does not depend on the light level: every level gets the same counter.
        let mut b = PpConfig::new(PpRule::EqualDensity, 500.0, 50.0).unwrap();
        b.lambda_max = 4.0;
        let cache = PpCache::new(b, 8).unwrap();
        assert!(Arc::ptr_eq(
            &cache.get(0.5).unwrap(),
            &cache.get(3.0).unwrap()
        ));
        // Capacity 2: the third level clears the map, so the first is built anew.
        let a = PpConfig::new(PpRule::PoissonPrior, 500.0, 50.0).unwrap();
        let cache = PpCache::new(a, 2).unwrap();
        let first = cache.get(1.0).unwrap();
        cache.get(2.0).unwrap();
        cache.get(3.0).unwrap();
        assert!(!Arc::ptr_eq(&first, &cache.get(1.0).unwrap()));
        assert_eq!(first.thresholds, cache.get(1.0).unwrap().thresholds);
    }
}
