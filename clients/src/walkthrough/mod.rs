//! Walkthroughs: a thin client moving along a camera path, drawing every
//! frame from the meshes it holds and fetching by a [`policy::Strategy`]
//! (Qu et al., "Image based rendering with stable frame rates", Sec. 3;
//! DMesh Sec. 7.3 on the cost of re-extracting every frame).
//!
//! Per frame: select the reference views for the camera (DMesh Sec. 6.2, the
//! server's own rule, run here on the cameras the server listed), plan the
//! fetches, send them concurrently through [`crate::http::Server`], then
//! blend the selected held meshes. The policy knows nothing of HTTP.
//!
//! Requests are view-dependent at the target `tau` for the frame's camera
//! widened by a guard band (`guard` of the image size on each side, like
//! rendering a larger image than is shown), so that a turning camera finds
//! what it needs in the held meshes for a few frames before their culled
//! parts come into view.

pub mod path;
pub mod policy;
pub mod summary;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use dmesh_engine::camera::{Camera, Projection};
use dmesh_engine::scene::{select_views, SelectionRule};
use dmesh_engine::sim::SceneSpec;
use dmesh_proto::{StripRequest, StripResponse};
use serde::Serialize;

use crate::blend::{blend, BlendOptions, Texture, ViewInput};
use crate::compare::compare;
use crate::http::Server;
use policy::{Cost, Held, Hole, Plan, Policy};

/// A scene's reference views as a walkthrough holds them.
pub struct Scene {
    /// Scene id.
    pub id: String,
    /// View ids, in the server's order.
    pub views: Vec<String>,
    /// Their cameras.
    pub cameras: Vec<Camera>,
    /// Their colour textures (fetched once, before the walk).
    pub textures: Vec<Texture>,
}

impl Scene {
    /// Lists `scene`'s views and fetches their colour images.
    pub async fn load(server: &Server, scene: &str) -> anyhow::Result<Self> {
        let summaries = server.views(scene).await?;
        anyhow::ensure!(!summaries.is_empty(), "scene {scene} has no view");
        let mut out = Self {
            id: scene.to_string(),
            views: Vec::new(),
            cameras: Vec::new(),
            textures: Vec::new(),
        };
        for s in summaries {
            let bytes = server.color(&s.color_url).await?;
            let img = image::load_from_memory(&bytes)
                .with_context(|| format!("colour of view {}", s.view))?
                .to_rgb8();
            out.cameras.push(Camera::try_from(&s.camera)?);
            out.textures.push(Texture {
                width: img.width(),
                height: img.height(),
                rgb: img.into_raw(),
            });
            out.views.push(s.view);
        }
        Ok(out)
    }
}

/// How a walkthrough runs, besides its policy.
#[derive(Clone, Debug)]
pub struct Options {
    /// Guard band: the requested frustum is wider by this fraction of the image on each side.
    pub guard: f64,
    /// Residual bit-depth of the depths (`None`: exact).
    pub bits: Option<u8>,
    /// Largest number of views a frame draws.
    pub max_views: usize,
    /// Blending.
    pub blend: BlendOptions,
    /// Write every frame's image here as `frame-NNNN.png`.
    pub frames_out: Option<PathBuf>,
    /// Compare every frame with the simulator's ground truth of this scene.
    pub truth: Option<SceneSpec>,
    /// Refresh a held mesh by the change from it (compact stream), not whole.
    pub changes: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            guard: 0.15,
            bits: None,
            max_views: 5,
            blend: BlendOptions::default(),
            frames_out: None,
            truth: None,
            changes: true,
        }
    }
}

