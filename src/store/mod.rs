//! Durable storage of reference views.
//!
//! The service keeps what users uploaded (camera, depth as `z`, colour bytes,
//! segmentation settings) behind [`ViewStore`]; hierarchies are rebuilt from
//! it on demand. [`file::FileStore`] is the embedded default;
//! [`object::ObjectViewStore`] keeps views in an S3-compatible object store
//! for stateless replicas. Both encode a view the same way ([`dmv`]).
//!
//! Every read returns the view's [`Version`]: an opaque string that changes
//! whenever the view is replaced. A store that other processes write too
//! ([`ViewStore::shared`]) is revalidated against it by the server's cache.

pub mod dmv;
pub mod file;
mod ids;
pub mod object;

pub use file::FileStore;
pub use ids::validate_id;
pub use object::ObjectViewStore;

use dmesh_engine::mesh::SegmentationSpec;

/// Everything stored for one view.
#[derive(Clone, Debug, PartialEq)]
pub struct StoredView {
    /// The reference camera, wire form.
    pub camera: dmesh_proto::Camera,
    /// Segmentation settings.
    pub segmentation: SegmentationSpec,
    /// Depth as `z`, row-major, 0 for invalid.
    pub z: Vec<f32>,
    /// The affine map from raw samples to `z` when the depth was uploaded as
    /// `z` (not range or disparity): residual coding uses it to stay lossless
    /// on integer input.
    pub raw_grid: Option<dmesh_proto::RawGrid>,
    /// The colour image as uploaded (PNG or JPEG bytes), shared with the
    /// upload and the cache rather than copied.
    pub color: bytes::Bytes,
}

impl StoredView {
    /// Its parts, borrowed.
    pub fn parts(&self) -> ViewParts<'_> {
        ViewParts {
            camera: &self.camera,
            segmentation: self.segmentation,
            z: &self.z,
            raw_grid: self.raw_grid,
            color: &self.color,
        }
    }
}

/// What a store keeps of a view, borrowed: a [`StoredView`] before its
/// depths are moved into it (the server writes a view aside while the
/// depths are still the build's input).
#[derive(Clone, Copy, Debug)]
pub struct ViewParts<'a> {
    /// The reference camera, wire form.
    pub camera: &'a dmesh_proto::Camera,
    /// Segmentation settings.
    pub segmentation: SegmentationSpec,
    /// Depth as `z`, row-major, 0 for invalid.
    pub z: &'a [f32],
    /// As [`StoredView::raw_grid`].
    pub raw_grid: Option<dmesh_proto::RawGrid>,
    /// The colour image's bytes.
    pub color: &'a [u8],
}

/// A view written aside by [`ViewStore::stage`], which
/// [`ViewStore::put_staged`] makes the view's version. Dropped unused (the
/// view could not be built), what was written is removed.
#[derive(Debug, Default)]
pub struct Staged {
    aside: Option<Aside>,
}

/// A file written aside: its path, its version, and whether it reached
/// the disk.
#[derive(Debug)]
struct Aside {
    path: std::path::PathBuf,
    version: Version,
    durable: bool,
}

impl Staged {
    fn take(&mut self) -> Option<Aside> {
        self.aside.take()
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(aside) = self.aside.take() {
            let _ = std::fs::remove_file(aside.path);
        }
    }
}

/// Store failures: bad ids, or the storage itself.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// A scene or view id outside `[A-Za-z0-9._-]{1,64}` (or `.`, `..`).
    #[error("{0}")]
    BadId(String),
    /// Stored bytes that do not parse: the file was damaged outside dmesh.
    #[error("stored view {0} is damaged: {1}")]
    Damaged(String, String),
    /// The file system failed.
    #[error("storage: {0}")]
    Io(#[from] std::io::Error),
    /// A store the server depends on did not answer, or answered with an
    /// error: worth retrying shortly (the server answers 503).
    #[error("object store unavailable: {0}")]
    Unavailable(String),
}

/// A view's version: opaque, equal for equal versions of one view, changed
/// by every replace.
pub type Version = String;

