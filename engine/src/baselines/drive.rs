//! Driving a mesher to a triangle count: Naik Sec. 6.2 compares the meshers
//! at equal reduction rates, so each one's single knob ([`Knob`]) is set,
//! directly or by bisection, to the setting whose mesh has the requested
//! number of triangles.

use super::{Knob, Mesher, TriMesh};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::image::DepthImage;

/// A mesh driven to a triangle count, with the knob setting that gave it.
pub struct Driven {
    /// The mesh.
    pub mesh: TriMesh,
    /// The knob setting.
    pub knob: f64,
    /// Wall-clock milliseconds of the meshing that gave it (the search not included).
    pub ms: f64,
    /// The fallback of the mesher that gave it ([`Mesher::fallback`], maybe
    /// several deep); `None` when the mesher itself did.
    pub runner: Option<Box<dyn Mesher>>,
}

/// Relative miss of the count past which [`drive`] tries [`Mesher::fallback`].
pub const FALLBACK_MISS: f64 = 0.1;

/// Relative distance from the target at which [`drive`] stops searching.
const GOOD_ENOUGH: f64 = 0.02;
/// Most meshes [`drive`] makes while searching a threshold.
const SEARCH_STEPS: usize = 40;

/// Runs `mesher` at the setting whose triangle count comes closest to
/// `triangles`: directly for [`Knob::Triangles`], by bisection on the
/// logarithm of the threshold for [`Knob::Coarser`] (a step function, so the
/// result can miss when the count jumps over the target); when that misses
/// by more than [`FALLBACK_MISS`], the closer of it and its fallback's.
pub fn drive(mesher: &dyn Mesher, depth: &DepthImage, camera: &Camera, triangles: usize) -> Result<Driven> {
    let first = drive_knob(mesher, depth, camera, triangles)?;
    match mesher.fallback() {
        Some(other) if miss(&first.mesh, triangles) > FALLBACK_MISS => {
            let second = drive(other.as_ref(), depth, camera, triangles)?;
            if miss(&second.mesh, triangles) >= miss(&first.mesh, triangles) {
                return Ok(first);
            }
            let Driven { mesh, knob, ms, runner } = second;
            Ok(Driven {
                mesh,
                knob,
                ms,
                runner: Some(runner.unwrap_or(other)),
            })
        }
        _ => Ok(first),
    }
}

/// Relative distance of `mesh`'s triangle count from `triangles`.
fn miss(mesh: &TriMesh, triangles: usize) -> f64 {
    (mesh.triangles.len() as f64 / triangles.max(1) as f64 - 1.0).abs()
}

fn drive_knob(mesher: &dyn Mesher, depth: &DepthImage, camera: &Camera, triangles: usize) -> Result<Driven> {
    let target = triangles.max(1) as f64;
    let timed = |knob: f64| -> Result<Driven> {
        let start = std::time::Instant::now();
        let mesh = mesher.mesh(depth, camera, knob)?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(Driven {
            mesh,
            knob,
            ms,
            runner: None,
        })
    };
    match mesher.knob(depth) {
        Knob::Triangles => timed(target),
        Knob::Coarser { lo, hi } => {
            if !(lo > 0.0 && hi >= lo && hi.is_finite()) {
                return Err(Error::invalid(format!(
                    "{}: knob range [{lo}, {hi}] is not positive and ordered",
                    mesher.name()
                )));
            }
            let (mut a, mut b) = (lo.ln(), hi.ln());
            let mut best: Option<Driven> = None;
            for _ in 0..SEARCH_STEPS {
                let knob = (0.5 * (a + b)).exp();
                let run = timed(knob)?;
                let n = run.mesh.triangles.len() as f64;
                let better = best
                    .as_ref()
                    .is_none_or(|d| miss(&run.mesh, triangles) < miss(&d.mesh, triangles));
                let done = miss(&run.mesh, triangles) <= GOOD_ENOUGH;
                if n > target {
                    a = knob.ln();
                } else {
                    b = knob.ln();
                }
                if better {
                    best = Some(run);
                }
                if done || b - a < 1e-9 {
                    break;
                }
            }
            best.ok_or_else(|| Error::invalid(format!("{}: no mesh", mesher.name())))
        }
    }
}
