//! The embedded store: one file per view under a data directory.
//!
//! Layout: `DATA/scenes/{scene}/{view}.dmv`, written first to `DATA/tmp/`,
//! flushed to disk (`fsync`), renamed over the old file (atomic on POSIX file
//! systems) and the scene directory flushed: an acknowledged upload survives a
//! crash, and a reader never sees a half-written view. Leftover temporary
//! files from a crash are removed when the store opens.
//!
//! A `.dmv` file: the magic `DMV1`; a little-endian `u64` length and the JSON
//! metadata (`camera`, `segmentation`); a `u64` sample count and the depths as
//! little-endian `f32`; a `u64` length and the colour image bytes.

use std::fs::{self, File};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use serde::{Deserialize, Serialize};

use super::{validate_id, SegmentationSpec, StoreError, StoredView, ViewStore};

const MAGIC: &[u8; 4] = b"DMV1";
const SUFFIX: &str = ".dmv";
/// Metadata (camera, segmentation) is a few hundred bytes of JSON.
const MAX_META_BYTES: u64 = 1 << 20;

/// Views as files under a data directory.
#[derive(Debug)]
pub struct FileStore {
    root: PathBuf,
    counter: AtomicU64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Meta {
    camera: dmesh_proto::Camera,
    segmentation: SegmentationSpec,
    /// Absent in files written before residual coding.
    #[serde(default)]
    raw_grid: Option<dmesh_proto::RawGrid>,
}

/// A bounds-checked cursor over a `.dmv` file.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len())?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Some(s)
    }

    fn len(&mut self) -> Option<usize> {
        let b: [u8; 8] = self.take(8)?.try_into().ok()?;
        usize::try_from(u64::from_le_bytes(b)).ok()
    }
}

fn sync_dir(path: &Path) -> std::io::Result<()> {
    File::open(path)?.sync_all()
}

impl FileStore {
    /// Opens (creating) the store at `root` and removes temporary files left by a crash.
    pub fn open(root: impl Into<PathBuf>) -> Result<Self, StoreError> {
        let root = root.into();
        fs::create_dir_all(root.join("scenes"))?;
        let tmp = root.join("tmp");
        if tmp.exists() {
            fs::remove_dir_all(&tmp)?;
        }
        fs::create_dir_all(&tmp)?;
        sync_dir(&root)?;
        Ok(Self {
            root,
            counter: AtomicU64::new(0),
        })
    }

    fn scene_dir(&self, scene: &str) -> Result<PathBuf, StoreError> {
        validate_id("scene", scene)?;
        Ok(self.root.join("scenes").join(scene))
    }

    fn view_path(&self, scene: &str, view: &str) -> Result<PathBuf, StoreError> {
        validate_id("view", view)?;
        Ok(self.scene_dir(scene)?.join(format!("{view}{SUFFIX}")))
    }

    fn encode(v: &StoredView) -> Result<Vec<u8>, StoreError> {
        let meta = serde_json::to_vec(&Meta {
            camera: v.camera.clone(),
            segmentation: v.segmentation,
            raw_grid: v.raw_grid,
        })
        .map_err(|e| StoreError::Io(std::io::Error::other(e)))?;
        let mut out = Vec::with_capacity(4 + 24 + meta.len() + v.z.len() * 4 + v.color.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&(meta.len() as u64).to_le_bytes());
        out.extend_from_slice(&meta);
        out.extend_from_slice(&(v.z.len() as u64).to_le_bytes());
        for z in &v.z {
            out.extend_from_slice(&z.to_le_bytes());
        }
        out.extend_from_slice(&(v.color.len() as u64).to_le_bytes());
        out.extend_from_slice(&v.color);
        Ok(out)
    }

