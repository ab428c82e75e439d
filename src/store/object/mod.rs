//! Views in an S3-compatible object store, for stateless replicas
//! (DESIGN.md, "Scale"), through the `object_store` crate.
//!
//! Layout under the prefix:
//!
//! - `scenes/{scene}`: the scene's marker, so a scene exists with no views
//!   (as a directory does in the file store). Every put and delete of one
//!   of its views rewrites it, with new content, after its own commit: its
//!   ETag is the scene's version, which a replica checks with one HEAD to
//!   know that nothing it holds of the scene is stale;
//! - `data/{scene}/{view}/{id}.dmv`: one version of a view in the
//!   [`dmv`](super::dmv) encoding, written once under a fresh id and never
//!   changed;
//! - `manifests/{scene}/{view}`: a few hundred bytes of JSON naming the
//!   current data object and holding the camera, written last;
//! - `replicas/{id}`: a replica's note for its restart, the views it held
//!   ([`ViewStore::put_note`]).
//!
//! A `put` writes the data object, then the manifest; the manifest's PUT is
//! the commit. S3 replaces a whole object atomically and reads after a write
//! see it (strong read-after-write, honoured by AWS, moto and s3s-fs), so a
//! reader sees the old manifest or the new one, and each names complete,
//! immutable data: never one version's depth with another's colour. A
//! failed data PUT leaves the old manifest; nothing relies on conditional
//! (`If-None-Match`) PUTs, which some servers ignore. The version of a view
//! is its manifest's ETag; the version of a scene its marker's. A cache
//! revalidates everything it holds of a scene with one HEAD of the marker,
//! and only when that changed with one LIST (on a server whose listings
//! carry no ETags, s3s-fs among them, one HEAD per view as well).
//!
//! The replaced data object is deleted after the commit, without a LIST:
//! the old manifest named it. A view's first upload, and every
//! [`SWEEP_EVERY`]-th upload of a process, also has the view's data
//! objects listed in the background, and those older than [`GRACE`] (left
//! by an upload that failed or lost a race) deleted: no upload waits for a
//! LIST. A reader that read the old manifest just
//! before the delete re-reads the manifest. Errors other than "not found"
//! are [`StoreError::Unavailable`]: requests are retried briefly
//! ([`RETRIES`], [`RETRY_TIMEOUT`]), then the server answers 503.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use futures_util::StreamExt;
use object_store::path::Path;
use object_store::{ObjectStore, ObjectStoreExt, PutPayload};
use serde::{Deserialize, Serialize};

mod connect;

use super::{dmv, validate_id, StoreError, StoredView, Version, ViewStore};

/// Data objects of a view other than the current one are deleted once this
/// much older than the newest (an upload in flight is far younger).
pub const GRACE: Duration = Duration::from_secs(300);
/// One upload in this many (and a view's first) lists its view's data
/// objects to delete what failed uploads left; the others LIST nothing.
pub const SWEEP_EVERY: u64 = 32;
/// Retries of a failed request before the store is reported unavailable.
pub const RETRIES: usize = 2;
/// Longest time spent retrying one request.
pub const RETRY_TIMEOUT: Duration = Duration::from_secs(2);
/// Longest one request to the object store may take (a view of a few
/// megabytes on a local network takes well under a second).
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(20);

/// What a manifest holds.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    /// The data object's id under `data/{scene}/{view}/`.
    data: String,
    /// The view's metadata (the camera, for selection without the data).
    meta: dmv::Meta,
    /// Bytes of the data object.
    bytes: u64,
}

/// Views in an object store.
pub struct ObjectViewStore {
    store: Arc<dyn ObjectStore>,
    prefix: String,
    /// The store's requests run here: the trait is blocking, and callers
    /// (the server's blocking pool, the command line) are not async.
    runtime: Option<tokio::runtime::Runtime>,
    counter: AtomicU64,
    /// Uploads made, for [`SWEEP_EVERY`].
    puts: AtomicU64,
    name: String,
}

impl std::fmt::Debug for ObjectViewStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ObjectViewStore").field("at", &self.name).finish()
    }
}

fn unavailable(e: object_store::Error) -> StoreError {
    StoreError::Unavailable(e.to_string())
}

/// `Ok(None)` for "not found", the value otherwise.
fn found<T>(r: object_store::Result<T>) -> Result<Option<T>, StoreError> {
    match r {
        Ok(v) => Ok(Some(v)),
        Err(object_store::Error::NotFound { .. }) => Ok(None),
        Err(e) => Err(unavailable(e)),
    }
}

