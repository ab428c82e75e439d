//! Surface simplification with the quadric error metric: Naik Sec. 5.2.3,
//! after Garland and Heckbert (1997), through meshoptimizer's simplifier
//! (the `meshopt` crate) on the full-resolution mesh in camera space.
//!
//! What differs from Garland-Heckbert as the thesis used it:
//! - meshoptimizer collapses edges only onto one of their two endpoints (a
//!   half-edge collapse): no optimal position is solved for, so every kept
//!   vertex is a depth sample;
//! - it collapses mesh edges only, never the unconnected "virtual pairs"
//!   that let Garland-Heckbert join separate parts, and it keeps the
//!   topology (no collapse that would make the mesh non-manifold);
//! - border vertices (the image edge, holes, the cuts at discontinuities)
//!   move only along their border, with extra quadrics weighting borders;
//! - collapses are applied in batches of the cheapest edges per pass,
//!   rather than strictly one at a time from a global queue.
//!
//! The error limit is set past any mesh (1, in units of the mesh's extent)
//! so that the triangle target alone stops it; it may stop short of the
//! target when no collapse is left that keeps the topology.

use super::{full_mesh, Knob, Mesher, TriMesh};
use crate::camera::Camera;
use crate::error::Result;
use crate::image::DepthImage;

/// Quadric error simplification.
#[derive(Clone, Copy, Debug, Default)]
pub struct Qem;

impl Mesher for Qem {
    fn name(&self) -> &'static str {
        "qem"
    }

    fn knob_name(&self) -> String {
        "triangles".into()
    }

    fn knob(&self, _depth: &DepthImage) -> Knob {
        Knob::Triangles
    }

    fn mesh(&self, depth: &DepthImage, camera: &Camera, triangles: f64) -> Result<TriMesh> {
        let full = full_mesh(depth);
        let points: Vec<[f32; 3]> = full
            .vertices
            .iter()
            .map(|&[u, v, z]| {
                let p = camera.back_project(f64::from(u), f64::from(v), f64::from(z));
                [p.x as f32, p.y as f32, p.z as f32]
            })
            .collect();
        let indices: Vec<u32> = full.triangles.iter().flatten().copied().collect();
        let target = 3 * (triangles.max(1.0) as usize);
        let kept = meshopt::simplify_decoder(&indices, &points, target, 1.0, meshopt::SimplifyOptions::None, None);
        Ok(TriMesh {
            vertices: full.vertices,
            triangles: kept.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        }
        .compact())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meets_rates_is_valid_and_exact_on_planes() {
        super::super::tests::check_mesher(&Qem, true, &[5.0, 20.0]);
    }
}
