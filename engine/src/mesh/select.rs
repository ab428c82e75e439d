//! Vertex selection: static (DMesh Sec. 4.3, Eq. 3) and view-dependent with
//! frustum culling (Sec. 4.4, Eq. 4).
//!
//! Both predicates are monotone over the hierarchy (a vertex is selected only
//! if every vertex it depends on is), which is what keeps the extracted mesh
//! conforming without an explicit dependency walk:
//! - static: `e^2 > epsilon^2`, with saturated errors;
//! - view-dependent: the error projected into the requesting camera in pixels
//!   exceeds `tau`. For a perspective camera with focal length `f` (the larger
//!   of `fx, fy`) and eye `E`, Eq. 4 with nested spheres (Lindstrom and
//!   Pascucci) reads `(f e)^2 > tau^2 (|p - E| - r)^2`, true outright when the eye
//!   is inside the sphere (`|p - E| <= r`, which covers the eye on a vertex);
//!   for an orthographic one with pixel size `s`, `e^2 > tau^2 s^2`. Frustum
//!   culling acts on triangles, not vertices: a triangle whose bounding sphere
//!   (its corners and the nested sphere of its split vertex) lies outside a
//!   frustum plane is skipped with everything below it, so the vertex test
//!   stays a function of the vertex alone.
//!
//! `epsilon = 0` and `tau = 0` mean full resolution: every vertex is selected
//! (inside the frustum), even where the surface is exactly planar.

use glam::{DMat3, DVec3};

use super::border::FORCED;
use crate::camera::{Camera, Projection};

/// Frustum planes still to test, one bit each: a triangle entirely inside a
/// plane has descendants entirely inside it too, so the traversal drops that
/// plane for them.
pub(crate) type PlaneMask = u8;

/// Every plane.
pub(crate) const ALL_PLANES: PlaneMask = 0b1_1111;

/// A selection predicate plus triangle culling.
pub(crate) trait Select {
    /// True when the vertex with squared error `err2`, position `p` and
    /// nested radius `r` is to be in the mesh. Depends on the vertex alone
    /// and is monotone over the hierarchy.
    fn active(&self, err2: f32, p: DVec3, r: f32) -> bool;
    /// `None` when a triangle whose content lies in the sphere `(centre,
    /// radius)` is entirely outside one plane of `mask`; otherwise the planes
    /// of `mask` it is not entirely inside.
    fn cull(&self, centre: DVec3, radius: f64, mask: PlaneMask) -> Option<PlaneMask>;
    /// For a vertex `active` left out: the eye distance its test allowed,
    /// `|p - E| - r` (infinite when the test does not depend on the eye).
    fn left_out(&self, _p: DVec3, _r: f32) -> f64 {
        f64::INFINITY
    }
}

/// Static selection by an object-space tolerance.
pub(crate) struct Static {
    pub eps2: f32,
    pub all: bool,
}

impl Select for Static {
    #[inline]
    fn active(&self, err2: f32, _: DVec3, _: f32) -> bool {
        self.all || err2 > self.eps2 || err2 == FORCED
    }

    #[inline]
    fn cull(&self, _: DVec3, _: f64, _: PlaneMask) -> Option<PlaneMask> {
        Some(0)
    }
}

/// View-dependent selection for a requesting camera, in the reference frame.
pub(crate) struct ViewDependent {
    /// Eye position in the reference frame.
    eye: DVec3,
    /// Frustum planes (unit normal, offset) moved into the reference frame,
    /// so no point needs transforming: inside when `n . p + d >= 0`.
    planes: [(DVec3, f64); 5],
    /// `f^2` (perspective) or `None` (orthographic).
    focal2: Option<f64>,
    /// `tau^2 s^2` for orthographic views, `tau^2` for perspective ones.
    tau2: f64,
    all: bool,
}

impl ViewDependent {
    /// Selection for `view` looking at a mesh built in `reference`'s frame.
    pub fn new(reference: &Camera, view: &Camera, tau: f64) -> Self {
        let inv = view.rotation.inverse();
        let rot = DMat3::from_quat(inv * reference.rotation);
        let off = inv * (reference.translation - view.translation);
        let eye = reference.to_camera(view.translation);
        let (w, h) = (f64::from(view.width), f64::from(view.height));
        let planes = match view.projection {
            Projection::Perspective { fx, fy, cx, cy } => {
                let (l, r) = ((-0.5 - cx) / fx, (w - 0.5 - cx) / fx);
                let (t, b) = ((-0.5 - cy) / fy, (h - 0.5 - cy) / fy);
                let unit = |n: DVec3| (n.normalize(), 0.0);
                [
                    unit(DVec3::new(1.0, 0.0, -l)),
                    unit(DVec3::new(-1.0, 0.0, r)),
                    unit(DVec3::new(0.0, 1.0, -t)),
                    unit(DVec3::new(0.0, -1.0, b)),
                    (DVec3::Z, 0.0),
                ]
            }
            Projection::Orthographic { sx, sy, cx, cy } => {
                let (l, r) = ((-0.5 - cx) * sx, (w - 0.5 - cx) * sx);
                let (t, b) = ((-0.5 - cy) * sy, (h - 0.5 - cy) * sy);
                [
                    (DVec3::X, -l),
                    (DVec3::NEG_X, r),
                    (DVec3::Y, -t),
                    (DVec3::NEG_Y, b),
                    (DVec3::Z, 0.0),
                ]
            }
        };
        let (focal2, tau2) = match (view.focal_pixels(), view.projection) {
            (Some(f), _) => (Some(f * f), tau * tau),
            (None, Projection::Orthographic { sx, sy, .. }) => (None, tau * tau * sx.min(sy).powi(2)),
            (None, _) => (None, tau * tau),
        };
        // n . (R p + o) + d = (R^T n) . p + (n . o + d).
        let planes = planes.map(|(n, d)| (rot.transpose() * n, n.dot(off) + d));
        Self {
            eye,
            planes,
            focal2,
            tau2,
            all: tau == 0.0,
        }
    }
}

impl Select for ViewDependent {
    #[inline]
    fn active(&self, err2: f32, p: DVec3, r: f32) -> bool {
        if self.all || err2 == FORCED {
            return true;
        }
        let e2 = f64::from(err2);
        match self.focal2 {
            Some(f2) => {
                let dist = (p - self.eye).length() - f64::from(r);
                dist <= 0.0 || f2 * e2 > self.tau2 * dist * dist
            }
            None => e2 > self.tau2,
        }
    }

    #[inline]
    fn left_out(&self, p: DVec3, r: f32) -> f64 {
        match self.focal2 {
            Some(_) => (p - self.eye).length() - f64::from(r),
            None => f64::INFINITY,
        }
    }

    #[inline]
    fn cull(&self, centre: DVec3, radius: f64, mask: PlaneMask) -> Option<PlaneMask> {
        let mut left = mask;
        for (i, &(n, d)) in self.planes.iter().enumerate() {
            if mask & (1 << i) == 0 {
                continue;
            }
            let dist = n.dot(centre) + d;
            if dist < -radius {
                return None;
            }
            if dist >= radius {
                left &= !(1 << i);
            }
        }
        Some(left)
    }
}