/// The version named by an object's metadata.
fn version_of(meta: &object_store::ObjectMeta) -> Version {
    meta.e_tag
        .clone()
        .unwrap_or_else(|| format!("{}-{}", meta.last_modified.timestamp_micros(), meta.size))
}

/// The last segment of an object path.
fn file_name(p: &Path) -> Option<String> {
    p.filename().map(str::to_string)
}

impl ObjectViewStore {
    fn path(&self, rest: &str) -> Path {
        Path::from(format!("{}{rest}", self.prefix))
    }

    fn marker(&self, scene: &str) -> Result<Path, StoreError> {
        validate_id("scene", scene)?;
        Ok(self.path(&format!("scenes/{scene}")))
    }

    fn manifest_path(&self, scene: &str, view: &str) -> Result<Path, StoreError> {
        validate_id("scene", scene)?;
        validate_id("view", view)?;
        Ok(self.path(&format!("manifests/{scene}/{view}")))
    }

    fn data_dir(&self, scene: &str, view: Option<&str>) -> Path {
        match view {
            Some(v) => self.path(&format!("data/{scene}/{v}")),
            None => self.path(&format!("data/{scene}")),
        }
    }

    fn data_path(&self, scene: &str, view: &str, id: &str) -> Path {
        self.path(&format!("data/{scene}/{view}/{id}.dmv"))
    }

    /// A fresh data id: time, process and a counter, hashed with a random key.
    fn fresh_id(&self) -> String {
        use std::hash::{BuildHasher, Hasher};
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u128(now.as_nanos());
        h.write_u32(std::process::id());
        h.write_u64(self.counter.fetch_add(1, Ordering::Relaxed));
        format!("{:012x}-{:016x}", now.as_millis(), h.finish())
    }

    async fn read_manifest(&self, path: &Path) -> Result<Option<(Manifest, Version)>, StoreError> {
        let Some(got) = found(self.store.get(path).await)? else {
            return Ok(None);
        };
        let version = version_of(&got.meta);
        let bytes = found(got.bytes().await)?.ok_or_else(|| StoreError::Unavailable("manifest vanished".into()))?;
        let m: Manifest = serde_json::from_slice(&bytes)
            .map_err(|e| StoreError::Damaged(path.to_string(), format!("manifest: {e}")))?;
        Ok(Some((m, version)))
    }

    /// Objects under `dir` (everything with `None`), recursively.
    async fn list_all(&self, dir: Option<&Path>) -> Result<Vec<object_store::ObjectMeta>, StoreError> {
        let mut stream = self.store.list(dir);
        let mut out = Vec::new();
        while let Some(m) = stream.next().await {
            out.push(m.map_err(unavailable)?);
        }
        Ok(out)
    }

    /// Rewrites a scene's marker with `change` (unique to this change), so
    /// its version changes.
    async fn touch(&self, marker: &Path, change: &str) -> Result<(), StoreError> {
        let body = PutPayload::from(change.as_bytes().to_vec());
        self.store.put(marker, body).await.map(drop).map_err(unavailable)
    }

    /// Deletes `path`; "not found" is success.
    async fn remove(&self, path: &Path) -> Result<(), StoreError> {
        found(self.store.delete(path).await).map(drop)
    }

    /// Deletes the data objects of a view other than `keep` that are older
    /// than [`GRACE`] or are `replaced`, in the background: the upload that
    /// asks does not wait for its LIST. Best effort: what fails stays as
    /// garbage for the next sweep.
    fn sweep(&self, scene: &str, view: &str, keep: &str, replaced: Option<&str>) {
        let Some(rt) = &self.runtime else {
            return;
        };
        let store = self.store.clone();
        let dir = self.data_dir(scene, Some(view));
        let keep = self.data_path(scene, view, keep);
        let replaced = replaced.map(|r| self.data_path(scene, view, r));
        rt.spawn(async move {
            let mut stream = store.list(Some(&dir));
            let mut objects = Vec::new();
            while let Some(m) = stream.next().await {
                let Ok(m) = m else { return };
                objects.push(m);
            }
            let newest = objects.iter().map(|m| m.last_modified).max();
            for m in &objects {
                let old = newest.is_some_and(|n| (n - m.last_modified).num_seconds() > GRACE.as_secs() as i64);
                if m.location != keep && (old || replaced.as_ref() == Some(&m.location)) {
                    let _ = store.delete(&m.location).await;
                }
            }
        });
    }
}

