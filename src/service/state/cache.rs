//! The memory-bounded cache of built views (least recently used out) and
//! loading through it: a view is built from the store once at a time,
//! the requests that arrive meanwhile waiting for that build.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use crate::store::Version;

use super::super::error::AppError;
use super::{AppState, Listed, Loaded};

/// A cached view: the view, its last use (LRU clock), its last check.
pub(super) struct Entry {
    pub(super) loaded: Arc<Loaded>,
    pub(super) used: u64,
    pub(super) checked: Instant,
}

#[derive(Default)]
pub(super) struct Cache {
    pub(super) entries: HashMap<(String, String), Entry>,
    pub(super) bytes: usize,
    pub(super) clock: u64,
}

/// A view: its scene and its id.
pub(super) type ViewKey = (String, String);

/// What requests for a view being built wait at.
pub(super) type Gate = Arc<Mutex<()>>;

impl AppState {
    pub(super) fn cache(&self) -> std::sync::MutexGuard<'_, Cache> {
        // A panic while holding the lock leaves a consistent map: recover it.
        self.cache.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Puts a view in the cache, evicting the least recently used over the budget.
    pub fn remember(&self, scene: &str, view: &str, loaded: Arc<Loaded>) {
        let mut c = self.cache();
        self.insert(&mut c, scene, view, loaded);
    }

    pub(super) fn insert(&self, c: &mut Cache, scene: &str, view: &str, loaded: Arc<Loaded>) {
        c.clock += 1;
        let entry = Entry {
            loaded: loaded.clone(),
            used: c.clock,
            checked: Instant::now(),
        };
        if let Some(old) = c.entries.insert((scene.into(), view.into()), entry) {
            c.bytes -= old.loaded.bytes();
        }
        c.bytes += loaded.bytes();
        while c.bytes > self.settings.cache_bytes && c.entries.len() > 1 {
            let Some(oldest) = c.entries.iter().min_by_key(|(_, e)| e.used).map(|(k, _)| k.clone()) else {
                break;
            };
            if let Some(gone) = c.entries.remove(&oldest) {
                c.bytes -= gone.loaded.bytes();
            }
        }
        self.metrics.set_views_loaded(c.entries.len());
    }

    /// Drops one view from the cache, so that what was read of it before
    /// is not cached after (it changed in the store).
    pub(super) fn drop_view(&self, scene: &str, view: &str) {
        let mut c = self.cache();
        self.changes.bump(scene, Some(view));
        if let Some(gone) = c.entries.remove(&(scene.to_string(), view.to_string())) {
            c.bytes -= gone.loaded.bytes();
        }
        self.metrics.set_views_loaded(c.entries.len());
    }

    /// Drops a view (or, with `view` `None`, every view of the scene) from the cache.
    pub fn forget(&self, scene: &str, view: Option<&str>) {
        self.scene_changed(scene, view);
        let mut c = self.cache();
        let keys: Vec<_> = c
            .entries
            .keys()
            .filter(|(s, v)| s == scene && view.is_none_or(|w| w == v))
            .cloned()
            .collect();
        for k in keys {
            if let Some(gone) = c.entries.remove(&k) {
                c.bytes -= gone.loaded.bytes();
            }
        }
        self.metrics.set_views_loaded(c.entries.len());
    }

    /// The cached view and whether it needs a check, bumping its LRU clock.
    pub(super) fn cached(&self, scene: &str, view: &str) -> Option<(Arc<Loaded>, bool)> {
        let mut c = self.cache();
        c.clock += 1;
        let clock = c.clock;
        let e = c.entries.get_mut(&(scene.to_string(), view.to_string()))?;
        e.used = clock;
        Some((e.loaded.clone(), self.stale(e.checked)))
    }

    /// The loaded view, from the cache or rebuilt from the store (blocking:
    /// call off the async workers). Over a shared store a cached view not
    /// checked within [`Settings::revalidate`] is checked first.
    pub fn load(&self, scene: &str, view: &str) -> Result<Arc<Loaded>, AppError> {
        self.used(scene);
        if let Some((hit, stale)) = self.cached(scene, view) {
            if !stale {
                return Ok(hit);
            }
            self.check_scene(scene)?;
            if let Some((hit, false)) = self.cached(scene, view) {
                return Ok(hit);
            }
        }
        self.fetch(scene, view, None)
    }

    /// The loaded view at `version` (just listed by [`Self::scene_cameras`]),
    /// from the cache when it holds that version (over a store only this
    /// process writes, the cache is exact).
    pub fn load_listed(&self, scene: &str, listed: &Listed) -> Result<Arc<Loaded>, AppError> {
        if let Some((hit, _)) = self.cached(scene, &listed.name) {
            if !self.store.shared() || hit.version == listed.version {
                return Ok(hit);
            }
        }
        self.fetch(scene, &listed.name, Some(&listed.version))
    }

    /// Reads and builds a view from the store, and caches it. One build
    /// per view at a time: requests that arrive meanwhile wait for it and
    /// take what it cached (a replica that takes over a busy scene builds
    /// each view once, not once per client), unless they `want` another
    /// version.
    pub(super) fn fetch(&self, scene: &str, view: &str, want: Option<&Version>) -> Result<Arc<Loaded>, AppError> {
        let key = (scene.to_string(), view.to_string());
        let gate = self.building().entry(key.clone()).or_default().clone();
        let fetched = {
            let _one = gate.lock().unwrap_or_else(|p| p.into_inner());
            match self.cached(scene, view) {
                Some((hit, false)) if want.is_none_or(|v| *v == hit.version) => Ok(hit),
                _ => self.fetch_now(scene, view),
            }
        };
        let mut building = self.building();
        if building
            .get(&key)
            .is_some_and(|g| Arc::ptr_eq(g, &gate) && Arc::strong_count(g) == 2)
        {
            building.remove(&key);
        }
        fetched
    }

    pub(super) fn building(&self) -> std::sync::MutexGuard<'_, HashMap<ViewKey, Gate>> {
        self.building.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub(super) fn fetch_now(&self, scene: &str, view: &str) -> Result<Arc<Loaded>, AppError> {
        let before = self.changes.view(scene, view);
        let read_at = Instant::now();
        let (stored, version) = self
            .store
            .get(scene, view)?
            .ok_or_else(|| AppError::NotFound(format!("scene {scene:?} has no view {view:?}")))?;
        let loaded = Arc::new(Loaded::from_stored(&stored, version)?);
        // Cached only when nothing changed here since the store was read: a
        // replace meanwhile may already have cached the newer view.
        let mut c = self.cache();
        if self.changes.view(scene, view) == before {
            self.insert(&mut c, scene, view, loaded.clone());
            // Current when the read began, not when the build ended.
            if let Some(e) = c.entries.get_mut(&(scene.to_string(), view.to_string())) {
                e.checked = read_at;
            }
        }
        Ok(loaded)
    }
}