/// What one frame did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Frame {
    /// Frame index.
    pub frame: u32,
    /// Requests waited on plus blend, milliseconds.
    pub frame_ms: f64,
    /// The requests' part (they run concurrently).
    pub fetch_ms: f64,
    /// The blend's part.
    pub blend_ms: f64,
    /// Server extraction milliseconds summed over the frame's responses.
    pub server_ms: f64,
    /// Response bytes.
    pub bytes: u64,
    /// Triangles fetched.
    pub fetched_triangles: u64,
    /// Triangles drawn.
    pub drawn_triangles: u64,
    /// Views drawn.
    pub views: u32,
    /// Holes fetched (views missing, stale or uncovered).
    pub holes: u32,
    /// Of which: not held.
    pub missing: u32,
    /// Of which: error bound past the stale factor.
    pub stale: u32,
    /// Of which: culled parts in view.
    pub uncovered: u32,
    /// Requests the server shed (503) and were sent again.
    pub retries: u32,
    /// Held meshes refreshed.
    pub refreshed: u32,
    /// Triangles of the refreshed meshes as fetched (the plan uses the held ones').
    pub refreshed_triangles: u64,
    /// The refresh budget, in its unit (balanced only).
    pub budget: Option<f64>,
    /// Planned cost of the holes, in the budget's unit.
    pub planned_holes: f64,
    /// Planned cost of the refresh, in the budget's unit.
    pub planned_refresh: f64,
    /// `(view index, age)` of the drawn meshes after this frame's fetches, by view index.
    pub ages: Vec<(usize, u32)>,
    /// PSNR against the ground truth (valid mask), with `truth`.
    pub psnr: Option<f64>,
    /// Inverse-depth RMSE against the ground truth, with `truth`.
    pub inverse_depth_rmse: Option<f64>,
    /// Fraction of the ground truth's covered pixels the frame covers, with `truth`.
    pub coverage: Option<f64>,
}

/// `camera` widened by `guard` of its size on each side, same focal length.
pub fn widened(camera: &Camera, guard: f64) -> anyhow::Result<Camera> {
    let (gw, gh) = (
        (f64::from(camera.width) * guard).round(),
        (f64::from(camera.height) * guard).round(),
    );
    let projection = match camera.projection {
        Projection::Perspective { fx, fy, cx, cy } => Projection::Perspective {
            fx,
            fy,
            cx: cx + gw,
            cy: cy + gh,
        },
        Projection::Orthographic { sx, sy, cx, cy } => Projection::Orthographic {
            sx,
            sy,
            cx: cx + gw,
            cy: cy + gh,
        },
    };
    Ok(Camera::new(
        camera.width + 2 * gw as u32,
        camera.height + 2 * gh as u32,
        projection,
        camera.rotation,
        camera.translation,
    )?)
}

/// Times a shed request (503) is sent again, after 4, 8, 16, 32, 64 ms.
const MAX_RETRIES: u32 = 5;

/// True for a 503 (the server shed the request; it asks to retry).
fn shed(e: &anyhow::Error) -> bool {
    e.downcast_ref::<crate::http::CallError>()
        .is_some_and(|c| c.status() == hyper::StatusCode::SERVICE_UNAVAILABLE)
}