impl ViewStore for ObjectViewStore {
    fn put(&self, scene: &str, view: &str, v: &StoredView) -> Result<Version, StoreError> {
        let manifest_path = self.manifest_path(scene, view)?;
        let marker = self.marker(scene)?;
        let bytes = dmv::encode(v.parts())?;
        self.block_on(async {
            let previous = self.read_manifest(&manifest_path).await.ok().flatten();
            let id = self.fresh_id();
            let data = self.data_path(scene, view, &id);
            let manifest = Manifest {
                data: id.clone(),
                meta: dmv::Meta::of(v.parts()),
                bytes: bytes.len() as u64,
            };
            let manifest = serde_json::to_vec(&manifest).map_err(|e| StoreError::Io(std::io::Error::other(e)))?;
            self.store
                .put(&data, PutPayload::from(bytes))
                .await
                .map_err(unavailable)?;
            let committed = match self.store.put(&manifest_path, PutPayload::from(manifest)).await {
                Ok(r) => r,
                Err(e) => {
                    // The old manifest stands; the new data is garbage.
                    let _ = self.remove(&data).await;
                    return Err(unavailable(e));
                }
            };
            let version = match committed.e_tag {
                Some(t) => t,
                None => version_of(&self.store.head(&manifest_path).await.map_err(unavailable)?),
            };
            // After the commit, before the answer: once the put is
            // acknowledged, the scene's version has changed.
            self.touch(&marker, &id).await?;
            let replaced = previous.map(|(m, _)| m.data);
            let sweep =
                replaced.is_none() || self.puts.fetch_add(1, Ordering::Relaxed) % SWEEP_EVERY == SWEEP_EVERY - 1;
            match replaced {
                Some(old) if !sweep => {
                    // Best effort: what fails stays as garbage for a sweep.
                    let _ = self.remove(&self.data_path(scene, view, &old)).await;
                }
                _ => self.sweep(scene, view, &id, replaced.as_deref()),
            }
            Ok(version)
        })
    }

    fn get(&self, scene: &str, view: &str) -> Result<Option<(StoredView, Version)>, StoreError> {
        let manifest_path = self.manifest_path(scene, view)?;
        let name = format!("{scene}/{view}");
        self.block_on(async {
            // A replace between reading the manifest and its data deletes
            // the data read for: read the manifest again.
            for _ in 0..3 {
                let Some((m, version)) = self.read_manifest(&manifest_path).await? else {
                    return Ok(None);
                };
                let data = self.data_path(scene, view, &m.data);
                let Some(got) = found(self.store.get(&data).await)? else {
                    continue;
                };
                let Some(bytes) = found(got.bytes().await)? else {
                    continue;
                };
                return Ok(Some((dmv::decode(&name, &bytes)?, version)));
            }
            Err(StoreError::Unavailable(format!(
                "view {name} changed three times while being read"
            )))
        })
    }

    fn camera(&self, scene: &str, view: &str) -> Result<Option<(dmesh_proto::Camera, Version)>, StoreError> {
        let path = self.manifest_path(scene, view)?;
        Ok(self
            .block_on(self.read_manifest(&path))?
            .map(|(m, version)| (m.meta.camera, version)))
    }

    fn version(&self, scene: &str, view: &str) -> Result<Option<Version>, StoreError> {
        let path = self.manifest_path(scene, view)?;
        Ok(found(self.block_on(self.store.head(&path)))?.map(|m| version_of(&m)))
    }

    fn scene_version(&self, scene: &str) -> Result<Option<Version>, StoreError> {
        let marker = self.marker(scene)?;
        Ok(found(self.block_on(self.store.head(&marker)))?.map(|m| version_of(&m)))
    }

    fn scenes(&self) -> Result<Vec<String>, StoreError> {
        let dir = self.path("scenes");
        let listed = self
            .block_on(self.store.list_with_delimiter(Some(&dir)))
            .map_err(unavailable)?;
        let mut out: Vec<String> = listed
            .objects
            .iter()
            .filter_map(|m| file_name(&m.location))
            .filter(|s| validate_id("scene", s).is_ok())
            .collect();
        out.sort();
        Ok(out)
    }

