//! Values shared between frames (output camera and remap table per source camera): built once
//! per key by whichever frame needs it first, while the other frames wanting it wait.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// A map of values built once per key; the build runs outside the map's lock. Builds must not
/// use rayon themselves (work stealing could re-enter the same cell on one thread).
pub struct OnceMap<K, V> {
    entries: Mutex<HashMap<K, Arc<OnceLock<V>>>>,
}

impl<K: std::hash::Hash + Eq + Clone, V: Clone> Default for OnceMap<K, V> {
    fn default() -> Self {
        Self {
            entries: Mutex::new(HashMap::new()),
        }
    }
}

impl<K: std::hash::Hash + Eq + Clone, V: Clone> OnceMap<K, V> {
    /// The value of `key`, running `build` if no value exists yet; concurrent callers for the same
    /// key wait for that one build instead of building again.
    pub fn get_or_build(&self, key: &K, build: impl FnOnce() -> V) -> V {
        let cell = {
            let mut map = self.entries.lock().unwrap_or_else(|e| e.into_inner());
            map.entry(key.clone()).or_default().clone()
        };
        cell.get_or_init(build).clone()
    }

    /// Sets the value of `key` unless it has one (a value built ahead of need).
    pub fn insert(&self, key: K, value: V) {
        let mut map = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        let _ = map.entry(key).or_default().set(value);
    }

    /// Number of distinct keys seen so far.
    pub fn len(&self) -> usize {
        self.entries.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// Whether no key has been seen yet.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}
