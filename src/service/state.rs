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
//! Lock order, where two are held: `commit`, then `cache`; a view's build
//! gate, then `cache`; the other locks are held alone.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::store::{StoredView, Version, ViewStore};
use dmesh_engine::camera::Camera;
use dmesh_engine::image::{sniff, DepthImage, Format, Limits};
use dmesh_engine::mesh::DepthMesh;

use super::error::AppError;
use super::metrics::Metrics;

/// A view ready to serve: its hierarchy and what responses need.
#[derive(Debug)]
pub struct Loaded {
    /// The hierarchy.
    pub hierarchy: DepthMesh,
    /// The reference camera.
    pub camera: Camera,
    /// The colour image as uploaded.
    pub color: Vec<u8>,
    /// `image/png` or `image/jpeg`.
    pub color_type: &'static str,
    /// The store's version of the view this was built from.
    pub version: Version,
    /// Strong validator of the stored view (depth, camera, segmentation,
    /// colour) and its version.
    pub etag: String,
    /// Hash of the stored content.
    content: u64,
    /// Valid depth samples.
    pub valid_samples: u64,
    /// The integer grid of the uploaded depth, for lossless residual coding.
    pub raw_grid: Option<dmesh_proto::RawGrid>,
    /// When this frame became visible, for a live frame (`PUT ...?live=true`)
    /// this process received; `None` otherwise.
    pub live_since: Option<std::time::SystemTime>,
}

impl Loaded {
    /// Milliseconds since this live frame became visible (`None`: not a
    /// live frame of this process).
    pub fn live_age_ms(&self) -> Option<f64> {
        let since = self.live_since?;
        Some(since.elapsed().map_or(0.0, |d| d.as_secs_f64() * 1e3))
    }
}

impl Loaded {
    /// Bytes this entry keeps in memory, at most: its size must not change
    /// while it is cached (the hierarchy computes its outlines on first
    /// use), so the hierarchy's bound is charged.
    pub fn bytes(&self) -> usize {
        self.hierarchy.heap_bytes_bound() + self.color.len()
    }

    /// Builds from a stored view at `version`.
    pub fn from_stored(v: &StoredView, version: Version) -> Result<Self, AppError> {
        let camera = Camera::try_from(&v.camera)?;
        let depth = DepthImage::from_z(camera.width, camera.height, v.z.clone())?;
        let hierarchy = DepthMesh::build(&depth, &camera, &v.segmentation.to_engine())?;
        // Uploads are checked to be PNG or JPEG by their magic bytes.
        let color_type = match sniff(&v.color) {
            Some(Format::Png) => "image/png",
            _ => "image/jpeg",
        };
        let mut h = std::collections::hash_map::DefaultHasher::new();
        for z in &v.z {
            z.to_bits().hash(&mut h);
        }
        v.color.hash(&mut h);
        serde_json::to_string(&v.camera).unwrap_or_default().hash(&mut h);
        serde_json::to_string(&v.segmentation).unwrap_or_default().hash(&mut h);
        serde_json::to_string(&v.raw_grid).unwrap_or_default().hash(&mut h);
        Ok(Self {
            version: Version::new(),
            content: h.finish(),
            valid_samples: depth.valid_count() as u64,
            raw_grid: v.raw_grid,
            live_since: None,
            hierarchy,
            camera,
            color: v.color.clone(),
            color_type,
            etag: String::new(),
        }
        .at_version(version))
    }

    /// The same view as stored at `version`: its ETag names both the
    /// content and the version.
    pub fn at_version(mut self, version: Version) -> Self {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        version.hash(&mut h);
        self.etag = format!("\"{:016x}.{:08x}\"", self.content, h.finish() as u32);
        self.version = version;
        self
    }
}

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

/// What this process last learnt of a scene's version (shared stores).
struct SceneCheck {
    /// The scene's version when last checked.
    version: Option<Version>,
    /// When the last request used the scene.
    used: Instant,
}

/// A cached view: the view, its last use (LRU clock), its last check.
struct Entry {
    loaded: Arc<Loaded>,
    used: u64,
    checked: Instant,
}

#[derive(Default)]
struct Cache {
    entries: HashMap<(String, String), Entry>,
    bytes: usize,
    clock: u64,
}

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

/// A view: its scene and its id.
type ViewKey = (String, String);

/// What requests for a view being built wait at.
type Gate = Arc<Mutex<()>>;

/// A replica's note: the views it held.
#[derive(serde::Serialize, serde::Deserialize)]
struct Note {
    views: Vec<(String, String)>,
}

/// The longest a restarted replica spends building the views of its note
/// before it reports ready anyway.
pub const WARM_LIMIT: Duration = Duration::from_secs(60);

