//! The scenes a report sweeps: simulated ones, whose ground truth is exact,
//! and the Middlebury 2003 pairs (left view meshed, right view as truth).

use std::path::Path;

use anyhow::Context;
use dmesh_engine::camera::Camera;
use dmesh_engine::image::{decode_depth, DepthImage, DepthKind, DepthOptions, Limits};
use dmesh_engine::sim::SceneSpec;
use dmesh_proto::RawGrid;
use glam::DVec3;

use crate::blend::Texture;

/// One reference view as the server would hold it.
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
pub struct Novel {
    /// The camera.
    pub camera: Camera,
    /// True colour.
    pub rgb: Vec<u8>,
    /// True depth `z` (0 where nothing is).
    pub depth: Vec<f32>,
}

/// A scene of the report.
pub struct Case {
    /// Its name in tables and plots.
    pub name: String,
    /// Reference views.
    pub references: Vec<Reference>,
    /// Novel views with ground truth.
    pub novels: Vec<Novel>,
    /// A typical depth, metres: epsilon sweeps are fractions of it.
    pub depth_scale: f64,
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
    })
}

/// Focal length assumed for the Middlebury 2003 scenes (pixels); depth is
/// `f B / d` with `B = 1`, and the right view sits at `B` along x.
pub const MIDDLEBURY_FOCAL: f64 = 450.0;

/// A Middlebury 2003 scene (`cones`, `teddy`) from `data/<scene>`: view 2
/// meshed, view 6 as the novel view.
pub fn middlebury(data: &Path, scene: &str) -> anyhow::Result<Case> {
    let dir = data.join(scene);
    let read = |f: &str| std::fs::read(dir.join(f)).with_context(|| format!("cannot read {}", dir.join(f).display()));
    let camera = |x: f64| {
        Camera::new(
            450,
            375,
            dmesh_engine::camera::Projection::Perspective {
                fx: MIDDLEBURY_FOCAL,
                fy: MIDDLEBURY_FOCAL,
                cx: 224.5,
                cy: 187.0,
            },
            glam::DQuat::IDENTITY,
            DVec3::new(x, 0.0, 0.0),
        )
    };
    let options = DepthOptions {
        kind: DepthKind::Disparity,
        scale: 0.25,
        focal_baseline: Some(MIDDLEBURY_FOCAL),
        ..Default::default()
    };
    let left = camera(0.0)?;
    let right = camera(1.0)?;
    let limits = Limits::default();
    let depth = decode_depth(&read("disp2.png")?, &options, &left, &limits)?;
    let truth_depth = decode_depth(&read("disp6.png")?, &options, &right, &limits)?;
    let rgb = |f: &str| -> anyhow::Result<Texture> {
        let img = image::load_from_memory(&read(f)?)?.to_rgb8();
        Ok(Texture {
            width: img.width(),
            height: img.height(),
            rgb: img.into_raw(),
        })
    };
    let truth = rgb("im6.png")?;
    Ok(Case {
        name: scene.to_string(),
        references: vec![Reference {
            camera: left,
            depth,
            texture: rgb("im2.png")?,
            raw_grid: None,
        }],
        novels: vec![Novel {
            camera: right,
            rgb: truth.rgb,
            depth: truth_depth.z,
        }],
        depth_scale: MIDDLEBURY_FOCAL / 30.0,
    })
}