    fn listing(&self, scene: &str) -> Result<Option<Vec<(String, Version)>>, StoreError> {
        let marker = self.marker(scene)?;
        let dir = self.path(&format!("manifests/{scene}"));
        self.block_on(async {
            let listed = self.store.list_with_delimiter(Some(&dir)).await.map_err(unavailable)?;
            let mut out = Vec::with_capacity(listed.objects.len());
            for m in &listed.objects {
                let Some(name) = file_name(&m.location).filter(|v| validate_id("view", v).is_ok()) else {
                    continue;
                };
                if m.e_tag.is_some() {
                    out.push((name, version_of(m)));
                } else if let Some(head) = found(self.store.head(&m.location).await)? {
                    // Some servers (s3s-fs) list no ETags: ask each manifest.
                    out.push((name, version_of(&head)));
                }
            }
            // No views: the marker says whether the scene exists.
            if out.is_empty() && found(self.store.head(&marker).await)?.is_none() {
                return Ok(None);
            }
            out.sort();
            Ok(Some(out))
        })
    }

    fn delete_view(&self, scene: &str, view: &str) -> Result<bool, StoreError> {
        let path = self.manifest_path(scene, view)?;
        self.block_on(async {
            if found(self.store.head(&path).await)?.is_none() {
                return Ok(false);
            }
            // The manifest first: the view is gone at once; then the scene's
            // version changes; then the view's data goes.
            self.remove(&path).await?;
            self.touch(&self.marker(scene)?, &self.fresh_id()).await?;
            for m in self.list_all(Some(&self.data_dir(scene, Some(view)))).await? {
                self.remove(&m.location).await?;
            }
            Ok(true)
        })
    }

    fn delete_scene(&self, scene: &str) -> Result<bool, StoreError> {
        let marker = self.marker(scene)?;
        let manifests = self.path(&format!("manifests/{scene}"));
        self.block_on(async {
            let views = self.list_all(Some(&manifests)).await?;
            let existed = !views.is_empty() || found(self.store.head(&marker).await)?.is_some();
            for m in &views {
                self.remove(&m.location).await?;
            }
            self.remove(&marker).await?;
            for m in self.list_all(Some(&self.data_dir(scene, None))).await? {
                self.remove(&m.location).await?;
            }
            Ok(existed)
        })
    }

    fn put_note(&self, name: &str, bytes: &[u8]) -> Result<(), StoreError> {
        validate_id("note", name)?;
        let path = self.path(&format!("replicas/{name}"));
        let body = PutPayload::from(bytes.to_vec());
        self.block_on(self.store.put(&path, body))
            .map(drop)
            .map_err(unavailable)
    }

    fn get_note(&self, name: &str) -> Result<Option<Vec<u8>>, StoreError> {
        validate_id("note", name)?;
        let path = self.path(&format!("replicas/{name}"));
        self.block_on(async {
            let Some(got) = found(self.store.get(&path).await)? else {
                return Ok(None);
            };
            Ok(found(got.bytes().await)?.map(|b| b.to_vec()))
        })
    }

    fn bytes_stored(&self) -> Result<u64, StoreError> {
        let root = (!self.prefix.is_empty()).then(|| self.path(""));
        let all = self.block_on(self.list_all(root.as_ref()))?;
        Ok(all.iter().map(|m| m.size).sum())
    }

    fn shared(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_name_a_bucket() {
        for bad in ["file:///tmp", "s3://", "s3:///prefix", "bucket/prefix"] {
            assert!(
                matches!(ObjectViewStore::from_url(bad), Err(StoreError::BadId(_))),
                "{bad}"
            );
        }
    }

    #[test]
    fn an_unreachable_endpoint_is_unavailable_not_a_panic() {
        // Port 9 (discard) on loopback: nothing listens.
        let vars = [
            ("AWS_ENDPOINT_URL", "http://127.0.0.1:9"),
            ("AWS_ALLOW_HTTP", "true"),
            ("AWS_REGION", "us-east-1"),
            ("AWS_ACCESS_KEY_ID", "test"),
            ("AWS_SECRET_ACCESS_KEY", "test"),
        ]
        .map(|(k, v)| (k.to_string(), v.to_string()));
        let started = std::time::Instant::now();
        let e = ObjectViewStore::open("s3://bucket/p", vars).unwrap_err();
        assert!(matches!(e, StoreError::Unavailable(_)), "{e}");
        assert!(started.elapsed() < RETRY_TIMEOUT * 3, "{:?}", started.elapsed());
    }
}
