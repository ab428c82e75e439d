//! Normals and the sampling quality rho derived from a decoded mesh (DMesh
//! Sec. 4.2, computed where the compact stream lands instead of sent):
//! each vertex's normal is the area-weighted sum of the normals of the
//! triangles around it, back-projected through the reference camera, turned
//! to face it; `rho = |n . v|` as the hierarchy's own (see [`super::normals`]).
//!
//! The browser (`clients/web/src/compact.js`) computes the same numbers
//! with the same operations in the same order, so both clients draw the
//! same bytes; `docs/stream.md` measures what it costs the blend against
//! the server's normals.

use super::normals::{oct_encode, rho_to_byte};
use crate::camera::{Camera, Projection};

/// Encoded normals and rho bytes of the vertices `ij` at `depths`, from the
/// triangles (corners ordered to face the camera, as extraction emits them).
pub fn derive(camera: &Camera, ij: &[(u16, u16)], depths: &[f32], triangles: &[[u32; 3]]) -> (Vec<[u8; 2]>, Vec<u8>) {
    let ortho = matches!(camera.projection, Projection::Orthographic { .. });
    let points: Vec<[f64; 3]> = ij
        .iter()
        .zip(depths)
        .map(|(&(i, j), &z)| {
            let (ax, bx) = camera.column_factors(f64::from(i));
            let (ay, by) = camera.row_factors(f64::from(j));
            let z = f64::from(z);
            [ax + bx * z, ay + by * z, z]
        })
        .collect();
    let mut sum = vec![[0f64; 3]; points.len()];
    for t in triangles {
        let [p0, p1, p2] = t.map(|k| points.get(k as usize).copied().unwrap_or([0.0; 3]));
        let (e1, e2) = (sub(p1, p0), sub(p2, p0));
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        for &k in t {
            if let Some(s) = sum.get_mut(k as usize) {
                *s = [s[0] + n[0], s[1] + n[1], s[2] + n[2]];
            }
        }
    }
    sum.iter()
        .zip(&points)
        .map(|(&n, &p)| {
            let v = if ortho { [0.0, 0.0, 1.0] } else { p };
            let nv = dot(n, v);
            let nn = dot(n, n) * dot(v, v);
            if !(nn > 0.0 && nn < f64::INFINITY) {
                return (oct_encode(glam::DVec3::new(-v[0], -v[1], -v[2])), 0);
            }
            let flip = if nv > 0.0 { -1.0 } else { 1.0 };
            let normal = oct_encode(glam::DVec3::new(n[0] * flip, n[1] * flip, n[2] * flip));
            (normal, rho_to_byte(nv.abs() / nn.sqrt()))
        })
        .unzip()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::normals::oct_decode;

    #[test]
    fn a_plane_facing_the_camera_has_its_normal_and_full_quality() {
        let cam = Camera::orthographic(3, 3, 0.1, 0.1, 1.0, 1.0).unwrap();
        let ij = [(0, 0), (2, 0), (0, 2), (2, 2)];
        let (n, rho) = derive(&cam, &ij, &[2.0; 4], &[[0, 1, 2], [1, 3, 2]]);
        for (e, r) in n.iter().zip(&rho) {
            assert!(oct_decode(*e).dot(glam::DVec3::NEG_Z) > 0.999, "{e:?}");
            assert_eq!(*r, 255);
        }
        // A vertex of no triangle faces the camera with no quality.
        let (n, rho) = derive(&cam, &[(1, 1)], &[2.0], &[]);
        assert!(
            oct_decode(n[0]).dot(glam::DVec3::NEG_Z) > 0.999 && rho[0] == 0,
            "{n:?} {rho:?}"
        );
    }

    #[test]
    fn a_tilted_plane_loses_quality_by_its_angle() {
        let cam = Camera::orthographic(3, 3, 1.0, 1.0, 1.0, 1.0).unwrap();
        let ij = [(0, 0), (2, 0), (0, 2), (2, 2)];
        // z rises by one metre per metre along x: 45 degrees.
        let z = [2.0, 4.0, 2.0, 4.0];
        let (_, rho) = derive(&cam, &ij, &z, &[[0, 1, 2], [1, 3, 2]]);
        for r in rho {
            assert!((f64::from(r) / 255.0 - 0.5f64.sqrt()).abs() < 0.01, "{r}");
        }
    }
}
