//! Warm restarts of replicas: each keeps a note in the store of the views
//! it holds, and after a restart builds them before it reports ready.

use std::time::{Duration, Instant};

use super::super::error::AppError;
use super::AppState;

/// A replica's note: the views it held.
#[derive(serde::Serialize, serde::Deserialize)]
struct Note {
    views: Vec<(String, String)>,
}

/// The longest a restarted replica spends building the views of its note
/// before it reports ready anyway.
pub const WARM_LIMIT: Duration = Duration::from_secs(60);

impl AppState {
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

    pub(super) fn warm_from_note(&self) -> usize {
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
}
