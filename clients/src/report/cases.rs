//! The scenes a report sweeps: simulated ones, whose ground truth is exact,
//! and the Middlebury pairs (left view meshed, right view as truth).

use std::path::Path;

use anyhow::Context;
use dmesh_engine::camera::Camera;
use dmesh_engine::image::{decode_depth, DepthImage, DepthKind, DepthOptions, Limits};
use dmesh_engine::render_plan;
use dmesh_engine::scene::Weighted;
use dmesh_engine::sim::SceneSpec;
use dmesh_proto::RawGrid;
use glam::DVec3;

use crate::blend::Texture;

/// One reference view as the server would hold it.
#[derive(Clone)]
pub struct Reference {
    /// Its camera.
    pub camera: Camera,
    /// Its depth.
    pub depth: DepthImage,
    /// Its colour.
    pub texture: Texture,
    /// The integer grid of its depth, if it came from integers as `z`.
    pub raw_grid: Option<RawGrid>,
}

/// A novel camera with what it should see.
#[derive(Clone)]
pub struct Novel {
    /// The camera.
    pub camera: Camera,
    /// True colour.
    pub rgb: Vec<u8>,
    /// True depth `z` (0 where nothing is).
    pub depth: Vec<f32>,
}

/// A scene of the report.
#[derive(Clone)]
pub struct Case {
    /// Its name in tables and plots.
    pub name: String,
    /// Reference views.
    pub references: Vec<Reference>,
    /// Novel views with ground truth.
    pub novels: Vec<Novel>,
    /// A typical depth, metres: epsilon sweeps are fractions of it.
    pub depth_scale: f64,
    /// `focal * baseline` of a stereo pair (disparity `= fB / z`), pixels
    /// times metres; `None` for simulated scenes.
    pub focal_baseline: Option<f64>,
}

impl Case {
    /// Each novel view's selection of the references by the DMesh rule
    /// (DMesh Sec. 6.2), at most `max_views` each (`None`: the default).
    pub fn selections(&self, max_views: Option<u32>) -> anyhow::Result<Vec<Vec<Weighted>>> {
        let cameras: Vec<Camera> = self.references.iter().map(|r| r.camera).collect();
        Ok(self
            .novels
            .iter()
            .map(|n| render_plan::select(&n.camera, &cameras, dmesh_proto::Selection::Dmesh, max_views, None))
            .collect::<Result<Vec<_>, _>>()?)
    }
}

/// The simulated demo scene, exact (`noise = None`) or with depth noise and
/// disparity quantisation, seen from `novels` cameras around it.
pub fn simulated(name: &str, noisy: bool, novels: usize) -> anyhow::Result<Case> {
    let mut spec = SceneSpec::demo();
    if noisy {
        spec.effects.noise = Some(0.003);
        spec.effects.quantize_disparity = Some(dmesh_engine::sim::effects::Quantize {
            focal_baseline: 40.0,
            steps_per_pixel: 4.0,
        });
    }
    let references = spec
        .reference_views()?
        .into_iter()
        .map(|v| Reference {
            camera: v.camera,
            depth: v.depth,
            texture: Texture {
                width: v.color.width,
                height: v.color.height,
                rgb: v.color.rgb,
            },
            raw_grid: None,
        })
        .collect();
    let target = DVec3::new(0.0, 0.4, 0.0);
    let novels = (0..novels)
        .map(|k| {
            let angle = std::f64::consts::TAU * (k as f64 + 0.37) / novels as f64;
            let height = 1.2 + 0.7 * (k % 3) as f64;
            let eye = DVec3::new(4.0 * angle.sin(), height, 4.0 * angle.cos());
            let camera = dmesh_engine::sim::rig::camera(spec.width, spec.height, spec.fov_deg, eye, target)?;
            let truth = spec.ground_truth(&camera)?;
            Ok(Novel {
                camera,
                rgb: truth.color.rgb,
                depth: truth.depth.z,
            })
        })
        .collect::<anyhow::Result<_>>()?;
    Ok(Case {
        name: name.to_string(),
        references,
        novels,
        depth_scale: 4.0,
        focal_baseline: None,
    })
}

/// Focal length assumed for the Middlebury 2003 scenes (pixels); depth is
/// `f B / d` with `B = 1`, and the right view sits at `B` along x.
pub const MIDDLEBURY_FOCAL: f64 = 450.0;

/// Focal length of the full-size Middlebury 2005 and 2006 scenes, pixels,
/// and their baseline between views 1 and 5, metres (the datasets' pages).
const FULL_SIZE_FOCAL: f64 = 3740.0;
const BASELINE_2005: f64 = 0.16;

