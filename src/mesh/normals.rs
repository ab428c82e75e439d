//! Per-vertex normals and the sampling quality rho, DMesh Sec. 4.2.
//!
//! The normal of a sample is the cross product of the central differences of
//! its back-projected neighbours along the row and the column (one-sided where
//! a neighbour is invalid or off the image), turned to face the reference
//! camera. `rho = |n . v|` with `v` the unit direction from the camera to the
//! sample: 1 where the surface faces the camera, 0 where it is seen edge-on.
//! A sample with no usable neighbour gets the normal facing the camera and
//! `rho = 0` (nothing is known of its orientation). Normals travel
//! octahedron-encoded in two bytes, `rho` in one.

use glam::{DVec2, DVec3};

use super::backproject::BackProject;
use super::grid::Grid;
use crate::camera::Camera;

/// Octahedral encoding of a unit vector into two bytes.
pub fn oct_encode(n: DVec3) -> [u8; 2] {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if !(l1 > 0.0 && l1.is_finite()) {
        return oct_encode(DVec3::NEG_Z);
    }
    let mut p = DVec2::new(n.x, n.y) / l1;
    if n.z < 0.0 {
        let sign = |v: f64| if v >= 0.0 { 1.0 } else { -1.0 };
        p = DVec2::new((1.0 - p.y.abs()) * sign(p.x), (1.0 - p.x.abs()) * sign(p.y));
    }
    let q = |v: f64| ((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * 255.0).round() as u8;
    [q(p.x), q(p.y)]
}

/// Inverse of [`oct_encode`]: a unit vector.
pub fn oct_decode(e: [u8; 2]) -> DVec3 {
    let x = f64::from(e[0]) / 255.0 * 2.0 - 1.0;
    let y = f64::from(e[1]) / 255.0 * 2.0 - 1.0;
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let sign = |v: f64| if v >= 0.0 { 1.0 } else { -1.0 };
    let n = DVec3::new(x - t * sign(x), y - t * sign(y), z);
    n.try_normalize().unwrap_or(DVec3::NEG_Z)
}

/// Quantises `rho` in `[0, 1]` to a byte.
pub fn rho_to_byte(rho: f64) -> u8 {
    (rho.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Computes the encoded normal and quality byte of every grid vertex.
pub fn normals_and_quality(
    grid: &Grid,
    camera: &Camera,
    bp: &BackProject,
    z: &[f32],
) -> (Vec<[u8; 2]>, Vec<u8>) {
    let (gw, gh) = (grid.gw(), grid.gh());
    let facing = oct_encode(DVec3::NEG_Z);
    let mut normals = vec![facing; grid.len()];
    let mut rho = vec![0u8; grid.len()];
    let valid = |x: i64, y: i64| -> Option<DVec3> {
        if x < 0 || y < 0 || x >= i64::from(grid.width) || y >= i64::from(grid.height) {
            return None;
        }
        let (x, y) = (x as u32, y as u32);
        let zz = z[y as usize * gw as usize + x as usize];
        (zz > 0.0).then(|| bp.point(x, y, zz))
    };
    // Difference across a sample along one axis, one-sided where needed.
    let diff = |c: DVec3, lo: Option<DVec3>, hi: Option<DVec3>| match (lo, hi) {
        (Some(l), Some(h)) => Some(h - l),
        (None, Some(h)) => Some(h - c),
        (Some(l), None) => Some(c - l),
        (None, None) => None,
    };
    for y in 0..grid.height.min(gh) {
        for x in 0..grid.width.min(gw) {
            let idx = y as usize * gw as usize + x as usize;
            let zz = z[idx];
            if zz <= 0.0 {
                continue;
            }
            let p = bp.point(x, y, zz);
            let (xi, yi) = (i64::from(x), i64::from(y));
            let dx = diff(p, valid(xi - 1, yi), valid(xi + 1, yi));
            let dy = diff(p, valid(xi, yi - 1), valid(xi, yi + 1));
            let n = match (dx, dy) {
                (Some(dx), Some(dy)) => dy.cross(dx).try_normalize(),
                _ => None,
            };
            let v = camera.view_direction(p);
            if let Some(mut n) = n {
                if n.dot(v) > 0.0 {
                    n = -n;
                }
                normals[idx] = oct_encode(n);
                rho[idx] = rho_to_byte(n.dot(v).abs());
            } else {
                normals[idx] = oct_encode(-v);
            }
        }
    }
    (normals, rho)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn oct_round_trip_is_within_two_degrees(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
            let n = DVec3::new(x, y, z);
            prop_assume!(n.length() > 1e-3);
            let n = n.normalize();
            let back = oct_decode(oct_encode(n));
            prop_assert!(back.dot(n) > 2f64.to_radians().cos(), "{n} -> {back}");
        }
    }

    #[test]
    fn a_fronto_parallel_plane_has_full_quality_at_the_centre() {
        let cam = Camera::perspective(5, 5, 100.0, 100.0, 2.0, 2.0).unwrap();
        let grid = Grid::for_image(5, 5);
        let bp = BackProject::new(&cam, grid.gw(), grid.gh());
        let z = vec![2.0f32; grid.len()];
        let (n, rho) = normals_and_quality(&grid, &cam, &bp, &z);
        let centre = grid.index((2, 2));
        assert_eq!(rho[centre], 255);
        assert!(oct_decode(n[centre]).dot(DVec3::NEG_Z) > 0.999);
    }
}
