//! Scenes as selection sees them (their views' names and cameras, from the
//! store's metadata alone) and, over a shared store, the checks that keep
//! what is cached of a scene current: one HEAD of its version, one LIST
//! when it changed, in the background for the scenes in use.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

use crate::store::Version;
use dmesh_engine::camera::Camera;

use super::super::error::AppError;
use super::{AppState, IDLE};

/// What this process last learnt of a scene's version (shared stores).
pub(super) struct SceneCheck {
    /// The scene's version when last checked.
    pub(super) version: Option<Version>,
    /// When the last request used the scene.
    pub(super) used: Instant,
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
    pub(super) fn relist(
        &self,
        scene: &str,
        at: Instant,
    ) -> Result<(SceneCameras, HashMap<String, Version>), AppError> {
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
    pub(super) fn used(&self, scene: &str) {
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

    pub(super) fn checks(&self) -> std::sync::MutexGuard<'_, HashMap<String, SceneCheck>> {
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
    pub(super) fn scene_changed(&self, scene: &str, view: Option<&str>) {
        self.changes.bump(scene, view);
        self.cameras.lock().unwrap_or_else(|p| p.into_inner()).remove(scene);
    }
}