/// Change counters, so that what was read from the store before a change
/// is not cached after it. Counted per scene and per view, in 64 buckets
/// each: a change to one view does not stop another from being cached (with
/// one global counter, an uploader busy on one scene left every other view
/// it fetched uncached, rebuilt on each request), and two keys sharing a
/// bucket only cost a skipped cache insert.
struct Changes {
    scenes: [std::sync::atomic::AtomicU64; 64],
    views: [std::sync::atomic::AtomicU64; 64],
}

impl Default for Changes {
    fn default() -> Self {
        Self {
            scenes: std::array::from_fn(|_| Default::default()),
            views: std::array::from_fn(|_| Default::default()),
        }
    }
}

impl Changes {
    fn bucket(parts: &[&str]) -> usize {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        parts.hash(&mut h);
        (h.finish() % 64) as usize
    }

    fn scene(&self, scene: &str) -> u64 {
        self.scenes[Self::bucket(&[scene])].load(std::sync::atomic::Ordering::SeqCst)
    }

    fn view(&self, scene: &str, view: &str) -> u64 {
        self.views[Self::bucket(&[scene, view])].load(std::sync::atomic::Ordering::SeqCst)
    }

    /// A change to `view` of `scene`, or to all its views when `None`.
    fn bump(&self, scene: &str, view: Option<&str>) {
        use std::sync::atomic::Ordering::SeqCst;
        self.scenes[Self::bucket(&[scene])].fetch_add(1, SeqCst);
        match view {
            Some(v) => {
                self.views[Self::bucket(&[scene, v])].fetch_add(1, SeqCst);
            }
            None => {
                for c in &self.views {
                    c.fetch_add(1, SeqCst);
                }
            }
        }
    }
}

/// A view of a scene as selection sees it.
#[derive(Clone, Debug)]
pub struct Listed {
    /// The view id.
    pub name: String,
    /// Its camera.
    pub camera: Camera,
    /// The store's version the camera was read at.
    pub version: Version,
}

