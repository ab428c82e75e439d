//! The embedded store: one file per view under a data directory.
//!
//! Layout: `DATA/scenes/{scene}/{view}.dmv`, written first to `DATA/tmp/`,
//! flushed to disk (`fsync`), renamed over the old file (atomic on POSIX file
//! systems) and the scene directory flushed: an acknowledged upload survives a
//! crash, and a reader never sees a half-written view. Leftover temporary
//! files from a crash are removed when the store opens. An upload is
//! written aside while its hierarchy is built ([`ViewStore::stage`]) and
//! renamed into place once it is built ([`ViewStore::put_staged`]).
//!
//! A file holds the view in the [`dmv`](super::dmv) encoding. Only this
//! process writes the directory, so its own cache needs no revalidation
//! ([`ViewStore::shared`] is false).

use std::fs::{self, File};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;

use super::{dmv, validate_id, Aside, Staged, StoreError, StoredView, Version, ViewParts, ViewStore};

const SUFFIX: &str = ".dmv";

/// Views as files under a data directory.
#[derive(Debug)]
pub struct FileStore {
    root: PathBuf,
    counter: AtomicU64,
    /// Files removed off the callers' path ([`FileStore::discard`]); `None`
    /// when the thread that removes them could not start.
    discard: Option<mpsc::Sender<PathBuf>>,
}

/// A file's version: inode, modification time and length change whenever
/// the view is replaced (a replace renames a new file over the old).
fn version_of(meta: &fs::Metadata) -> Version {
    use std::os::unix::fs::MetadataExt;
    format!(
        "{:x}-{:x}.{:x}-{:x}",
        meta.ino(),
        meta.mtime(),
        meta.mtime_nsec(),
        meta.len()
    )
}