/// Walks `path` over `scene` with `policy`; `progress` is called after each frame.
pub async fn run(
    server: &Server,
    scene: &Scene,
    path: &path::Path,
    policy: &Policy,
    options: &Options,
    mut progress: impl FnMut(&Frame),
) -> anyhow::Result<Vec<Frame>> {
    // Per reference view: what the policy sees of its held mesh, and what the blend draws.
    let mut held: Vec<Option<Held>> = vec![None; scene.views.len()];
    let mut strips: Vec<Option<StripResponse>> = vec![None; scene.views.len()];
    // And, on the compact wire, the decoded mesh a refresh asks the change from.
    let mut compact: Vec<Option<crate::http::HeldMesh>> = vec![None; scene.views.len()];
    let mut frames = Vec::with_capacity(path.frames as usize);
    if let Some(dir) = &options.frames_out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    for t in 0..path.frames {
        let camera = path.camera(t)?;
        let start = Instant::now();
        for h in held.iter_mut().flatten() {
            h.age += 1;
        }
        let selected = select_views(
            &camera,
            &scene.cameras,
            SelectionRule::Dmesh { max_angle_deg: 135.0 },
            options.max_views,
        )?;
        let indices: Vec<usize> = selected.iter().map(|w| w.index).collect();
        let plan = policy.plan(t, &camera, &indices, &held);
        let mut frame = Frame {
            frame: t,
            ..Frame::default()
        };
        count_holes(&plan, &mut frame);
        let request = StripRequest {
            lod: dmesh_proto::Lod::Tau(policy.tau),
            camera: Some((&widened(&camera, options.guard)?).into()),
            bits: options.bits,
            held: None,
            held_camera: None,
        };
        let mut tasks = tokio::task::JoinSet::new();
        for v in plan.fetches() {
            let (server, scene_id, view, request) = (
                server.clone(),
                scene.id.clone(),
                scene.views[v].clone(),
                request.clone(),
            );
            let from = compact[v].clone().filter(|_| options.changes);
            tasks.spawn(async move {
                let sent = Instant::now();
                let mut retries = 0;
                let answer = loop {
                    let answer = server.strips_from(&scene_id, &view, &request, from.as_ref()).await;
                    if retries < MAX_RETRIES && answer.as_ref().is_err_and(shed) {
                        retries += 1;
                        tokio::time::sleep(std::time::Duration::from_millis(2 << retries)).await;
                        continue;
                    }
                    break answer;
                };
                (v, answer, sent.elapsed().as_secs_f64() * 1e3, retries)
            });
        }
        while let Some(done) = tasks.join_next().await {
            let (v, answer, ms, retries) = done?;
            frame.retries += retries;
            let refreshed = plan.refresh.contains(&v);
            let (mesh, kept, bytes) = answer.with_context(|| format!("frame {t}: view {}", scene.views[v]))?;
            compact[v] = kept;
            let tau = match mesh.lod {
                dmesh_proto::Lod::Tau(tau) => tau,
                // A response states epsilon or tau; only tau was asked for.
                _ => policy.tau,
            };
            let reach = mesh.reach.as_ref().map(dmesh_engine::wire::engine_reach).transpose()?;
            frame.server_ms += mesh.extract_ms;
            frame.bytes += bytes as u64;
            frame.fetched_triangles += u64::from(mesh.triangles);
            if refreshed {
                frame.refreshed_triangles += u64::from(mesh.triangles);
            }
            held[v] = Some(Held {
                age: 0,
                tau,
                reach,
                cost: Cost {
                    triangles: f64::from(mesh.triangles),
                    bytes: bytes as f64,
                    ms,
                },
            });
            strips[v] = Some(mesh);
        }
        frame.fetch_ms = start.elapsed().as_secs_f64() * 1e3;
        let drawn: Vec<(usize, ViewInput<'_>)> = selected
            .iter()
            .filter_map(|w| {
                let input = ViewInput {
                    weight: w.weight,
                    strips: strips[w.index].as_ref()?,
                    texture: &scene.textures[w.index],
                };
                Some((w.index, input))
            })
            .collect();
        let inputs: Vec<ViewInput<'_>> = drawn.iter().map(|d| d.1).collect();
        let blend_start = Instant::now();
        let image = blend(&camera, &inputs, &options.blend)?;
        frame.blend_ms = blend_start.elapsed().as_secs_f64() * 1e3;
        frame.frame_ms = start.elapsed().as_secs_f64() * 1e3;
        frame.views = drawn.len() as u32;
        frame.drawn_triangles = drawn.iter().map(|d| u64::from(d.1.strips.triangles)).sum();
        frame.ages = drawn
            .iter()
            .filter_map(|d| held[d.0].as_ref().map(|h| (d.0, h.age)))
            .collect();
        frame.ages.sort_unstable();
        if let Some(spec) = &options.truth {
            let truth = spec.ground_truth(&camera)?;
            let c = compare(&image.rgb, &truth.color.rgb, Some((&image.depth, &truth.depth.z)))?;
            frame.psnr = Some(c.psnr);
            frame.inverse_depth_rmse = c.inverse_depth_rmse;
            let valid = truth.depth.z.iter().filter(|z| **z > 0.0).count();
            let covered = truth
                .depth
                .z
                .iter()
                .zip(&image.depth)
                .filter(|(t, d)| **t > 0.0 && **d > 0.0)
                .count();
            frame.coverage = Some(if valid == 0 { 1.0 } else { covered as f64 / valid as f64 });
        }
        if let Some(dir) = &options.frames_out {
            let file = dir.join(format!("frame-{t:04}.png"));
            image::RgbImage::from_raw(image.width, image.height, image.rgb)
                .context("frame buffer size")?
                .save(&file)
                .with_context(|| format!("cannot write {}", file.display()))?;
        }
        progress(&frame);
        frames.push(frame);
    }
    Ok(frames)
}

fn count_holes(plan: &Plan, frame: &mut Frame) {
    frame.holes = plan.holes.len() as u32;
    for (_, why) in &plan.holes {
        match why {
            Hole::Missing => frame.missing += 1,
            Hole::Stale => frame.stale += 1,
            Hole::Uncovered => frame.uncovered += 1,
        }
    }
    frame.refreshed = plan.refresh.len() as u32;
    frame.budget = plan.budget;
    frame.planned_holes = plan.planned_holes;
    frame.planned_refresh = plan.planned_refresh;
}
