//! Ingest: one uploaded view decoded (depth to `z`, mask, colour checked
//! against the depth's size: `dmesh_engine::image::decode_view`, which
//! `dmesh mesh` uses too), built, and stored with its hierarchy cached. A
//! view that cannot be meshed is not kept; a failed store leaves the old
//! view (DESIGN.md, "Store").

use std::sync::Arc;

use crate::store::{SegmentationSpec, StoredView};
use dmesh_engine::camera::{camera_from_json, Camera};
use dmesh_engine::image::{decode_view, DepthKind, DepthOptions, ViewFiles};

use super::error::AppError;
use super::state::{AppState, Loaded};

/// The parts of an upload, as the HTTP layer read them.
#[derive(Clone, Debug, Default)]
pub struct Upload {
    /// Camera JSON.
    pub camera: String,
    /// Depth image bytes (EXR, PNG, PFM or PGM).
    pub depth: Vec<u8>,
    /// Colour image bytes (PNG or JPEG).
    pub color: Vec<u8>,
    /// Mask bytes, if any.
    pub mask: Option<Vec<u8>>,
    /// How to read the depth.
    pub options: DepthOptions,
    /// How to segment.
    pub segmentation: SegmentationSpec,
}

/// Decodes, checks, builds and stores `upload` as `scene/view` (blocking:
/// call off the async workers); a `live` frame is made durable later
/// ([`AppState::persist_live`]). Returns the cached view.
pub fn ingest(state: &AppState, scene: &str, view: &str, upload: Upload, live: bool) -> Result<Arc<Loaded>, AppError> {
    upload.segmentation.validate()?;
    upload.segmentation.to_engine().validate()?;
    let camera: Camera = camera_from_json(&upload.camera)?;
    let files = ViewFiles {
        depth: &upload.depth,
        mask: upload.mask.as_deref(),
        color: Some(&upload.color),
    };
    let depth = decode_view(files, &upload.options, &camera, &state.settings.limits)?.depth;
    let stored = StoredView {
        camera: (&camera).into(),
        segmentation: upload.segmentation,
        z: depth.z,
        // Integer z keeps its lattice, so residual coding can be lossless.
        raw_grid: (upload.options.kind == DepthKind::Z).then_some(dmesh_proto::RawGrid {
            scale: upload.options.scale,
            offset: upload.options.offset,
        }),
        color: upload.color,
    };
    // Build before storing: a view that cannot be meshed is not kept.
    let loaded = Loaded::from_stored(&stored, String::new())?;
    state.store_view(scene, view, &stored, loaded, live)
}