    fn decode(name: &str, bytes: &[u8]) -> Result<StoredView, StoreError> {
        let damaged = |why: &str| StoreError::Damaged(name.to_string(), why.to_string());
        let mut r = Reader { bytes, at: 0 };
        if r.take(4).ok_or_else(|| damaged("truncated"))? != MAGIC {
            return Err(damaged("bad magic"));
        }
        let n = r.len().ok_or_else(|| damaged("truncated"))?;
        let meta: Meta = serde_json::from_slice(r.take(n).ok_or_else(|| damaged("truncated"))?)
            .map_err(|e| damaged(&e.to_string()))?;
        let count = r.len().ok_or_else(|| damaged("truncated"))?;
        let raw = count
            .checked_mul(4)
            .and_then(|n| r.take(n))
            .ok_or_else(|| damaged("truncated"))?;
        let z = raw
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let n = r.len().ok_or_else(|| damaged("truncated"))?;
        let color = r.take(n).ok_or_else(|| damaged("truncated"))?.to_vec();
        if r.at != bytes.len() {
            return Err(damaged("trailing bytes"));
        }
        Ok(StoredView {
            camera: meta.camera,
            segmentation: meta.segmentation,
            raw_grid: meta.raw_grid,
            z,
            color,
        })
    }

    fn list(dir: &Path, want_dirs: bool) -> Result<Vec<String>, StoreError> {
        let mut out = Vec::new();
        for entry in fs::read_dir(dir)? {
            let entry = entry?;
            let name = entry.file_name().to_string_lossy().into_owned();
            if want_dirs && entry.file_type()?.is_dir() && validate_id("scene", &name).is_ok() {
                out.push(name);
            } else if !want_dirs {
                if let Some(view) = name.strip_suffix(SUFFIX) {
                    if validate_id("view", view).is_ok() {
                        out.push(view.to_string());
                    }
                }
            }
        }
        out.sort();
        Ok(out)
    }
}

impl ViewStore for FileStore {
    fn put(&self, scene: &str, view: &str, v: &StoredView) -> Result<(), StoreError> {
        let target = self.view_path(scene, view)?;
        let scene_dir = self.scene_dir(scene)?;
        if !scene_dir.exists() {
            fs::create_dir_all(&scene_dir)?;
            sync_dir(&self.root.join("scenes"))?;
        }
        let bytes = Self::encode(v)?;
        let n = self.counter.fetch_add(1, Ordering::Relaxed);
        let tmp = self.root.join("tmp").join(format!("{}-{n}", std::process::id()));
        let written = (|| {
            let mut f = File::create(&tmp)?;
            f.write_all(&bytes)?;
            f.sync_all()?;
            fs::rename(&tmp, &target)?;
            sync_dir(&scene_dir)
        })();
        if written.is_err() {
            let _ = fs::remove_file(&tmp);
        }
        Ok(written?)
    }