/// Where a Middlebury scene's files are and what its disparities mean.
struct Layout {
    left: &'static str,
    right: &'static str,
    left_disparity: &'static str,
    right_disparity: &'static str,
    /// Raw PNG value to disparity in this image's pixels.
    scale: f64,
    /// Disparity offset of the cropped views (`dmin`, scaled to the size):
    /// true disparity is `scale * v + offset`, and the right camera's
    /// principal point sits `offset` pixels right of the left one's, so that
    /// a left pixel `x` still matches the right pixel `x - scale * v`.
    offset: f64,
    focal: f64,
    baseline: f64,
}

fn layout(dir: &Path, width: u32) -> anyhow::Result<Layout> {
    if dir.join("im2.png").exists() {
        // 2003, quarter size: d = v / 4, focal and baseline unknown.
        return Ok(Layout {
            left: "im2.png",
            right: "im6.png",
            left_disparity: "disp2.png",
            right_disparity: "disp6.png",
            scale: 0.25,
            offset: 0.0,
            focal: MIDDLEBURY_FOCAL,
            baseline: 1.0,
        });
    }
    // 2005 and 2006: half size (d = v / 2) or full size (d = v), with dmin.
    let dmin_path = dir.join("dmin.txt");
    let dmin: f64 = std::fs::read_to_string(&dmin_path)
        .with_context(|| format!("cannot read {}", dmin_path.display()))?
        .trim()
        .parse()
        .with_context(|| format!("{} does not hold a number", dmin_path.display()))?;
    let scale = if width < 1000 { 0.5 } else { 1.0 };
    Ok(Layout {
        left: "view1.png",
        right: "view5.png",
        left_disparity: "disp1.png",
        right_disparity: "disp5.png",
        scale,
        offset: dmin * scale,
        focal: FULL_SIZE_FOCAL * scale,
        baseline: BASELINE_2005,
    })
}

/// A Middlebury scene from `data/<scene>`: the left view meshed, the right
/// one as the novel view. 2003 scenes (`cones`, `teddy`: views 2 and 6) use
/// an assumed focal length of [`MIDDLEBURY_FOCAL`] and a baseline of 1;
/// 2005 and 2006 ones (`art`, `aloe`, `reindeer`, ...: views 1 and 5) their
/// published focal length and baseline, and `dmin`.
pub fn middlebury(data: &Path, scene: &str) -> anyhow::Result<Case> {
    let dir = data.join(scene);
    let read = |f: &str| std::fs::read(dir.join(f)).with_context(|| format!("cannot read {}", dir.join(f).display()));
    let probe = if dir.join("im2.png").exists() {
        "im2.png"
    } else {
        "view1.png"
    };
    let (width, height) = image::load_from_memory(&read(probe)?)?.to_rgb8().dimensions();
    let l = layout(&dir, width)?;
    let fb = l.focal * l.baseline;
    let (cx, cy) = ((f64::from(width) - 1.0) / 2.0, (f64::from(height) - 1.0) / 2.0);
    let camera = |x: f64, cx: f64| {
        Camera::new(
            width,
            height,
            dmesh_engine::camera::Projection::Perspective {
                fx: l.focal,
                fy: l.focal,
                cx,
                cy,
            },
            glam::DQuat::IDENTITY,
            DVec3::new(x, 0.0, 0.0),
        )
    };
    let options = DepthOptions {
        kind: DepthKind::Disparity,
        scale: l.scale,
        offset: l.offset,
        focal_baseline: Some(fb),
        ..Default::default()
    };
    let left = camera(0.0, cx)?;
    let right = camera(l.baseline, cx + l.offset)?;
    let limits = Limits::default();
    let depth = decode_depth(&read(l.left_disparity)?, &options, &left, &limits)?;
    let truth_depth = decode_depth(&read(l.right_disparity)?, &options, &right, &limits)?;
    let rgb = |f: &str| -> anyhow::Result<Texture> {
        let img = image::load_from_memory(&read(f)?)?.to_rgb8();
        Ok(Texture {
            width: img.width(),
            height: img.height(),
            rgb: img.into_raw(),
        })
    };
    let truth = rgb(l.right)?;
    Ok(Case {
        name: scene.to_string(),
        references: vec![Reference {
            camera: left,
            depth,
            texture: rgb(l.left)?,
            raw_grid: None,
        }],
        novels: vec![Novel {
            camera: right,
            rgb: truth.rgb,
            depth: truth_depth.z,
        }],
        // The depth of a disparity of 30 quarter-size pixels.
        depth_scale: fb / (l.offset + 120.0 * l.scale),
        focal_baseline: Some(fb),
    })
}
