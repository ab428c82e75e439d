//! Shared state: the store, a memory-bounded cache of built hierarchies, limits.
//!
//! Over a store only this process writes (the file store) the cache is
//! exact: every change goes through [`AppState`], which updates it.
//!
//! Over a shared store (replicas on one object store) the cache is checked
//! per scene: one HEAD of the scene's version ([`ViewStore::scene_version`]),
//! and only when that changed one LIST, which drops the views that changed.
//! Nothing is served from a scene not checked within
//! [`Settings::revalidate`] (default 1 s): [`AppState::revalidate_used`],
//! which the server runs in the background, keeps the scenes in use
//! checked, so requests do not wait for the store; a scene idle for
//! [`IDLE`] (one a replica gains when ownership moves) is checked before
//! its first answer. So:
//!
//! - a replica's own writes update its cache at once: behind a balancer
//!   that sends each scene to one replica, a read after an acknowledged
//!   write sees it;
//! - another replica serves a replaced view for at most
//!   [`Settings::revalidate`] after the replace was acknowledged (0: never,
//!   at the cost of a HEAD per request);
//! - a view is one version throughout: a response is built from one
//!   [`Loaded`], which is never changed in place.
//!
//! Lock order, the one rule for every file here: where two locks are held,
//! `commit` comes first, then one of `cache`, `cameras` or `unpersisted`;
//! or a view's build gate first, then `cache`. `checks`, `note` and
//! `building` are only ever held alone.
//!
//! One file per part: [`loaded`] (a built view and its ETag), `cache`
//! (the cache and loading through it), [`listing`] (scenes' cameras and
//! their checks), `writes` (uploads, live frames, deletes), `warm`
//! (replicas' notes), `changes` (the change counters).

mod cache;
mod changes;
pub mod listing;
pub mod loaded;
mod warm;
mod writes;

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::store::ViewStore;
use dmesh_engine::image::Limits;

use super::metrics::Metrics;
use cache::{Cache, Gate, ViewKey};
use changes::Changes;
use listing::SceneCheck;
pub use listing::{Listed, SceneCameras};
pub use loaded::Loaded;
pub use warm::WARM_LIMIT;

/// Server settings.
#[derive(Clone, Debug)]
pub struct Settings {
    /// Largest request body, bytes.
    pub max_upload_bytes: usize,
    /// Decoded-pixel limit.
    pub limits: Limits,
    /// Bytes of hierarchies kept in memory.
    pub cache_bytes: usize,
    /// Over a shared store, the longest a cached view or scene listing is
    /// served without checking its scene's version: how long another
    /// replica's replace may go unseen.
    pub revalidate: Duration,
    /// The longest a live view's latest frame waits before it is made
    /// durable ([`AppState::persist_live`]).
    pub live_persist: Duration,
    /// Over a shared store, this replica's id: it keeps a note of the
    /// views it holds under it, and after a restart builds them before
    /// `/healthz` says it is ready ([`AppState::warm`]). `None`: no notes.
    pub replica: Option<String>,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            max_upload_bytes: 256 << 20,
            limits: Limits::default(),
            cache_bytes: 1 << 30,
            revalidate: DEFAULT_REVALIDATE,
            live_persist: Duration::from_secs(2),
            replica: None,
        }
    }
}

/// The default of [`Settings::revalidate`].
pub const DEFAULT_REVALIDATE: Duration = Duration::from_secs(1);

/// A scene not used for this long is no longer checked in the background
/// ([`AppState::revalidate_used`]); its next request checks it first.
pub const IDLE: Duration = Duration::from_secs(10);

/// Everything handlers share.
pub struct AppState {
    /// Durable views.
    pub store: Arc<dyn ViewStore>,
    /// Settings.
    pub settings: Settings,
    /// Prometheus metrics.
    pub metrics: Metrics,
    cache: Mutex<Cache>,
    /// Per scene, its views' names and cameras, read from the store's
    /// metadata alone (view selection needs no hierarchy).
    cameras: Mutex<HashMap<String, (SceneCameras, Instant)>>,
    /// Bumped by every store change, so a listing or a view read before a
    /// change is not cached after it.
    changes: Changes,
    /// Held while a change reaches the store and the cache, so two uploads
    /// of one view leave the cache holding what the store holds.
    commit: Mutex<()>,
    /// Live views whose latest frame is not durable yet, with when their
    /// oldest such frame was stored.
    unpersisted: Mutex<HashMap<(String, String), Instant>>,
    /// Per scene in use, its version when last checked (shared stores).
    checks: Mutex<HashMap<String, SceneCheck>>,
    /// False while a restarted replica builds the views it held.
    ready: std::sync::atomic::AtomicBool,
    /// The note last kept ([`Self::keep_note`]), to skip rewriting it.
    note: Mutex<Vec<u8>>,
    /// Per view being built from the store, the gate its other requests
    /// wait at ([`Self::fetch`]).
    building: Mutex<HashMap<ViewKey, Gate>>,
}

impl AppState {
    /// State over `store`.
    pub fn new(store: Arc<dyn ViewStore>, settings: Settings) -> Self {
        // A replica with a note is not ready until [`Self::warm`] ran.
        let ready = !(store.shared() && settings.replica.is_some());
        Self {
            store,
            settings,
            metrics: Metrics::default(),
            cache: Mutex::new(Cache::default()),
            cameras: Mutex::new(HashMap::new()),
            changes: Changes::default(),
            commit: Mutex::new(()),
            unpersisted: Mutex::new(HashMap::new()),
            checks: Mutex::new(HashMap::new()),
            ready: std::sync::atomic::AtomicBool::new(ready),
            note: Mutex::new(Vec::new()),
            building: Mutex::new(HashMap::new()),
        }
    }

    /// True when a cached entry checked at `checked` must be checked again.
    fn stale(&self, checked: Instant) -> bool {
        self.store.shared() && checked.elapsed() > self.settings.revalidate
    }
}
