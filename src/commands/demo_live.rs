//! `dmesh serve --demo`'s live scene `demo-live`: the demo scene's objects
//! swaying (`SceneSpec::swayed`), seen by one of its reference cameras at a
//! small size, stored by the server itself as live frames of view `v00`
//! (`PUT ...?live=true` without the HTTP: the same [`AppState::store_view`]).
//! A viewer on it follows the frames (DMesh Sec. 1: depth images "updated
//! dynamically at run-time").
//!
//! One period of the sway is rendered once, lazily, and then repeated, so
//! after the first period a frame costs its hierarchy build alone.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use dmesh::http::AppState;
use dmesh::service::Loaded;
use dmesh::store::{Staged, StoredView};
use dmesh_engine::mesh::SegmentationSpec;

/// The live scene's id.
pub const SCENE: &str = "demo-live";
/// Its one view.
const VIEW: &str = "v00";
/// The demo rig's camera that sees every object in front of the wall.
const CAMERA: usize = 4;
/// Frame size: a quarter of the demo's reference views, so a frame costs
/// a few milliseconds of one core.
const SIZE: (u32, u32) = (320, 240);

/// Stores the live scene's first frame, so the scene exists once the
/// server listens, then a thread that stores the next at `fps` until the
/// process ends, or until a client deletes or replaces the view (the feed
/// then stops, as a camera unplugged would, rather than bring the view
/// back). A frame that cannot be stored is reported and the feed goes on
/// with the next.
pub fn start(state: Arc<AppState>, fps: f64) -> Result<()> {
    let mut frames = Frames::new(fps)?;
    let mut last = frames.store(&state, 0, None)?.context("the first frame")?;
    tracing::info!("demo scene: {SCENE} moves at {fps} frames per second (view {VIEW}, live)");
    std::thread::Builder::new()
        .name("demo-live".into())
        .spawn(move || {
            let period = Duration::from_secs_f64(1.0 / fps);
            let start = Instant::now();
            for k in 1u64.. {
                let due = start + period.mul_f64(k as f64);
                std::thread::sleep(due.saturating_duration_since(Instant::now()));
                match frames.store(&state, k, Some(&last)) {
                    Ok(Some(version)) => last = version,
                    Ok(None) => {
                        tracing::info!("{SCENE}: view {VIEW} was deleted or replaced; its feed stops");
                        return;
                    }
                    Err(e) => tracing::warn!("{SCENE}: frame {k} not stored: {e:#}"),
                }
            }
        })
        .context("starting the demo-live feed")?;
    Ok(())
}

/// One period of frames, rendered as they are first needed.
struct Frames {
    spec: dmesh_engine::sim::SceneSpec,
    camera: dmesh_engine::camera::Camera,
    fps: f64,
    rendered: Vec<StoredView>,
    count: usize,
}

impl Frames {
    fn new(fps: f64) -> Result<Self> {
        let spec = dmesh_engine::sim::SceneSpec::demo();
        let camera = *spec
            .rig
            .cameras(SIZE.0, SIZE.1, spec.fov_deg)?
            .get(CAMERA)
            .context("the demo rig has too few cameras")?;
        let count = (fps * dmesh_engine::sim::SWAY_PERIOD_S).round().max(1.0) as usize;
        Ok(Self {
            spec,
            camera,
            fps,
            rendered: Vec::with_capacity(count),
            count,
        })
    }

    /// Stores frame `k` as the view's live frame, over the version
    /// `previous` when given (none stored when the view is another by
    /// then), and gives the version stored.
    fn store(&mut self, state: &AppState, k: u64, previous: Option<&str>) -> Result<Option<String>> {
        let i = (k % self.count as u64) as usize;
        if i == self.rendered.len() {
            let view = dmesh_engine::sim::render_view(&self.spec.swayed(i as f64 / self.fps), &self.camera, true, k)?;
            let img = image::RgbImage::from_raw(view.color.width, view.color.height, view.color.rgb)
                .context("frame colour")?;
            let mut color = Vec::new();
            image::DynamicImage::ImageRgb8(img)
                .write_to(&mut std::io::Cursor::new(&mut color), image::ImageFormat::Png)?;
            self.rendered.push(StoredView {
                camera: (&self.camera).into(),
                segmentation: SegmentationSpec::default(),
                z: view.depth.z,
                raw_grid: None,
                color: color.into(),
            });
        }
        let stored = &self.rendered[i];
        let loaded = Loaded::from_stored(stored, String::new())?;
        let done = match previous {
            None => Some(state.store_view(SCENE, VIEW, stored, loaded, true, Staged::default())?),
            Some(previous) => state.store_live_frame_over(SCENE, VIEW, stored, loaded, previous)?,
        };
        Ok(done.map(|loaded| loaded.version.clone()))
    }
}