/// Starts the kernel's writeback of `f` without waiting for it (a hint:
/// its failure changes nothing). A file renamed over another is flushed
/// at the rename on ext4 (`auto_da_alloc`, so that a power loss leaves the
/// old file or the new one, whole): 9 ms for a 1920 x 1080 frame's 8 MB on
/// this project's VMs, and 3 ms once its writeback has started.
/// `POSIX_FADV_DONTNEED` starts it (and lets the kernel drop the pages
/// once written; readers take the view from the server's cache).
fn start_writeback(f: &File) {
    #[cfg(target_os = "linux")]
    let _ = rustix::fs::fadvise(f, 0, None, rustix::fs::Advice::DontNeed);
    #[cfg(not(target_os = "linux"))]
    let _ = f;
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
        let (send, receive) = mpsc::channel::<PathBuf>();
        let discard = std::thread::Builder::new()
            .name("dmesh-store-discard".into())
            .spawn(move || {
                // Ends when the store (the sender) is dropped.
                for path in receive {
                    let _ = fs::remove_file(path);
                }
            })
            .is_ok()
            .then_some(send);
        Ok(Self {
            root,
            counter: AtomicU64::new(0),
            discard,
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

impl FileStore {
    /// Writes a view to a temporary file and renames it into place; with
    /// `durable`, the file and its directory reach the disk before the
    /// rename counts.
    fn write(&self, scene: &str, view: &str, v: ViewParts<'_>, durable: bool) -> Result<Version, StoreError> {
        let target = self.view_path(scene, view)?;
        let scene_dir = self.scene_dir(scene)?;
        if !scene_dir.exists() {
            fs::create_dir_all(&scene_dir)?;
            sync_dir(&self.root.join("scenes"))?;
        }
        let aside = self.write_aside(v, durable)?;
        self.rename_into_place(aside, &target, &scene_dir)
    }

    /// Writes a view to a temporary file (with `durable`, to the disk):
    /// removed again if this fails.
    fn write_aside(&self, v: ViewParts<'_>, durable: bool) -> Result<Aside, StoreError> {
        let path = self.tmp_path("");
        let written = (|| {
            // Through a small buffer: a 1920 x 1080 frame is not encoded
            // whole (8 MB filled and faulted in) first.
            let mut f = std::io::BufWriter::with_capacity(1 << 16, File::create(&path)?);
            dmv::write(v, &mut f)?;
            let f = f.into_inner().map_err(|e| e.into_error())?;
            if durable {
                f.sync_all()?;
            } else {
                start_writeback(&f);
            }
            Ok(version_of(&f.metadata()?))
        })();
        match written {
            Ok(version) => Ok(Aside { path, version, durable }),
            Err(e) => {
                let _ = fs::remove_file(&path);
                Err(e)
            }
        }
    }

    /// A new path in the store's temporary directory, ending in `suffix`.
    fn tmp_path(&self, suffix: &str) -> PathBuf {
        let n = self.counter.fetch_add(1, Ordering::Relaxed);
        self.root
            .join("tmp")
            .join(format!("{}-{n}{suffix}", std::process::id()))
    }

    /// Removes `path` on the store's own thread (or here, if it has none).
    fn discard(&self, path: PathBuf) {
        let unsent = match &self.discard {
            Some(send) => send.send(path).err().map(|mpsc::SendError(path)| path),
            None => Some(path),
        };
        if let Some(path) = unsent {
            let _ = fs::remove_file(path);
        }
    }

    /// Renames the file written `aside` over `target` (its directory
    /// `scene_dir` reaches the disk after, when the file did); its version.
    /// The version replaced keeps a second name in the temporary directory
    /// across the rename, which the store's own thread then removes: so
    /// freeing its pages (3 ms for a 1920 x 1080 frame's 8 MB on ext4) is
    /// not on the caller's path. A crash leaves that name in the temporary
    /// directory, which [`FileStore::open`] empties.
    fn rename_into_place(&self, aside: Aside, target: &Path, scene_dir: &Path) -> Result<Version, StoreError> {
        let old = self.tmp_path("-replaced");
        // Fails when there is no version yet: nothing to keep.
        let kept = fs::hard_link(target, &old).is_ok();
        if let Err(e) = fs::rename(&aside.path, target) {
            let _ = fs::remove_file(&aside.path);
            if kept {
                let _ = fs::remove_file(&old);
            }
            return Err(e.into());
        }
        if kept {
            self.discard(old);
        }
        if aside.durable {
            sync_dir(scene_dir)?;
        }
        Ok(aside.version)
    }
}

impl ViewStore for FileStore {
    fn put(&self, scene: &str, view: &str, v: &StoredView) -> Result<Version, StoreError> {
        self.write(scene, view, v.parts(), true)
    }

    /// Written and renamed into place like any view, without waiting for
    /// the disk: a process that dies keeps it (the kernel has it); a machine
    /// that loses power may come back with an earlier frame.
    fn put_live(&self, scene: &str, view: &str, v: &StoredView) -> Result<Version, StoreError> {
        self.write(scene, view, v.parts(), false)
    }

    /// Written to a temporary file, for a scene that exists (the first
    /// view of a scene is written at `put_staged`, so a view that cannot
    /// be built leaves no scene behind).
    fn stage(&self, scene: &str, view: &str, parts: ViewParts<'_>, durable: bool) -> Result<Staged, StoreError> {
        self.view_path(scene, view)?;
        if !self.scene_dir(scene)?.is_dir() {
            return Ok(Staged::default());
        }
        Ok(Staged {
            aside: Some(self.write_aside(parts, durable)?),
        })
    }

    /// The staged file renamed into place (made durable first if it was
    /// staged without and `live` is false); written whole when nothing
    /// was staged or the rename fails (its scene was deleted meanwhile).
    fn put_staged(
        &self,
        scene: &str,
        view: &str,
        v: &StoredView,
        live: bool,
        mut staged: Staged,
    ) -> Result<Version, StoreError> {
        let (target, scene_dir) = (self.view_path(scene, view)?, self.scene_dir(scene)?);
        match staged.take() {
            Some(aside) if live || aside.durable => self
                .rename_into_place(aside, &target, &scene_dir)
                .or_else(|_| self.write(scene, view, v.parts(), !live)),
            // Not yet on disk (or nothing aside): written whole.
            aside => {
                drop(Staged { aside });
                self.write(scene, view, v.parts(), !live)
            }
        }
    }

    fn persist(&self, scene: &str, view: &str) -> Result<(), StoreError> {
        let path = self.view_path(scene, view)?;
        match File::open(&path) {
            Ok(f) => {
                f.sync_all()?;
                sync_dir(&self.scene_dir(scene)?)?;
                Ok(())
            }
            // Deleted meanwhile: nothing to keep.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(e.into()),
        }
    }

    fn get(&self, scene: &str, view: &str) -> Result<Option<(StoredView, Version)>, StoreError> {
        let path = self.view_path(scene, view)?;
        let mut file = match File::open(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e.into()),
        };
        // The version of the file read, not of whatever the path names later.
        let version = version_of(&file.metadata()?);
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes)?;
        Ok(Some((dmv::decode(&format!("{scene}/{view}"), &bytes)?, version)))
    }

    fn camera(&self, scene: &str, view: &str) -> Result<Option<(dmesh_proto::Camera, Version)>, StoreError> {
        let path = self.view_path(scene, view)?;
        let name = format!("{scene}/{view}");
        let truncated = || StoreError::Damaged(name.clone(), "truncated".into());
        let mut file = match File::open(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e.into()),
        };
        let version = version_of(&file.metadata()?);
        // Magic and metadata length, then the metadata alone.
        let mut head = [0u8; dmv::HEAD_BYTES];
        file.read_exact(&mut head).map_err(|_| truncated())?;
        let mut meta = vec![0u8; dmv::meta_len(&name, &head)?];
        file.read_exact(&mut meta).map_err(|_| truncated())?;
        Ok(Some((dmv::decode_meta(&name, &meta)?.camera, version)))
    }

    fn version(&self, scene: &str, view: &str) -> Result<Option<Version>, StoreError> {
        match fs::metadata(self.view_path(scene, view)?) {
            Ok(m) => Ok(Some(version_of(&m))),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    fn scenes(&self) -> Result<Vec<String>, StoreError> {
        Self::list(&self.root.join("scenes"), true)
    }

    fn listing(&self, scene: &str) -> Result<Option<Vec<(String, Version)>>, StoreError> {
        let dir = self.scene_dir(scene)?;
        if !dir.is_dir() {
            return Ok(None);
        }
        let mut out = Vec::new();
        for view in Self::list(&dir, false)? {
            // A view deleted since the directory was read is left out.
            if let Some(v) = self.version(scene, &view)? {
                out.push((view, v));
            }
        }
        Ok(Some(out))
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
    use dmesh_engine::mesh::SegmentationSpec;

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
            color: vec![1, 2, 3].into(),
        }
    }

    #[test]
    fn put_get_list_delete_and_reopen() {
        let dir = tempfile::tempdir().unwrap();
        let store = FileStore::open(dir.path()).unwrap();
        store.put("s", "a", &view(1.0)).unwrap();
        store.put("s", "b", &view(2.0)).unwrap();
        let first = store.version("s", "a").unwrap().unwrap();
        let version = store.put("s", "a", &view(3.0)).unwrap();
        assert_ne!(version, first, "a replace changes the version");
        assert_eq!(store.get("s", "a").unwrap().unwrap(), (view(3.0), version.clone()));
        assert_eq!(
            store.camera("s", "a").unwrap(),
            Some((view(3.0).camera, version.clone()))
        );
        assert_eq!(store.version("s", "a").unwrap(), Some(version));
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

    /// Files in the store's temporary directory once the versions it
    /// replaced are removed (by its own thread: waited for, 10 s at most).
    fn tmp_files(dir: &Path) -> usize {
        let names = || -> Vec<String> {
            fs::read_dir(dir.join("tmp"))
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        };
        let start = std::time::Instant::now();
        while names().iter().any(|n| n.ends_with("-replaced")) {
            assert!(
                start.elapsed().as_secs() < 10,
                "replaced versions not removed: {:?}",
                names()
            );
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        names().len()
    }

    /// A view written aside changes nothing until it is put, and leaves
    /// nothing behind when dropped unput (its hierarchy failed to build);
    /// put, it is the view, durable or live, with the version it reads
    /// back with. A scene that does not exist yet is not made by staging.
    #[test]
    fn a_staged_view_is_the_view_once_put_and_nothing_when_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let store = FileStore::open(dir.path()).unwrap();
        let nothing = store.stage("new", "a", view(1.0).parts(), true).unwrap();
        assert!(nothing.aside.is_none());
        assert!(store.scenes().unwrap().is_empty(), "staging made a scene");
        let first = store.put_staged("new", "a", &view(1.0), false, nothing).unwrap();
        assert_eq!(store.get("new", "a").unwrap().unwrap(), (view(1.0), first.clone()));

        let dropped = store.stage("new", "a", view(2.0).parts(), false).unwrap();
        assert_eq!(tmp_files(dir.path()), 1);
        drop(dropped);
        assert_eq!(tmp_files(dir.path()), 0);
        assert_eq!(store.version("new", "a").unwrap(), Some(first.clone()));

        let mut previous = first;
        for (live, durable, seed) in [
            (true, false, 3.0),
            (false, true, 4.0),
            (false, false, 5.0),
            (true, true, 6.0),
        ] {
            let staged = store.stage("new", "a", view(seed).parts(), durable).unwrap();
            assert_eq!(
                store.version("new", "a").unwrap().as_ref(),
                Some(&previous),
                "staging replaced the view"
            );
            let version = store.put_staged("new", "a", &view(seed), live, staged).unwrap();
            assert_ne!(version, previous);
            let read = store.get("new", "a").unwrap().unwrap();
            assert_eq!(read, (view(seed), version.clone()), "live {live} durable {durable}");
            assert_eq!(tmp_files(dir.path()), 0);
            previous = version;
        }
    }

    /// A staged view whose scene was deleted meanwhile is still put.
    #[test]
    fn a_staged_view_outlives_its_scene_deleted_meanwhile() {
        let dir = tempfile::tempdir().unwrap();
        let store = FileStore::open(dir.path()).unwrap();
        store.put("s", "a", &view(1.0)).unwrap();
        let staged = store.stage("s", "a", view(2.0).parts(), false).unwrap();
        assert!(store.delete_scene("s").unwrap());
        let version = store.put_staged("s", "a", &view(2.0), true, staged).unwrap();
        assert_eq!(store.get("s", "a").unwrap().unwrap(), (view(2.0), version));
        assert_eq!(tmp_files(dir.path()), 0);
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
