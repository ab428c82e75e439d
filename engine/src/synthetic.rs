//! Synthetic depth maps that need no files: a rolling terrain at 4-6 m with
//! three boxes at 2-3 m in front of it (smooth regions, creases and depth
//! discontinuities), seen by a perspective camera with a 58-degree field of
//! view, or the same terrain as an orthographic height field. Used by the
//! demo, the benchmarks and the tests.

use crate::camera::Camera;
use crate::image::DepthImage;

fn terrain(u: f64, v: f64) -> f64 {
    5.0 + 0.6 * (5.0 * u).sin() * (3.0 * v).cos() + 0.15 * (23.0 * u + 7.0 * v).sin() + 0.04 * (71.0 * v).sin()
}

/// The terrain-and-boxes scene at `width x height` (both >= 2) and its camera.
pub fn terrain_with_boxes(width: u32, height: u32) -> (DepthImage, Camera) {
    let (w, h) = (width.max(2), height.max(2));
    let f = f64::from(w.max(h)) * 0.9;
    let cam = Camera::perspective(w, h, f, f, f64::from(w - 1) / 2.0, f64::from(h - 1) / 2.0)
        .unwrap_or_else(|_| unreachable!("positive focal length and finite centre"));
    let mut z = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (f64::from(x) / f64::from(w), f64::from(y) / f64::from(h));
            let mut d = terrain(u, v);
            for (cx, cy, r, zb) in [(0.3, 0.4, 0.12, 2.0), (0.7, 0.6, 0.15, 2.5), (0.5, 0.8, 0.08, 3.0)] {
                if (u - cx).abs() < r && (v - cy).abs() < r {
                    d = zb + 0.5 * (u - cx);
                }
            }
            z.push(d as f32);
        }
    }
    let depth = DepthImage::from_z(w, h, z).unwrap_or_else(|_| unreachable!("size matches and is at least 2x2"));
    (depth, cam)
}

/// The terrain alone as a height field in metres over a `size x size` grid
/// of 1 m cells (orthographic camera, `sx = sy = 1`), relief about 50 m.
pub fn height_field(size: u32) -> (DepthImage, Camera) {
    let s = size.max(2);
    let cam = Camera::orthographic(s, s, 1.0, 1.0, 0.0, 0.0).unwrap_or_else(|_| unreachable!("unit scales"));
    let z = (0..s)
        .flat_map(|y| (0..s).map(move |x| (x, y)))
        .map(|(x, y)| (100.0 + 40.0 * (terrain(f64::from(x) / f64::from(s), f64::from(y) / f64::from(s)) - 5.0)) as f32)
        .collect();
    let depth = DepthImage::from_z(s, s, z).unwrap_or_else(|_| unreachable!("size matches and is at least 2x2"));
    (depth, cam)
}
