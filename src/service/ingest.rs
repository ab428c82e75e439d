//! Ingest: one uploaded view decoded (depth to `z`, mask, colour checked
//! against the depth's size: `dmesh_engine::image::decode_view`, which
//! `dmesh mesh` uses too; a live frame's colour from its header alone),
//! built, and stored with its hierarchy cached. A
//! view that cannot be meshed is not kept; a failed store leaves the old
//! view (DESIGN.md, "Store"). Nothing is copied or converted twice: the
//! images stay the buffers the upload arrived in, the decoded depth is
//! built and then moved into the stored view, and the camera is parsed once.

use std::sync::Arc;

use bytes::Bytes;

use crate::store::{Staged, StoredView, ViewParts};
use dmesh_engine::camera::{camera_from_json, Camera};
use dmesh_engine::image::{check_color_header, decode_view, DepthKind, DepthOptions, ViewFiles};
use dmesh_engine::mesh::{Hierarchy, SegmentationSpec};

use super::error::AppError;
use super::state::loaded::content_of;
use super::state::{AppState, Loaded};

/// The parts of an upload, as the HTTP layer read them.
#[derive(Clone, Debug, Default)]
pub struct Upload {
    /// Camera JSON.
    pub camera: String,
    /// Depth image bytes (EXR, PNG, PFM or PGM).
    pub depth: Bytes,
    /// Colour image bytes (PNG or JPEG), kept as they came.
    pub color: Bytes,
    /// Mask bytes, if any.
    pub mask: Option<Bytes>,
    /// How to read the depth.
    pub options: DepthOptions,
    /// How to segment.
    pub segmentation: SegmentationSpec,
}

/// Decodes, checks, builds and stores `upload` as `scene/view` (blocking:
/// call off the async workers); a `live` frame is made durable later
/// ([`AppState::persist_live`]). Returns the cached view.
pub fn ingest(state: &AppState, scene: &str, view: &str, upload: Upload, live: bool) -> Result<Arc<Loaded>, AppError> {
    // Every threshold, the unused ones too (the build checks the one used
    // again, which costs nothing).
    upload.segmentation.validate()?;
    let camera: Camera = camera_from_json(&upload.camera)?;
    // A live frame's colour is checked from its header: decoding it whole
    // would take a tenth of the frame's time (docs/live-journal.md).
    let files = ViewFiles {
        depth: &upload.depth,
        mask: upload.mask.as_deref(),
        color: (!live).then_some(&upload.color[..]),
    };
    let limits = &state.settings.limits;
    let depth = decode_view(files, &upload.options, &camera, limits)?.depth;
    if live {
        check_color_header(&upload.color, &depth, limits)?;
    }
    let wire_camera: dmesh_proto::Camera = (&camera).into();
    // Integer z keeps its lattice, so residual coding can be lossless.
    let raw_grid = (upload.options.kind == DepthKind::Z).then_some(dmesh_proto::RawGrid {
        scale: upload.options.scale,
        offset: upload.options.offset,
    });
    let parts = ViewParts {
        camera: &wire_camera,
        segmentation: upload.segmentation,
        z: &depth.z,
        raw_grid,
        color: &upload.color,
    };
    // While the hierarchy is built, another thread hashes the view and
    // writes it aside: the build leaves part of a second core idle, and the
    // two took a 1920 x 1080 frame 12 ms after it (docs/live-journal.md). Build
    // before storing: a view that cannot be meshed is not kept (what was
    // written aside is removed).
    let (hierarchy, aside) = std::thread::scope(|s| {
        let aside = s.spawn(|| -> Result<(Staged, u64), AppError> {
            Ok((state.store.stage(scene, view, parts, !live)?, content_of(parts)))
        });
        let hierarchy = Hierarchy::build(&depth, &camera, &upload.segmentation.to_engine());
        let aside = aside.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (hierarchy, aside)
    });
    let hierarchy = hierarchy?;
    let (staged, content) = aside?;
    let stored = StoredView {
        camera: wire_camera,
        segmentation: upload.segmentation,
        z: depth.z,
        raw_grid,
        color: upload.color,
    };
    let loaded = Loaded::from_built(hierarchy, camera, &stored, content, String::new());
    state.store_view(scene, view, &stored, loaded, live, staged)
}
