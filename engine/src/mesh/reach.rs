//! What a held view-dependent mesh still serves once the camera moves: the
//! facts a client needs to decide, without guessing, when a mesh it holds
//! must be fetched again (the holes of Qu et al. Sec. 3.3-3.4), from the
//! selection test of DMesh Sec. 4.4, Eq. 4 and its frustum culling.
//!
//! - Tolerance. Every vertex the walk tested and left out satisfied
//!   `f e <= tau (|p - E| - r)`, and `|p - E| - r >= clearance` for those with
//!   an error. The untested vertices below a left-out one have no larger error
//!   and lie in its nested sphere, so they are bounded by it. For a camera
//!   with eye `E'` and focal length `f'`, `|p - E'| >= |p - E| - d` with
//!   `d = |E' - E|`, and `x / (x - d)` falls with `x`, so while `d < clearance`
//!   the mesh's error in the new camera is at most
//!   `tau (f' / f) clearance / (clearance - d)` pixels ([`Reach::error_factor`]).
//!   For orthographic cameras the factor is the ratio of pixel sizes, and
//!   no clearance is recorded (the test does not depend on the eye).
//! - Coverage. Every triangle the frustum culled lies in one of the `culled`
//!   spheres, so a camera whose frustum misses them all sees nothing the mesh
//!   lacks ([`Reach::covers`]); the test is the server's own plane test.

use glam::{DQuat, DVec3};

use super::select::{Select, ViewDependent, ALL_PLANES};
use crate::camera::{Camera, Projection};

/// Most culled spheres a [`Reach`] lists.
pub const MAX_CULLED: usize = 1024;

/// How far a view-dependent mesh reaches; see the module doc.
#[derive(Clone, Debug, PartialEq)]
pub struct Reach {
    /// The camera the vertices were selected and the triangles culled for.
    pub view: Camera,
    /// Smallest `|p - E| - r` (metres, > 0) over the left-out vertices with a
    /// nonzero error; `None` when there was none (a perspective mesh is then
    /// exact wherever the eye goes) and always for an orthographic camera.
    pub clearance: Option<f64>,
    /// World-frame spheres `[x, y, z, r]` holding every culled triangle, at
    /// most [`MAX_CULLED`] (neighbours in traversal order are merged past it).
    pub culled: Vec<[f64; 4]>,
}

impl Reach {
    /// A bound on the mesh's error in `camera`, as a multiple of the
    /// tolerance it was extracted at; `None` when nothing bounds it (the eye
    /// moved by the clearance or more, or the projection kind changed).
    pub fn error_factor(&self, camera: &Camera) -> Option<f64> {
        match (self.view.projection, camera.projection) {
            (Projection::Perspective { .. }, Projection::Perspective { .. }) => {
                let Some(clearance) = self.clearance else {
                    return Some(0.0);
                };
                let d = (camera.translation - self.view.translation).length();
                let (f0, f1) = (self.view.focal_pixels()?, camera.focal_pixels()?);
                let factor = (f1 / f0) * clearance / (clearance - d);
                (d < clearance && factor.is_finite()).then_some(factor)
            }
            // The orthographic test does not depend on the eye (no vertex
            // records a clearance), only on the pixel size.
            (Projection::Orthographic { sx: ax, sy: ay, .. }, Projection::Orthographic { sx, sy, .. }) => {
                let factor = ax.min(ay) / sx.min(sy);
                factor.is_finite().then_some(factor)
            }
            _ => None,
        }
    }

    /// True when `camera`'s frustum misses every culled sphere, so every
    /// part of the view it can see is in the mesh.
    pub fn covers(&self, camera: &Camera) -> bool {
        if self.culled.is_empty() {
            return true;
        }
        let Ok(world) = Camera::new(1, 1, camera.projection, DQuat::IDENTITY, DVec3::ZERO) else {
            return false;
        };
        let planes = ViewDependent::new(&world, camera, 1.0);
        self.culled
            .iter()
            .all(|&[x, y, z, r]| planes.cull(DVec3::new(x, y, z), r, ALL_PLANES).is_none())
    }
}

