//! Quadtree decomposition with plane fit: Naik Sec. 5.2.5, Alg. 2. Each
//! block is cut along one of its diagonals into two triangles, each a plane
//! through three of the block's corner samples (the thesis's pseudo-inverse
//! of three points is that plane), in inverse depth, where a planar surface
//! is planar. The block is kept when, for the better diagonal, no sample
//! inside is farther than the threshold from its triangle's plane, and is
//! split in four otherwise (the thesis splits in two, rows then columns; a
//! quadtree split gives the same leaves one level later). Blocks holding an
//! invalid sample are split; a kept block that a discontinuity crosses
//! ([`super::Cuts`]) loses its two faces, the thesis's "faces with
//! discontinuous edges", and single cells are cut as the full mesh is. Corners are shared samples, so the
//! planes meet at block corners; where a large block borders smaller ones
//! the smaller ones' extra corners leave T-junction cracks, as in the thesis.

use std::cell::Cell;

use super::{quad, quadtree, Cuts, Knob, Mesher, TriMesh};
use crate::camera::Camera;
use crate::error::Result;
use crate::image::DepthImage;

/// Quadtree of plane-fit blocks.
#[derive(Clone, Copy, Debug, Default)]
pub struct QuadtreePlane;

/// Largest distance, in inverse depth, from the samples of a block to the
/// two planes of the diagonal `top-left` to `bottom-right` (`main`) or
/// `top-right` to `bottom-left`, stopping once it passes `limit`.
fn plane_error(depth: &DepthImage, b: [u32; 4], main: bool, limit: f64) -> f64 {
    let [x0, y0, x1, y1] = b;
    let w = depth.width as usize;
    let inv = |x: u32, y: u32| 1.0 / f64::from(depth.z[y as usize * w + x as usize]);
    let (a, bb, c, d) = (inv(x0, y0), inv(x1, y0), inv(x0, y1), inv(x1, y1));
    let (sw, sh) = (f64::from(x1 - x0), f64::from(y1 - y0));
    let mut worst = 0f64;
    for y in y0..=y1 {
        let t = f64::from(y - y0) / sh;
        for x in x0..=x1 {
            let s = f64::from(x - x0) / sw;
            let p = match (main, s >= t, s + t <= 1.0) {
                (true, true, _) => a + s * (bb - a) + t * (d - bb),
                (true, false, _) => a + s * (d - c) + t * (c - a),
                (false, _, true) => a + s * (bb - a) + t * (c - a),
                (false, _, false) => d + (1.0 - s) * (c - d) + (1.0 - t) * (bb - d),
            };
            worst = worst.max((inv(x, y) - p).abs());
        }
        if worst > limit {
            break;
        }
    }
    worst
}

impl Mesher for QuadtreePlane {
    fn name(&self) -> &'static str {
        "quadtree_plane"
    }

    fn knob_name(&self) -> String {
        "plane distance (1/m)".into()
    }

    /// The largest inverse-depth distance of a sample from its plane, 1/m.
    fn knob(&self, depth: &DepthImage) -> Knob {
        Knob::inverse_depth(depth)
    }

    fn mesh(&self, depth: &DepthImage, _camera: &Camera, threshold: f64) -> Result<TriMesh> {
        let cuts = Cuts::new(depth);
        let w = depth.width as usize;
        let mut index = vec![u32::MAX; depth.z.len()];
        let mut out = TriMesh::default();
        // accept() decides the diagonal of the block leaf() then emits.
        let main = Cell::new(true);
        quadtree(
            depth,
            &cuts,
            |x0, y0, x1, y1| {
                let b = [x0, y0, x1, y1];
                let e_main = plane_error(depth, b, true, threshold);
                if e_main <= threshold {
                    main.set(true);
                    return true;
                }
                main.set(false);
                plane_error(depth, b, false, threshold) <= threshold
            },
            |x0, y0, x1, y1| {
                let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)];
                let z = corners.map(|(x, y)| depth.z[y as usize * w + x as usize]);
                let mut idx = [0u32; 4];
                for (k, &(x, y)) in corners.iter().enumerate() {
                    let i = y as usize * w + x as usize;
                    if index[i] == u32::MAX {
                        index[i] = out.vertices.len() as u32;
                        out.vertices.push([x as f32, y as f32, z[k].max(0.0)]);
                    }
                    idx[k] = index[i];
                }
                let [a, b, c, d] = idx;
                if x1 - x0 == 1 && y1 - y0 == 1 {
                    quad(&mut out.triangles, idx, z);
                } else if cuts.clean(x0, y0, x1, y1) {
                    // (A block a discontinuity crosses gets no rubber sheet.)
                    if main.get() {
                        out.triangles.extend([[a, b, d], [a, d, c]]);
                    } else {
                        out.triangles.extend([[a, b, c], [b, d, c]]);
                    }
                }
            },
        );
        Ok(out.compact())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meets_rates_is_valid_and_exact_on_planes() {
        super::super::tests::check_mesher(&QuadtreePlane, true, &[5.0, 20.0]);
    }

    #[test]
    fn a_ridge_along_the_other_diagonal_is_one_block() {
        // Inverse depth 1 + |s + t - 1|-like: two planes meeting on the
        // top-right to bottom-left diagonal, fitted exactly by that cut only.
        let n = 9u32;
        let z: Vec<f32> = (0..n * n)
            .map(|k| {
                let (x, y) = (f64::from(k % n), f64::from(k / n));
                (1.0 / (1.0 + 0.04 * (x + y - 8.0).abs())) as f32
            })
            .collect();
        let depth = DepthImage::from_z(n, n, z).unwrap();
        let camera = Camera::perspective(n, n, 9.0, 9.0, 4.0, 4.0).unwrap();
        assert!(plane_error(&depth, [0, 0, 8, 8], true, f64::INFINITY) > 0.1);
        assert!(Cuts::new(&depth).clean(0, 0, 8, 8));
        assert!(plane_error(&depth, [0, 0, 8, 8], false, f64::INFINITY) < 1e-6);
        let m = QuadtreePlane.mesh(&depth, &camera, 1e-4).unwrap();
        assert_eq!(m.triangles.len(), 2);
    }
}