/// Where views live. Implementations must make `put` durable and atomic:
/// once it returns, the view survives a crash, and a reader sees either the
/// previous version or the new one, never a mix. A failed `put` leaves the
/// previous version. Every method blocks: call them off the async workers.
pub trait ViewStore: Send + Sync {
    /// Stores (or atomically replaces) a view; returns its new version.
    fn put(&self, scene: &str, view: &str, v: &StoredView) -> Result<Version, StoreError>;
    /// [`ViewStore::put`] of one frame of a live view: atomic and visible
    /// to readers at once, but not yet durable; [`ViewStore::persist`] makes
    /// the view's latest frame durable. By default a live frame is put like
    /// any other.
    fn put_live(&self, scene: &str, view: &str, v: &StoredView) -> Result<Version, StoreError> {
        self.put(scene, view, v)
    }
    /// Makes a view's latest frame durable (after [`ViewStore::put_live`]).
    fn persist(&self, _scene: &str, _view: &str) -> Result<(), StoreError> {
        Ok(())
    }
    /// Writes `scene/view`'s `parts` aside, ahead of
    /// [`ViewStore::put_staged`], without changing the view: the server does
    /// it while the view's hierarchy is built. With `durable`, what is
    /// written reaches the disk. By default nothing is written aside
    /// (`put_staged` then puts the view whole).
    fn stage(&self, _scene: &str, _view: &str, _parts: ViewParts<'_>, _durable: bool) -> Result<Staged, StoreError> {
        Ok(Staged::default())
    }
    /// [`ViewStore::put_live`] (with `live`) or [`ViewStore::put`] of `v`,
    /// whose bytes [`ViewStore::stage`] wrote aside into `staged`.
    fn put_staged(
        &self,
        scene: &str,
        view: &str,
        v: &StoredView,
        live: bool,
        staged: Staged,
    ) -> Result<Version, StoreError> {
        drop(staged);
        if live {
            self.put_live(scene, view, v)
        } else {
            self.put(scene, view, v)
        }
    }
    /// Reads a view and its version, `None` when absent.
    fn get(&self, scene: &str, view: &str) -> Result<Option<(StoredView, Version)>, StoreError>;
    /// Reads only a view's camera (no depth, no colour) and its version,
    /// `None` when absent.
    fn camera(&self, scene: &str, view: &str) -> Result<Option<(dmesh_proto::Camera, Version)>, StoreError>;
    /// A view's current version, `None` when absent: the cheap check a
    /// cache makes before serving what it holds.
    fn version(&self, scene: &str, view: &str) -> Result<Option<Version>, StoreError>;
    /// A scene's version: an opaque token that changes whenever one of
    /// its views is put or deleted, and has changed by the time that put or
    /// delete returns; `None` when the scene does not exist. The check a
    /// replica makes to know that nothing it holds of the scene is stale.
    /// By default derived from [`ViewStore::listing`].
    fn scene_version(&self, scene: &str) -> Result<Option<Version>, StoreError> {
        use std::hash::{Hash, Hasher};
        Ok(self.listing(scene)?.map(|listing| {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            listing.hash(&mut h);
            format!("{:016x}", h.finish())
        }))
    }
    /// Scene ids, sorted.
    fn scenes(&self) -> Result<Vec<String>, StoreError>;
    /// View ids of a scene with their versions, sorted by id; `None` when
    /// the scene does not exist.
    fn listing(&self, scene: &str) -> Result<Option<Vec<(String, Version)>>, StoreError>;
    /// View ids of a scene, sorted; `None` when the scene does not exist.
    fn views(&self, scene: &str) -> Result<Option<Vec<String>>, StoreError> {
        Ok(self.listing(scene)?.map(|l| l.into_iter().map(|(v, _)| v).collect()))
    }
    /// Deletes a view; false when it did not exist.
    fn delete_view(&self, scene: &str, view: &str) -> Result<bool, StoreError>;
    /// Deletes a scene and its views; false when it did not exist.
    fn delete_scene(&self, scene: &str) -> Result<bool, StoreError>;
    /// Bytes held.
    fn bytes_stored(&self) -> Result<u64, StoreError>;
    /// Keeps a small note under `name` (an id), replacing the last: what a
    /// replica leaves for itself when it restarts (the views it held, to
    /// build before it takes traffic). By default notes are not kept.
    fn put_note(&self, _name: &str, _bytes: &[u8]) -> Result<(), StoreError> {
        Ok(())
    }
    /// The note last kept under `name`, `None` when there is none.
    fn get_note(&self, _name: &str) -> Result<Option<Vec<u8>>, StoreError> {
        Ok(None)
    }
    /// True when other processes may change the store (replicas sharing an
    /// object store): a cache must then revalidate what it holds against
    /// [`ViewStore::version`] before serving it.
    fn shared(&self) -> bool {
        false
    }
}
