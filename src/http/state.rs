//! Shared state: the store, a memory-bounded cache of built hierarchies, limits.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex};

use crate::camera::Camera;
use crate::image::{sniff, DepthImage, Format, Limits};
use crate::mesh::DepthMesh;
use crate::store::{StoredView, ViewStore};

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
    /// Strong validator of the stored view (depth, camera, segmentation, colour).
    pub etag: String,
    /// Valid depth samples.
    pub valid_samples: u64,
    /// The integer grid of the uploaded depth, for lossless residual coding.
    pub raw_grid: Option<dmesh_proto::RawGrid>,
}

impl Loaded {
    /// Bytes this entry keeps in memory.
    pub fn bytes(&self) -> usize {
        self.hierarchy.heap_bytes() + self.color.len()
    }

    /// Builds from a stored view.
    pub fn from_stored(v: &StoredView) -> Result<Self, AppError> {
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
            valid_samples: depth.valid_count() as u64,
            raw_grid: v.raw_grid,
            hierarchy,
            camera,
            color: v.color.clone(),
            color_type,
            etag: format!("\"{:016x}\"", h.finish()),
        })
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
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            max_upload_bytes: 256 << 20,
            limits: Limits::default(),
            cache_bytes: 1 << 30,
        }
    }
}

#[derive(Default)]
struct Cache {
    entries: HashMap<(String, String), (Arc<Loaded>, u64)>,
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
    cameras: Mutex<HashMap<String, SceneCameras>>,
    /// Bumped by every store change, so a listing or a view read before a
    /// change is not cached after it.
    changes: std::sync::atomic::AtomicU64,
    /// Held while a change reaches the store and the cache, so two uploads
    /// of one view leave the cache holding what the store holds.
    commit: Mutex<()>,
}

/// The views of a scene and their cameras, in view-id order.
pub type SceneCameras = Arc<Vec<(String, Camera)>>;

impl AppState {
    /// State over `store`.
    pub fn new(store: Arc<dyn ViewStore>, settings: Settings) -> Self {
        Self {
            store,
            settings,
            metrics: Metrics::default(),
            cache: Mutex::new(Cache::default()),
            cameras: Mutex::new(HashMap::new()),
            changes: std::sync::atomic::AtomicU64::new(0),
            commit: Mutex::new(()),
        }
    }

    /// The views of `scene` with their cameras (blocking: call off the async
    /// workers). Cached until the scene changes.
    pub fn scene_cameras(&self, scene: &str) -> Result<SceneCameras, AppError> {
        use std::sync::atomic::Ordering;
        let lock = || self.cameras.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(hit) = lock().get(scene) {
            return Ok(hit.clone());
        }
        let before = self.changes.load(Ordering::SeqCst);
        let names = self
            .store
            .views(scene)?
            .ok_or_else(|| AppError::NotFound(format!("no scene {scene:?}")))?;
        let mut list = Vec::with_capacity(names.len());
        for name in names {
            // A view deleted since the listing is simply left out.
            if let Some(c) = self.store.camera(scene, &name)? {
                list.push((name, Camera::try_from(&c)?));
            }
        }
        let list = Arc::new(list);
        let mut map = lock();
        if self.changes.load(Ordering::SeqCst) == before {
            map.insert(scene.to_string(), list.clone());
        }
        Ok(list)
    }

    /// Forgets what is cached about `scene`'s list of views (after a put or a delete).
    pub fn scene_changed(&self, scene: &str) {
        self.changes.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
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
        let clock = c.clock;
        if let Some((old, _)) = c.entries.insert((scene.into(), view.into()), (loaded.clone(), clock)) {
            c.bytes -= old.bytes();
        }
        c.bytes += loaded.bytes();
        while c.bytes > self.settings.cache_bytes && c.entries.len() > 1 {
            let Some(oldest) = c.entries.iter().min_by_key(|(_, (_, t))| *t).map(|(k, _)| k.clone()) else {
                break;
            };
            if let Some((gone, _)) = c.entries.remove(&oldest) {
                c.bytes -= gone.bytes();
            }
        }
        self.metrics.set_views_loaded(c.entries.len());
    }

    /// Stores an uploaded view and caches it, as one step against other
    /// changes (blocking: call off the async workers). A reader that loaded
    /// the old version from the store meanwhile does not cache it after this.
    pub fn store_view(
        &self,
        scene: &str,
        view: &str,
        stored: &StoredView,
        loaded: Arc<Loaded>,
    ) -> Result<(), AppError> {
        let _commit = self.commit.lock().unwrap_or_else(|p| p.into_inner());
        self.store.put(scene, view, stored)?;
        {
            let mut c = self.cache();
            self.changes.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            self.insert(&mut c, scene, view, loaded);
        }
        self.scene_changed(scene);
        Ok(())
    }

    /// Deletes a view (or, with `view` `None`, a scene) from the store and
    /// the cache as one step (blocking). True when it existed.
    pub fn delete(&self, scene: &str, view: Option<&str>) -> Result<bool, AppError> {
        let _commit = self.commit.lock().unwrap_or_else(|p| p.into_inner());
        let existed = match view {
            Some(v) => self.store.delete_view(scene, v)?,
            None => self.store.delete_scene(scene)?,
        };
        self.forget(scene, view);
        Ok(existed)
    }

    /// Drops a view (or, with `view` `None`, every view of the scene) from the cache.
    pub fn forget(&self, scene: &str, view: Option<&str>) {
        self.scene_changed(scene);
        let mut c = self.cache();
        let keys: Vec<_> = c
            .entries
            .keys()
            .filter(|(s, v)| s == scene && view.is_none_or(|w| w == v))
            .cloned()
            .collect();
        for k in keys {
            if let Some((gone, _)) = c.entries.remove(&k) {
                c.bytes -= gone.bytes();
            }
        }
        self.metrics.set_views_loaded(c.entries.len());
    }

    /// The loaded view, from the cache or rebuilt from the store (blocking: call off the async workers).
    pub fn load(&self, scene: &str, view: &str) -> Result<Arc<Loaded>, AppError> {
        {
            let mut c = self.cache();
            c.clock += 1;
            let clock = c.clock;
            if let Some((hit, t)) = c.entries.get_mut(&(scene.to_string(), view.to_string())) {
                *t = clock;
                return Ok(hit.clone());
            }
        }
        let before = self.changes.load(std::sync::atomic::Ordering::SeqCst);
        let stored = self
            .store
            .get(scene, view)?
            .ok_or_else(|| AppError::NotFound(format!("scene {scene:?} has no view {view:?}")))?;
        let loaded = Arc::new(Loaded::from_stored(&stored)?);
        // Cached only when nothing changed since the store was read: a
        // replace meanwhile may already have cached the newer view.
        let mut c = self.cache();
        if self.changes.load(std::sync::atomic::Ordering::SeqCst) == before {
            self.insert(&mut c, scene, view, loaded.clone());
        }
        Ok(loaded)
    }
}