    fn get(&self, scene: &str, view: &str) -> Result<Option<StoredView>, StoreError> {
        let path = self.view_path(scene, view)?;
        match fs::read(&path) {
            Ok(bytes) => Self::decode(&format!("{scene}/{view}"), &bytes).map(Some),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    fn camera(&self, scene: &str, view: &str) -> Result<Option<dmesh_proto::Camera>, StoreError> {
        let path = self.view_path(scene, view)?;
        let name = format!("{scene}/{view}");
        let damaged = |why: &str| StoreError::Damaged(name.clone(), why.to_string());
        let mut file = match File::open(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e.into()),
        };
        // Magic and metadata length, then the metadata alone.
        let mut head = [0u8; 12];
        file.read_exact(&mut head).map_err(|_| damaged("truncated"))?;
        if &head[..4] != MAGIC {
            return Err(damaged("bad magic"));
        }
        let n = u64::from_le_bytes(head[4..].try_into().map_err(|_| damaged("truncated"))?);
        if n > MAX_META_BYTES {
            return Err(damaged("metadata too long"));
        }
        let mut meta = vec![0u8; n as usize];
        file.read_exact(&mut meta).map_err(|_| damaged("truncated"))?;
        let meta: Meta = serde_json::from_slice(&meta).map_err(|e| damaged(&e.to_string()))?;
        Ok(Some(meta.camera))
    }

    fn scenes(&self) -> Result<Vec<String>, StoreError> {
        Self::list(&self.root.join("scenes"), true)
    }

    fn views(&self, scene: &str) -> Result<Option<Vec<String>>, StoreError> {
        let dir = self.scene_dir(scene)?;
        if !dir.is_dir() {
            return Ok(None);
        }
        Self::list(&dir, false).map(Some)
    }

    fn delete_view(&self, scene: &str, view: &str) -> Result<bool, StoreError> {
        let path = self.view_path(scene, view)?;
        match fs::remove_file(&path) {
            Ok(()) => {
                sync_dir(&self.scene_dir(scene)?)?;
                Ok(true)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
            Err(e) => Err(e.into()),
        }
    }

    fn delete_scene(&self, scene: &str) -> Result<bool, StoreError> {
        let dir = self.scene_dir(scene)?;
        match fs::remove_dir_all(&dir) {
            Ok(()) => {
                sync_dir(&self.root.join("scenes"))?;
                Ok(true)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
            Err(e) => Err(e.into()),
        }
    }

    fn bytes_stored(&self) -> Result<u64, StoreError> {
        let mut total = 0;
        for scene in self.scenes()? {
            for entry in fs::read_dir(self.scene_dir(&scene)?)? {
                total += entry?.metadata()?.len();
            }
        }
        Ok(total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(seed: f32) -> StoredView {
        StoredView {
            camera: dmesh_proto::Camera {
                width: 2,
                height: 2,
                projection: dmesh_proto::Projection::Perspective {
                    fx: 2.0,
                    fy: 2.0,
                    cx: 0.5,
                    cy: 0.5,
                },
                pose: dmesh_proto::Pose::default(),
            },
            segmentation: SegmentationSpec::default(),
            z: vec![seed, 2.0, 0.0, 4.0],
            raw_grid: (seed > 1.0).then_some(dmesh_proto::RawGrid {
                scale: 0.001,
                offset: 0.5,
            }),
            color: vec![1, 2, 3],
        }
    }

    #[test]
    fn put_get_list_delete_and_reopen() {
        let dir = tempfile::tempdir().unwrap();
        let store = FileStore::open(dir.path()).unwrap();
        store.put("s", "a", &view(1.0)).unwrap();
        store.put("s", "b", &view(2.0)).unwrap();
        store.put("s", "a", &view(3.0)).unwrap();
        assert_eq!(store.get("s", "a").unwrap().unwrap(), view(3.0));
        assert_eq!(store.camera("s", "a").unwrap(), Some(view(3.0).camera));
        assert_eq!(store.camera("s", "nope").unwrap(), None);
        assert_eq!(store.views("s").unwrap().unwrap(), vec!["a", "b"]);
        assert!(store.views("t").unwrap().is_none());
        assert!(store.bytes_stored().unwrap() > 0);
        drop(store);
        let store = FileStore::open(dir.path()).unwrap();
        assert_eq!(store.scenes().unwrap(), vec!["s"]);
        assert!(store.delete_view("s", "a").unwrap());
        assert!(!store.delete_view("s", "a").unwrap());
        assert!(store.get("s", "a").unwrap().is_none());
        assert!(store.delete_scene("s").unwrap());
        assert!(store.scenes().unwrap().is_empty());
    }

    #[test]
    fn bad_ids_never_touch_the_disk() {
        let dir = tempfile::tempdir().unwrap();
        let store = FileStore::open(dir.path()).unwrap();
        for (scene, v) in [("..", "a"), ("s", "../x"), ("s", ""), ("a/b", "c")] {
            assert!(matches!(store.put(scene, v, &view(1.0)), Err(StoreError::BadId(_))));
        }
        assert!(store.scenes().unwrap().is_empty());
    }

    #[test]
    fn damaged_files_are_reported_not_panicked_on() {
        let dir = tempfile::tempdir().unwrap();
        let store = FileStore::open(dir.path()).unwrap();
        store.put("s", "a", &view(1.0)).unwrap();
        let path = dir.path().join("scenes/s/a.dmv");
        let bytes = fs::read(&path).unwrap();
        for cut in [0, 3, 10, bytes.len() - 1] {
            fs::write(&path, &bytes[..cut]).unwrap();
            assert!(matches!(store.get("s", "a"), Err(StoreError::Damaged(..))), "cut {cut}");
        }
        for cut in [0, 3, 10, 20] {
            fs::write(&path, &bytes[..cut]).unwrap();
            assert!(
                matches!(store.camera("s", "a"), Err(StoreError::Damaged(..))),
                "cut {cut}"
            );
        }
        let mut huge = bytes.clone();
        huge[4..12].copy_from_slice(&u64::MAX.to_le_bytes());
        fs::write(&path, &huge).unwrap();
        assert!(matches!(store.camera("s", "a"), Err(StoreError::Damaged(..))));
    }
}