/// The views of a scene and their cameras, in view-id order.
pub type SceneCameras = Arc<Vec<Listed>>;

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

    /// False while a restarted replica builds the views it held.
    pub fn ready(&self) -> bool {
        self.ready.load(std::sync::atomic::Ordering::SeqCst)
    }

    /// Builds the views this replica's note names (blocking), until the cache would overflow or [`WARM_LIMIT`] passes,
    /// reporting not ready meanwhile; returns how many were built. A view
    /// gone from the store is skipped; a store that fails ends the warm-up.
    pub fn warm(&self) -> usize {
        let built = self.warm_from_note();
        self.ready.store(true, std::sync::atomic::Ordering::SeqCst);
        built
    }

    fn warm_from_note(&self) -> usize {
        let Some(id) = self.settings.replica.as_ref().filter(|_| self.store.shared()) else {
            return 0;
        };
        let note = match self.store.get_note(id) {
            Ok(Some(bytes)) => serde_json::from_slice::<Note>(&bytes).ok(),
            Ok(None) => None,
            Err(e) => {
                tracing::warn!(error = %e, "reading this replica's note");
                None
            }
        };
        let Some(note) = note else {
            return 0;
        };
        let started = Instant::now();
        let mut built = 0;
        for (scene, view) in &note.views {
            if started.elapsed() > WARM_LIMIT || self.cache().bytes >= self.settings.cache_bytes {
                break;
            }
            match self.load(scene, view) {
                Ok(_) => built += 1,
                Err(AppError::NotFound(_) | AppError::BadRequest(_)) => {}
                Err(e) => {
                    tracing::warn!(error = %e, "warming up");
                    break;
                }
            }
        }
        tracing::info!(
            views = built,
            ms = started.elapsed().as_millis() as u64,
            "warm: built the views this replica held"
        );
        built
    }

    /// Keeps a note of the views this replica holds when the set changed (blocking; the server calls it every few
    /// seconds). True when it was written.
    pub fn keep_note(&self) -> Result<bool, AppError> {
        let Some(id) = &self.settings.replica else {
            return Ok(false);
        };
        // Sorted: the note changes when the set held does, not with every
        // request's order.
        let mut views: Vec<(String, String)> = self.cache().entries.keys().cloned().collect();
        views.sort();
        let bytes = serde_json::to_vec(&Note { views }).map_err(|e| AppError::Internal(e.to_string()))?;
        let mut last = self.note.lock().unwrap_or_else(|p| p.into_inner());
        if *last == bytes {
            return Ok(false);
        }
        self.store.put_note(id, &bytes)?;
        *last = bytes;
        Ok(true)
    }

    /// True when a cached entry checked at `checked` must be checked again.
    fn stale(&self, checked: Instant) -> bool {
        self.store.shared() && checked.elapsed() > self.settings.revalidate
    }

    /// The views of `scene` with their cameras (blocking: call off the async
    /// workers). Cached until the scene changes; over a shared store,
    /// revalidated by one listing, and only changed cameras are read again.
    pub fn scene_cameras(&self, scene: &str) -> Result<SceneCameras, AppError> {
        self.used(scene);
        let lock = || self.cameras.lock().unwrap_or_else(|p| p.into_inner());
        let held = lock().get(scene).cloned();
        if let Some((hit, checked)) = &held {
            if !self.stale(*checked) {
                return Ok(hit.clone());
            }
            // One HEAD of the scene's version, which re-lists only when the
            // scene changed.
            self.check_scene(scene)?;
            if let Some((hit, checked)) = lock().get(scene) {
                if !self.stale(*checked) {
                    return Ok(hit.clone());
                }
            }
        }
        self.relist(scene, Instant::now()).map(|(list, _)| list)
    }

    /// Lists `scene` afresh (reading only the cameras that changed) and
    /// caches the listing as checked at `at` (when the check began), unless
    /// the scene changed here meanwhile. Also returns every view's version.
    fn relist(&self, scene: &str, at: Instant) -> Result<(SceneCameras, HashMap<String, Version>), AppError> {
        let lock = || self.cameras.lock().unwrap_or_else(|p| p.into_inner());
        let held = lock().get(scene).cloned();
        let before = self.changes.scene(scene);
        let listing = self
            .store
            .listing(scene)?
            .ok_or_else(|| AppError::NotFound(format!("no scene {scene:?}")))?;
        // What was listed before, by name and version: one pass, not one
        // search per view.
        let before_list: HashMap<(&str, &str), &Listed> = held
            .as_ref()
            .map(|(h, _)| h.iter().map(|l| ((l.name.as_str(), l.version.as_str()), l)).collect())
            .unwrap_or_default();
        let known = |name: &str, version: &str| before_list.get(&(name, version)).map(|l| (*l).clone());
        let listing_versions = listing.clone();
        let mut list = Vec::with_capacity(listing.len());
        for (name, version) in listing {
            if let Some(same) = known(&name, &version) {
                list.push(same);
            } else if let Some((c, version)) = self.store.camera(scene, &name)? {
                // A view deleted since the listing is simply left out.
                list.push(Listed {
                    name,
                    camera: Camera::try_from(&c)?,
                    version,
                });
            }
        }
        let versions = listing_versions.into_iter().collect();
        let list = Arc::new(list);
        let mut map = lock();
        if self.changes.scene(scene) == before {
            map.insert(scene.to_string(), (list.clone(), at));
        }
        Ok((list, versions))
    }

    /// Notes that a request uses `scene` (shared stores: the background
    /// check keeps it fresh while it is in use).
    fn used(&self, scene: &str) {
        if !self.store.shared() {
            return;
        }
        let mut checks = self.checks();
        match checks.get_mut(scene) {
            Some(c) => c.used = Instant::now(),
            None => {
                checks.insert(
                    scene.to_string(),
                    SceneCheck {
                        version: None,
                        used: Instant::now(),
                    },
                );
            }
        }
    }

    fn checks(&self) -> std::sync::MutexGuard<'_, HashMap<String, SceneCheck>> {
        self.checks.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Checks everything cached of `scene` against the store (blocking):
    /// one HEAD of the scene's version; when it changed (or was not known),
    /// one LIST, which drops the cached views whose version changed. What
    /// is left counts as checked when the HEAD was sent.
    pub fn check_scene(&self, scene: &str) -> Result<(), AppError> {
        let at = Instant::now();
        let Some(version) = self.store.scene_version(scene)? else {
            // The scene is gone.
            self.forget(scene, None);
            self.checks().remove(scene);
            return Ok(());
        };
        let known = self.checks().get(scene).and_then(|c| c.version.clone());
        if known.as_ref() != Some(&version) {
            let (_, versions) = match self.relist(scene, at) {
                Ok(listed) => listed,
                Err(AppError::NotFound(_)) => {
                    self.forget(scene, None);
                    self.checks().remove(scene);
                    return Ok(());
                }
                Err(e) => return Err(e),
            };
            let changed: Vec<String> = {
                let c = self.cache();
                (c.entries.iter())
                    .filter(|((s, v), e)| s == scene && versions.get(v) != Some(&e.loaded.version))
                    .map(|((_, v), _)| v.clone())
                    .collect()
            };
            for view in changed {
                self.drop_view(scene, &view);
            }
        }
        {
            let mut c = self.cache();
            for ((s, _), e) in c.entries.iter_mut() {
                if s == scene && e.checked < at {
                    e.checked = at;
                }
            }
        }
        if let Some((_, checked)) = self.cameras.lock().unwrap_or_else(|p| p.into_inner()).get_mut(scene) {
            if *checked < at {
                *checked = at;
            }
        }
        let mut checks = self.checks();
        let entry = checks.entry(scene.to_string()).or_insert_with(|| SceneCheck {
            version: None,
            used: at,
        });
        entry.version = Some(version);
        Ok(())
    }

    /// Checks every scene a request used within [`IDLE`] whose cache would
    /// turn stale before the next round (blocking; the server calls it
    /// every third of [`Settings::revalidate`]). Returns the scenes checked;
    /// a check that fails leaves its scene to be checked by its next request.
    pub fn revalidate_used(&self) -> usize {
        if !self.store.shared() {
            return 0;
        }
        let scenes: Vec<String> = {
            let mut checks = self.checks();
            checks.retain(|_, c| c.used.elapsed() < IDLE * 6);
            (checks.iter())
                .filter(|(_, c)| c.used.elapsed() < IDLE)
                .map(|(s, _)| s.clone())
                .collect()
        };
        let mut done = 0;
        for scene in scenes {
            match self.check_scene(&scene) {
                Ok(()) => done += 1,
                Err(e) => tracing::warn!(scene, error = %e, "background check failed"),
            }
        }
        done
    }

    /// Forgets what is cached about `scene`'s list of views (after a put or
    /// a delete of `view`, or of every view when `None`).
    fn scene_changed(&self, scene: &str, view: Option<&str>) {
        self.changes.bump(scene, view);
        self.cameras.lock().unwrap_or_else(|p| p.into_inner()).remove(scene);
    }

    fn cache(&self) -> std::sync::MutexGuard<'_, Cache> {
        // A panic while holding the lock leaves a consistent map: recover it.
        self.cache.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Puts a view in the cache, evicting the least recently used over the budget.
    pub fn remember(&self, scene: &str, view: &str, loaded: Arc<Loaded>) {
        let mut c = self.cache();
        self.insert(&mut c, scene, view, loaded);
    }

    fn insert(&self, c: &mut Cache, scene: &str, view: &str, loaded: Arc<Loaded>) {
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

    /// Stores an uploaded view and caches it (built from `stored`), as one
    /// step against other changes (blocking: call off the async workers). A
    /// reader that loaded the old version from the store meanwhile does not
    /// cache it after this. A `live` frame is visible at once but made
    /// durable later ([`Self::persist_live`]); a frame that is not live is
    /// durable when this returns, and so ends the view's live frames.
    pub fn store_view(
        &self,
        scene: &str,
        view: &str,
        stored: &StoredView,
        loaded: Loaded,
        live: bool,
    ) -> Result<Arc<Loaded>, AppError> {
        let _commit = self.commit.lock().unwrap_or_else(|p| p.into_inner());
        let key = (scene.to_string(), view.to_string());
        let version = if live {
            let version = self.store.put_live(scene, view, stored)?;
            self.unpersisted().entry(key).or_insert_with(Instant::now);
            version
        } else {
            let version = self.store.put(scene, view, stored)?;
            self.unpersisted().remove(&key);
            version
        };
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

    fn unpersisted(&self) -> std::sync::MutexGuard<'_, HashMap<(String, String), Instant>> {
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

    /// Drops one view from the cache, so that what was read of it before
    /// is not cached after (it changed in the store).
    fn drop_view(&self, scene: &str, view: &str) {
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
    fn cached(&self, scene: &str, view: &str) -> Option<(Arc<Loaded>, bool)> {
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
    fn fetch(&self, scene: &str, view: &str, want: Option<&Version>) -> Result<Arc<Loaded>, AppError> {
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

    fn building(&self) -> std::sync::MutexGuard<'_, HashMap<ViewKey, Gate>> {
        self.building.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn fetch_now(&self, scene: &str, view: &str) -> Result<Arc<Loaded>, AppError> {
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

#[cfg(test)]
mod tests {
    use super::Changes;

    #[test]
    fn a_change_counts_against_its_own_view_and_scene_only() {
        let c = Changes::default();
        // Two keys in different buckets (the buckets are deterministic).
        let other = (0..64)
            .map(|k| format!("b{k}"))
            .find(|s| {
                Changes::bucket(&[s]) != Changes::bucket(&["a"])
                    && Changes::bucket(&[s, "w"]) != Changes::bucket(&["a", "v"])
            })
            .unwrap();
        let (scene, view) = (c.scene(&other), c.view(&other, "w"));
        let (own_scene, own_view) = (c.scene("a"), c.view("a", "v"));
        c.bump("a", Some("v"));
        assert_eq!((c.scene(&other), c.view(&other, "w")), (scene, view));
        assert!(c.scene("a") > own_scene && c.view("a", "v") > own_view);
        // A whole scene's change reaches every view.
        c.bump("a", None);
        assert!(c.view(&other, "w") > view);
    }
}
