//! Median-filtered decimation: Naik Sec. 5.2.1, after its reference [53]
//! (downsampling by the median of the selected window). Each kept sample
//! takes the median of the valid samples in the window of the step's size
//! around it, which removes impulsive noise and fills small holes while
//! keeping edges; then the kept samples are triangulated as in
//! `decimate.rs`. A window with fewer valid samples than half its size
//! stays invalid.

use super::{grid_mesh, positions, Cuts, Knob, Mesher, TriMesh};
use crate::camera::Camera;
use crate::error::Result;
use crate::image::DepthImage;

/// Every n-th sample of the median-filtered depth.
#[derive(Clone, Copy, Debug, Default)]
pub struct MedianDecimate;

/// Median of the valid samples of the `(2r + 1)^2` window at `(x, y)`.
fn median(depth: &DepthImage, x: u32, y: u32, r: u32, scratch: &mut Vec<f32>) -> f32 {
    scratch.clear();
    let (x0, x1) = (x.saturating_sub(r), (x + r).min(depth.width - 1));
    let (y0, y1) = (y.saturating_sub(r), (y + r).min(depth.height - 1));
    let w = depth.width as usize;
    for yy in y0..=y1 {
        let row = &depth.z[yy as usize * w..][..w];
        scratch.extend(row[x0 as usize..=x1 as usize].iter().copied().filter(|&z| z > 0.0));
    }
    let window = ((x1 - x0 + 1) * (y1 - y0 + 1)) as usize;
    if scratch.is_empty() || 2 * scratch.len() < window {
        return 0.0;
    }
    let mid = scratch.len() / 2;
    *scratch.select_nth_unstable_by(mid, f32::total_cmp).1
}

impl Mesher for MedianDecimate {
    fn name(&self) -> &'static str {
        "median_decimate"
    }

    fn knob_name(&self) -> String {
        "step (samples)".into()
    }

    /// The step between kept samples, as in `decimate.rs`.
    fn knob(&self, depth: &DepthImage) -> Knob {
        Knob::step(depth)
    }

    fn mesh(&self, depth: &DepthImage, _camera: &Camera, step: f64) -> Result<TriMesh> {
        let xs = positions(depth.width - 1, step);
        let ys = positions(depth.height - 1, step);
        // The window spans the step: radius 1 (3 x 3) at least.
        let r = ((step / 2.0).round() as u32).max(1);
        let w = xs.len();
        let mut filtered = vec![0f32; xs.len() * ys.len()];
        let mut scratch = Vec::new();
        for (k, &y) in ys.iter().enumerate() {
            for (c, &x) in xs.iter().enumerate() {
                filtered[k * w + c] = median(depth, x, y, r, &mut scratch);
            }
        }
        let col = |x: u32| xs.binary_search(&x).unwrap_or(0);
        let row = |y: u32| ys.binary_search(&y).unwrap_or(0);
        Ok(grid_mesh(&xs, &ys, &Cuts::new(depth), |x, y| {
            filtered[row(y) * w + col(x)]
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meets_rates_is_valid_and_exact_on_planes() {
        super::super::tests::check_mesher(&MedianDecimate, false, &[5.0, 20.0]);
    }

    #[test]
    fn the_median_removes_an_outlier_and_fills_a_hole() {
        let mut z = vec![2.0f32; 25];
        z[12] = 9.0;
        z[6] = 0.0;
        let depth = DepthImage::from_z(5, 5, z).unwrap();
        let mut scratch = Vec::new();
        assert_eq!(median(&depth, 2, 2, 1, &mut scratch), 2.0);
        assert_eq!(median(&depth, 1, 1, 1, &mut scratch), 2.0);
    }
}
