//! Scenes for the benchmarks: the synthetic terrain with boxes
//! (`dmesh_engine::synthetic`) and the Middlebury scenes from `../shared/data` when
//! that folder is present.

use dmesh_engine::camera::Camera;
use dmesh_engine::image::{decode_depth, DepthImage, DepthKind, DepthOptions, Limits};

/// Rolling terrain at 4-6 m with three boxes at 2-3 m.
pub fn synthetic(w: u32, h: u32) -> (DepthImage, Camera) {
    dmesh_engine::synthetic::terrain_with_boxes(w, h)
}

/// The scene a command-line argument names: a size of the synthetic scene
/// (`513`, `1920x1080`) or a Middlebury scene of `../shared/data`; `None`
/// (with a message on standard error) when it names neither.
#[allow(dead_code)]
pub fn from_arg(arg: &str) -> Option<(DepthImage, Camera)> {
    let scene = if arg.starts_with(|c: char| c.is_ascii_digit()) {
        let (w, h): (u32, u32) = match arg.split_once('x') {
            Some((w, h)) => (w.parse().unwrap_or(513), h.parse().unwrap_or(513)),
            None => {
                let s = arg.parse().unwrap_or(513);
                (s, s)
            }
        };
        Some(synthetic(w, h))
    } else {
        middlebury(arg)
    };
    if scene.is_none() {
        eprintln!("no scene {arg:?}: give a size (513, 1920x1080) or a Middlebury scene of ../shared/data");
    }
    scene
}

/// A Middlebury scene's left disparity as depth, or `None` when the data is absent.
#[allow(dead_code)]
pub fn middlebury(name: &str) -> Option<(DepthImage, Camera)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(name);
    let file = ["disp1.png", "disp2.png"]
        .iter()
        .map(|f| dir.join(f))
        .find(|p| p.exists())?;
    let bytes = std::fs::read(&file).ok()?;
    let dmin: f64 = std::fs::read_to_string(dir.join("dmin.txt"))
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(0.0);
    // Size variants from the data README: 2003 scenes store 4 d at quarter
    // size, half-size 2005/2006 scenes store d in full-size pixels.
    let w = u32::from_be_bytes(bytes.get(16..20)?.try_into().ok()?);
    let h = u32::from_be_bytes(bytes.get(20..24)?.try_into().ok()?);
    let (scale, focal) = match w {
        450 => (0.25, 450.0),
        w if w < 800 => (0.5, 1870.0),
        _ => (1.0, 3740.0),
    };
    let cam = Camera::perspective(w, h, focal, focal, f64::from(w - 1) / 2.0, f64::from(h - 1) / 2.0).ok()?;
    let opts = DepthOptions {
        kind: DepthKind::Disparity,
        scale,
        offset: dmin * scale,
        focal_baseline: Some(focal * 0.16),
        channel: None,
    };
    Some((decode_depth(&bytes, &opts, &cam, &Limits::default()).ok()?, cam))
}
