//! Quadtree decomposition with constant blocks: Naik Sec. 5.2.4, Alg. 1. A
//! block is kept whole when the spread of its inverse depths (the thesis
//! works on disparity maps, which are inverse depths) is at most the
//! threshold, and is split in four otherwise; each kept block becomes two
//! triangles at one constant depth, the middle of its inverse-depth range
//! (which halves the largest error). Blocks holding an invalid sample are
//! split; single cells keep their own four depths, cut as the full mesh is.
//! A block's faces are flat, so no edge of theirs shows a discontinuity:
//! blocks whose spread is within the threshold are kept across
//! discontinuities, which the thesis reports as the method's "discontinuous
//! edges still connected". Neighbouring blocks at different depths leave
//! cracks between them, the method's holes.

use std::cell::Cell;

use super::{quad, quadtree, Cuts, Knob, Mesher, TriMesh};
use crate::camera::Camera;
use crate::error::Result;
use crate::image::DepthImage;

/// Quadtree of constant blocks.
#[derive(Clone, Copy, Debug, Default)]
pub struct QuadtreeConstant;

/// Smallest and largest inverse depth of the samples of a block, stopping
/// early once the spread passes `limit`.
fn spread(depth: &DepthImage, x0: u32, y0: u32, x1: u32, y1: u32, limit: f64) -> (f64, f64) {
    let w = depth.width as usize;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for y in y0..=y1 {
        for &z in &depth.z[y as usize * w + x0 as usize..=y as usize * w + x1 as usize] {
            let d = 1.0 / f64::from(z);
            lo = lo.min(d);
            hi = hi.max(d);
        }
        if hi - lo > limit {
            break;
        }
    }
    (lo, hi)
}

impl Mesher for QuadtreeConstant {
    fn name(&self) -> &'static str {
        "quadtree_constant"
    }

    fn knob_name(&self) -> String {
        "spread (1/m)".into()
    }

    /// The largest inverse-depth spread of a kept block, 1/m.
    fn knob(&self, depth: &DepthImage) -> Knob {
        Knob::inverse_depth(depth)
    }

    fn mesh(&self, depth: &DepthImage, _camera: &Camera, threshold: f64) -> Result<TriMesh> {
        let cuts = Cuts::new(depth);
        let w = depth.width as usize;
        let mut out = TriMesh::default();
        // accept() scans a block it keeps to the end, so leaf() takes the
        // block's spread from it rather than scanning again.
        let kept = Cell::new((0.0, 0.0));
        quadtree(
            depth,
            &cuts,
            |x0, y0, x1, y1| {
                let (lo, hi) = spread(depth, x0, y0, x1, y1, threshold);
                kept.set((lo, hi));
                hi - lo <= threshold
            },
            |x0, y0, x1, y1| {
                let base = out.vertices.len() as u32;
                let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)];
                let idx = [base, base + 1, base + 2, base + 3];
                if x1 - x0 == 1 && y1 - y0 == 1 {
                    let z = corners.map(|(x, y)| depth.z[y as usize * w + x as usize]);
                    let before = out.triangles.len();
                    quad(&mut out.triangles, idx, z);
                    if out.triangles.len() > before {
                        out.vertices.extend(
                            corners
                                .iter()
                                .zip(z)
                                .map(|(&(x, y), z)| [x as f32, y as f32, z.max(0.0)]),
                        );
                    }
                } else {
                    let (lo, hi) = kept.get();
                    let z = (2.0 / (lo + hi)) as f32;
                    out.vertices
                        .extend(corners.iter().map(|&(x, y)| [x as f32, y as f32, z]));
                    out.triangles
                        .extend([[idx[0], idx[1], idx[3]], [idx[0], idx[3], idx[2]]]);
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
        // Constant blocks are exact on a fronto-parallel plane only: on a
        // tilted one every block larger than a cell is off by half its spread.
        super::super::tests::check_mesher(&QuadtreeConstant, false, &[5.0, 20.0]);
    }

    #[test]
    fn a_block_sits_at_the_middle_of_its_inverse_depth_range() {
        let z: Vec<f32> = (0..25).map(|k| if k % 2 == 0 { 0.5 } else { 0.48 }).collect();
        let depth = DepthImage::from_z(5, 5, z).unwrap();
        let camera = Camera::perspective(5, 5, 5.0, 5.0, 2.0, 2.0).unwrap();
        // A spread of 1/0.48 - 2 = 0.083 (1/m) is within the threshold: one
        // block, two triangles at the middle inverse depth.
        let m = QuadtreeConstant.mesh(&depth, &camera, 0.1).unwrap();
        assert_eq!(m.triangles.len(), 2);
        let want = 2.0 / (2.0 + 1.0 / 0.48);
        assert!(m.vertices.iter().all(|v| (f64::from(v[2]) - want).abs() < 1e-6));
        // A tighter threshold splits it down to cells.
        assert_eq!(
            QuadtreeConstant.mesh(&depth, &camera, 0.05).unwrap().triangles.len(),
            32
        );
    }
}