/// The smallest sphere holding two spheres, padded so rounding never shrinks it.
pub(crate) fn merge_spheres(a: (DVec3, f64), b: (DVec3, f64)) -> (DVec3, f64) {
    let d = (b.0 - a.0).length();
    if d + b.1 <= a.1 {
        return a;
    }
    if d + a.1 <= b.1 {
        return b;
    }
    let r = 0.5 * (d + a.1 + b.1);
    let c = a.0 + (b.0 - a.0) * ((r - a.1) / d);
    (c, r * (1.0 + 1e-12) + 1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera_at(eye: DVec3, f: f64) -> Camera {
        Camera::new(
            64,
            48,
            Projection::Perspective {
                fx: f,
                fy: f,
                cx: 31.5,
                cy: 23.5,
            },
            DQuat::IDENTITY,
            eye,
        )
        .unwrap()
    }

    #[test]
    fn the_error_factor_grows_with_the_eye_move_and_ends_at_the_clearance() {
        let reach = Reach {
            view: camera_at(DVec3::ZERO, 50.0),
            clearance: Some(2.0),
            culled: vec![],
        };
        assert_eq!(reach.error_factor(&camera_at(DVec3::ZERO, 50.0)), Some(1.0));
        assert_eq!(reach.error_factor(&camera_at(DVec3::X, 50.0)), Some(2.0));
        assert_eq!(reach.error_factor(&camera_at(DVec3::X, 100.0)), Some(4.0));
        assert_eq!(reach.error_factor(&camera_at(2.0 * DVec3::Y, 50.0)), None);
        let exact = Reach {
            clearance: None,
            ..reach
        };
        assert_eq!(exact.error_factor(&camera_at(10.0 * DVec3::Z, 50.0)), Some(0.0));
    }

    #[test]
    fn an_orthographic_factor_is_the_ratio_of_pixel_sizes_wherever_the_eye_is() {
        let ortho = |s: f64, eye: DVec3| {
            let p = Projection::Orthographic {
                sx: s,
                sy: s,
                cx: 31.5,
                cy: 23.5,
            };
            Camera::new(64, 48, p, DQuat::IDENTITY, eye).unwrap()
        };
        // An orthographic walk records no clearance, left-out vertices or not.
        let reach = Reach {
            view: ortho(0.01, DVec3::ZERO),
            clearance: None,
            culled: vec![],
        };
        assert_eq!(reach.error_factor(&ortho(0.01, 5.0 * DVec3::X)), Some(1.0));
        assert_eq!(reach.error_factor(&ortho(0.005, DVec3::ZERO)), Some(2.0));
        assert_eq!(reach.error_factor(&camera_at(DVec3::ZERO, 50.0)), None);
    }

    #[test]
    fn a_culled_sphere_in_view_is_not_covered() {
        let cam = camera_at(DVec3::ZERO, 50.0);
        let mut reach = Reach {
            view: cam,
            clearance: None,
            culled: vec![],
        };
        assert!(reach.covers(&cam));
        // Behind the camera, then in front of it.
        reach.culled = vec![[0.0, 0.0, -5.0, 1.0]];
        assert!(reach.covers(&cam));
        reach.culled.push([0.0, 0.0, 5.0, 1.0]);
        assert!(!reach.covers(&cam));
    }

    #[test]
    fn merged_spheres_hold_both() {
        let a = (DVec3::ZERO, 1.0);
        let b = (DVec3::new(3.0, 0.0, 0.0), 0.5);
        let (c, r) = merge_spheres(a, b);
        assert!((c - a.0).length() + a.1 <= r && (c - b.0).length() + b.1 <= r);
        assert_eq!(merge_spheres(a, (DVec3::ZERO, 0.5)), a);
    }
}
