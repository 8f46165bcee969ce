//! A process-wide cache of read-only tables shared between renderers: each table is built once
//! per key, by the first thread that asks for it (others wait for that build), and kept while
//! the cached tables fit a byte budget, least recently used evicted first. An evicted table
//! lives on in the renderers that still hold it.

use std::collections::HashMap;
use std::hash::Hash;
use std::sync::{Arc, Mutex, OnceLock};

/// Heap size of a cached value (bytes), for the cache's budget.
pub(super) trait Footprint {
    /// Bytes held by the value.
    fn bytes(&self) -> usize;
}

/// Tables by key, at most `budget` bytes of them kept.
pub(super) struct Cache<K, V> {
    budget: usize,
    state: Mutex<State<K, V>>,
}

struct State<K, V> {
    slots: HashMap<K, Slot<V>>,
    clock: u64,
    bytes: usize,
}

struct Slot<V> {
    cell: Arc<OnceLock<Arc<V>>>,
    last_used: u64,
    /// 0 until the table is built and counted.
    bytes: usize,
}

impl<K: Hash + Eq + Clone, V: Footprint> Cache<K, V> {
    /// An empty cache keeping at most `budget` bytes of tables.
    pub(super) fn new(budget: usize) -> Self {
        Cache {
            budget,
            state: Mutex::new(State {
                slots: HashMap::new(),
                clock: 0,
                bytes: 0,
            }),
        }
    }

    /// The table of `key`, built by `build` if no thread has built it yet. A table's content
    /// must depend on its key only: then no result depends on which caller built it.
    pub(super) fn get(&self, key: &K, build: impl FnOnce() -> V) -> Arc<V> {
        let cell = {
            let mut state = self.lock();
            state.clock += 1;
            let clock = state.clock;
            let slot = state.slots.entry(key.clone()).or_insert_with(|| Slot {
                cell: Arc::new(OnceLock::new()),
                last_used: 0,
                bytes: 0,
            });
            slot.last_used = clock;
            slot.cell.clone()
        };
        // Built outside the map's lock: other keys stay available meanwhile, and threads asking
        // for this key wait here (the build must not wait on them: it uses no rayon pool).
        let table = cell.get_or_init(|| Arc::new(build())).clone();
        let mut state = self.lock();
        let counted = match state.slots.get_mut(key) {
            Some(slot) if slot.bytes == 0 && Arc::ptr_eq(&slot.cell, &cell) => {
                slot.bytes = table.bytes().max(1);
                slot.bytes
            }
            _ => 0,
        };
        state.bytes += counted;
        if counted > 0 {
            state.evict_over(self.budget, key);
        }
        table
    }

    /// Bytes of the tables kept now.
    #[cfg(test)]
    pub(super) fn kept_bytes(&self) -> usize {
        self.lock().bytes
    }

    /// Whether the table of `key` is kept now.
    #[cfg(test)]
    pub(super) fn holds(&self, key: &K) -> bool {
        self.lock().slots.contains_key(key)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, State<K, V>> {
        // The lock guards bookkeeping that no panic can leave half-updated (builds run outside
        // it), so a poisoned lock is still consistent.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl<K: Hash + Eq + Clone, V> State<K, V> {
    /// Drop least recently used built tables (never `keep`) until at most `budget` bytes remain.
    fn evict_over(&mut self, budget: usize, keep: &K) {
        while self.bytes > budget {
            let oldest = self
                .slots
                .iter()
                .filter(|(k, s)| s.bytes > 0 && *k != keep)
                .min_by_key(|(_, s)| s.last_used)
                .map(|(k, _)| k.clone());
            match oldest.and_then(|k| self.slots.remove(&k)) {
                Some(slot) => self.bytes -= slot.bytes,
                None => break,
            }
        }
    }
}
