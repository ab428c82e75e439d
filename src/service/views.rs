//! A stored view as the API shows it: loaded off the async workers, its
//! summary and the address of its colour image.

use std::sync::Arc;

use dmesh_proto::{ViewSummary, PROTOCOL_VERSION};

use super::error::AppError;
use super::state::{AppState, Loaded};
use crate::store::validate_id;

/// `/v1/scenes/{scene}/views/{view}/color`.
pub fn color_url(scene: &str, view: &str) -> String {
    format!("/v1/scenes/{scene}/views/{view}/color")
}

/// Loads a view (from the cache, or the store and a build) off the async
/// workers, after checking both ids.
pub async fn load(state: &Arc<AppState>, scene: &str, view: &str) -> Result<Arc<Loaded>, AppError> {
    validate_id("scene", scene)?;
    validate_id("view", view)?;
    let (st, sc, vw) = (state.clone(), scene.to_string(), view.to_string());
    tokio::task::spawn_blocking(move || st.load(&sc, &vw)).await?
}

/// What the API says of a view: camera, sizes, build time, colour URL and
/// the depth at its centre.
pub fn summary(scene: &str, view: &str, l: &Loaded) -> ViewSummary {
    let stats = l.hierarchy.stats();
    ViewSummary {
        version: PROTOCOL_VERSION,
        scene: scene.into(),
        view: view.into(),
        camera: (&l.camera).into(),
        grid_vertices: stats.grid_vertices as u64,
        segmented_triangles: stats.segmented_triangles as u64,
        valid_samples: l.valid_samples,
        build_ms: stats.build_ms,
        color_url: color_url(scene, view),
        center_depth: center_depth(l),
    }
}

/// Depth of the sample nearest the principal point, if valid.
fn center_depth(l: &Loaded) -> Option<f64> {
    use dmesh_engine::camera::Projection;
    let (cx, cy) = match l.camera.projection {
        Projection::Perspective { cx, cy, .. } | Projection::Orthographic { cx, cy, .. } => (cx, cy),
    };
    let clamp = |v: f64, n: u32| v.round().clamp(0.0, f64::from(n - 1)) as u32;
    let z = l
        .hierarchy
        .depth((clamp(cx, l.camera.width), clamp(cy, l.camera.height)));
    (z > 0.0).then_some(f64::from(z))
}
