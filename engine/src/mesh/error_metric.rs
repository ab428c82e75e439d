//! The per-vertex approximation error, DMesh Sec. 4.2, Eq. 1 and Eq. 2.
//!
//! Both equations give the distance of a refinement point `p` to the edge
//! `a-b` it bisects, and both are kept squared (DMesh: "working with squared
//! distances eliminates the need to compute square roots"). Eq. 2 is written
//! here without its slope `m = (z_b - z_a) / (y_b - y_a)`, which divides by zero
//! on surfaces seen edge-on: the 2D distance is `cross^2 / |b - a|^2`, and a
//! degenerate edge (`a == b`) gives `|p - a|^2`. Everything is computed in f64:
//! fourth powers of coordinates reach 1e48 with a 1e-3 px focal length, past f32.

use glam::DVec3;

/// Eq. 1: squared 3D distance from `p` to the line through `a` and `b`
/// (used for centres, which bisect a diagonal).
#[inline]
pub fn point_line_3d_sq(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let ap = p - a;
    let len2 = ab.length_squared();
    if len2 > 0.0 {
        (ab.cross(ap).length_squared() / len2).max(0.0)
    } else {
        ap.length_squared()
    }
}

/// Eq. 2: squared 2D distance from `p` to the line `a-b` in the projection on
/// the plane spanned by one image axis (`s`: x for a horizontal edge, y for a
/// vertical one) and depth `z`. Arguments are `(s, z)` pairs.
#[inline]
pub fn point_line_2d_sq(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (ds, dz) = (b.0 - a.0, b.1 - a.1);
    let (ps, pz) = (p.0 - a.0, p.1 - a.1);
    let len2 = ds * ds + dz * dz;
    if len2 > 0.0 {
        let cross = ds * pz - dz * ps;
        cross * cross / len2
    } else {
        ps * ps + pz * pz
    }
}

/// An upper bound of `|d|` without a square root: `max + (mid + min) / 2` of
/// the absolute components, at most 15 % over (used for nested radii and
/// culling spheres, which may grow but never shrink).
#[inline]
pub(crate) fn norm_bound(d: DVec3) -> f64 {
    let d = d.abs();
    let m = d.max_element();
    m + 0.5 * (d.x + d.y + d.z - m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq2_matches_the_slope_form_where_that_form_is_defined() {
        let (a, b, p) = ((0.0, 1.0), (2.0, 3.0), (1.0, 2.5));
        let m: f64 = (b.1 - a.1) / (b.0 - a.0);
        let slope_form = (m * (p.0 - a.0) - (p.1 - a.1)) / (1.0 + m * m).sqrt();
        assert!((point_line_2d_sq(p, a, b) - slope_form * slope_form).abs() < 1e-12);
    }

    #[test]
    fn vertical_edge_in_the_projection_does_not_divide_by_zero() {
        // y_b == y_a: the slope form would divide by zero.
        let d = point_line_2d_sq((1.0, 5.0), (0.0, 1.0), (0.0, 9.0));
        assert_eq!(d, 1.0);
        assert_eq!(point_line_2d_sq((3.0, 4.0), (0.0, 0.0), (0.0, 0.0)), 25.0);
        assert_eq!(point_line_3d_sq(DVec3::ONE, DVec3::ZERO, DVec3::ZERO), 3.0);
    }

    #[test]
    fn norm_bound_never_undershoots() {
        for d in [
            DVec3::ONE,
            DVec3::new(3.0, -4.0, 0.0),
            DVec3::new(-1e-3, 2.0, 1e6),
            DVec3::ZERO,
        ] {
            let b = norm_bound(d);
            assert!(
                b >= d.length() && b <= 1.16 * d.length() + f64::MIN_POSITIVE,
                "{d}: {b}"
            );
        }
    }

    #[test]
    fn eq1_is_the_perpendicular_distance() {
        let d = point_line_3d_sq(DVec3::new(1.0, 2.0, 0.0), DVec3::ZERO, DVec3::new(4.0, 0.0, 0.0));
        assert!((d - 4.0).abs() < 1e-12);
    }
}
