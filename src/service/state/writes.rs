//! Changes to the store, each with the cache as one step: uploads (live
//! frames made durable later), the persisting of live frames, deletes.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::store::{Staged, StoredView};

use super::super::error::AppError;
use super::{AppState, Loaded};

impl AppState {
    /// Stores an uploaded view and caches it (built from `stored`), as one
    /// step against other changes (blocking: call off the async workers). A
    /// reader that loaded the old version from the store meanwhile does not
    /// cache it after this. A `live` frame is visible at once but made
    /// durable later ([`Self::persist_live`]); a frame that is not live is
    /// durable when this returns, and so ends the view's live frames.
    /// `staged` is what the store wrote of it aside, if anything
    /// ([`crate::store::ViewStore::stage`]).
    pub fn store_view(
        &self,
        scene: &str,
        view: &str,
        stored: &StoredView,
        loaded: Loaded,
        live: bool,
        staged: Staged,
    ) -> Result<Arc<Loaded>, AppError> {
        let _commit = self.commit.lock().unwrap_or_else(|p| p.into_inner());
        self.store_view_committing(scene, view, stored, loaded, live, staged)
    }

    /// [`Self::store_view`] of a live frame only while the view is the
    /// version `previous` (what this writer stored last): `None`, storing
    /// nothing, once it was deleted or replaced by someone else. So a
    /// writer that feeds a view (the demo's `demo-live`) stops when a
    /// client deletes or takes over the view, rather than bringing it back.
    pub fn store_live_frame_over(
        &self,
        scene: &str,
        view: &str,
        stored: &StoredView,
        loaded: Loaded,
        previous: &str,
    ) -> Result<Option<Arc<Loaded>>, AppError> {
        let _commit = self.commit.lock().unwrap_or_else(|p| p.into_inner());
        if self.store.version(scene, view)?.as_deref() != Some(previous) {
            return Ok(None);
        }
        self.store_view_committing(scene, view, stored, loaded, true, Staged::default())
            .map(Some)
    }

    /// [`Self::store_view`]'s work, with the commit lock held.
    fn store_view_committing(
        &self,
        scene: &str,
        view: &str,
        stored: &StoredView,
        loaded: Loaded,
        live: bool,
        staged: Staged,
    ) -> Result<Arc<Loaded>, AppError> {
        let key = (scene.to_string(), view.to_string());
        let version = self.store.put_staged(scene, view, stored, live, staged)?;
        if live {
            self.unpersisted().entry(key).or_insert_with(Instant::now);
        } else {
            self.unpersisted().remove(&key);
        }
        let loaded = Arc::new(Loaded {
            live_since: live.then(std::time::SystemTime::now),
            ..loaded.at_version(version)
        });
        {
            let mut c = self.cache();
            self.changes.bump(scene, Some(view));
            self.insert(&mut c, scene, view, loaded.clone());
        }
        self.cameras.lock().unwrap_or_else(|p| p.into_inner()).remove(scene);
        Ok(loaded)
    }

    pub(super) fn unpersisted(&self) -> std::sync::MutexGuard<'_, HashMap<(String, String), Instant>> {
        self.unpersisted.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Makes durable the latest frame of every live view whose oldest
    /// frame not yet durable is older than `age` (blocking); returns how
    /// many. The server calls it with [`Settings::live_persist`] a few
    /// times a second, and with zero when it shuts down.
    pub fn persist_live(&self, age: Duration) -> Result<usize, AppError> {
        let due: Vec<(String, String)> = self
            .unpersisted()
            .iter()
            .filter(|(_, since)| since.elapsed() >= age)
            .map(|(k, _)| k.clone())
            .collect();
        for (scene, view) in &due {
            // No frame of this view is stored meanwhile: what is made durable
            // is the latest, and the entry it clears is its.
            let _commit = self.commit.lock().unwrap_or_else(|p| p.into_inner());
            self.store.persist(scene, view)?;
            self.unpersisted().remove(&(scene.clone(), view.clone()));
        }
        Ok(due.len())
    }

    /// Deletes a view (or, with `view` `None`, a scene) from the store and
    /// the cache as one step (blocking). True when it existed.
    pub fn delete(&self, scene: &str, view: Option<&str>) -> Result<bool, AppError> {
        let _commit = self.commit.lock().unwrap_or_else(|p| p.into_inner());
        let existed = match view {
            Some(v) => self.store.delete_view(scene, v)?,
            None => self.store.delete_scene(scene)?,
        };
        self.unpersisted()
            .retain(|(s, v), _| !(s == scene && view.is_none_or(|w| w == v)));
        self.forget(scene, view);
        Ok(existed)
    }
}
