//! Direct decimation of the depth map: Naik Sec. 5.2.1. Every n-th sample
//! along rows and columns is kept and the kept samples are triangulated as a
//! grid, dropping triangles across discontinuities ([`super::JUMP`]) and
//! invalid samples. The thesis drops every 3rd to 6th pixel; here the step
//! is a real number (the kept positions rounded to samples) so that any
//! reduction rate can be met.

use super::{grid_mesh, positions, Cuts, Knob, Mesher, TriMesh};
use crate::camera::Camera;
use crate::error::Result;
use crate::image::DepthImage;

/// Every n-th sample.
#[derive(Clone, Copy, Debug, Default)]
pub struct Decimate;

impl Mesher for Decimate {
    fn name(&self) -> &'static str {
        "decimate"
    }

    fn knob_name(&self) -> String {
        "step (samples)".into()
    }

    /// The step between kept samples, 1 (every sample) up to the image size.
    fn knob(&self, depth: &DepthImage) -> Knob {
        Knob::step(depth)
    }

    fn mesh(&self, depth: &DepthImage, _camera: &Camera, step: f64) -> Result<TriMesh> {
        let xs = positions(depth.width - 1, step);
        let ys = positions(depth.height - 1, step);
        let w = depth.width as usize;
        Ok(grid_mesh(&xs, &ys, &Cuts::new(depth), |x, y| {
            depth.z[y as usize * w + x as usize]
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meets_rates_is_valid_and_exact_on_planes() {
        super::super::tests::check_mesher(&Decimate, true, &[5.0, 20.0]);
    }

    #[test]
    fn step_one_is_the_full_mesh() {
        let (depth, camera) = super::super::tests::boxes(40, 30);
        assert_eq!(
            Decimate.mesh(&depth, &camera, 1.0).unwrap(),
            super::super::full_mesh(&depth)
        );
    }
}
