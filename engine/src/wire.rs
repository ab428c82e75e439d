//! From engine values to wire values (`dmesh-proto`): an extracted mesh as a
//! strip response, 16-bit indices when the vertex count allows.

use dmesh_proto::{
    Depths, Indices, RawGrid, Reach as WireReach, ResidualDepths, ResidualError, StripResponse, WireVertex,
    PROTOCOL_VERSION,
};

use crate::camera::Camera;
use crate::mesh::{Mesh, MeshVertex, Reach, MAX_CULLED};

impl From<&MeshVertex> for WireVertex {
    fn from(v: &MeshVertex) -> Self {
        Self {
            i: v.i,
            j: v.j,
            normal: v.normal,
            rho: v.rho,
        }
    }
}

/// The engine vertices of a strip response, depths decoded.
pub fn mesh_vertices(r: &StripResponse) -> Result<Vec<MeshVertex>, ResidualError> {
    let depths = r.decode_depths()?;
    Ok(r.vertices
        .iter()
        .zip(depths)
        .map(|(v, depth)| MeshVertex {
            i: v.i,
            j: v.j,
            depth,
            normal: v.normal,
            rho: v.rho,
        })
        .collect())
}

/// The engine form of a response's [`WireReach`], refusing a camera, a
/// clearance or a sphere a server could not have sent (not finite, negative).
pub fn engine_reach(r: &WireReach) -> crate::error::Result<Reach> {
    let bad = |what: &str| crate::error::Error::invalid(format!("reach: {what}"));
    if r.clearance.is_some_and(|c| !(c.is_finite() && c > 0.0)) {
        return Err(bad("the clearance must be a positive number of metres"));
    }
    if r.culled.len() > MAX_CULLED
        || r.culled.iter().flatten().any(|v| !v.is_finite())
        || r.culled.iter().any(|s| s[3] < 0.0)
    {
        return Err(bad(&format!(
            "culled spheres must be at most {MAX_CULLED}, finite, with radius >= 0"
        )));
    }
    Ok(Reach {
        view: Camera::try_from(&r.view)?,
        clearance: r.clearance,
        culled: r.culled.iter().map(|s| s.map(f64::from)).collect(),
    })
}

/// How a response carries its depths.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DepthCoding {
    /// Residual bit-depth (`0..=16`), `None` for exact `f32` depths.
    pub bits: Option<u8>,
    /// Root quad side of the view's grid (see [`crate::mesh::Grid::side`]).
    pub root_side: u32,
    /// The integer grid the stored depths came from, if any.
    pub raw_grid: Option<RawGrid>,
}

/// `mesh`, extracted from the view `scene/view` seen by `camera` at `mesh.lod`, as
/// a strip response with depths coded by `coding`.
pub fn strip_response(
    mesh: &Mesh,
    scene: &str,
    view: &str,
    camera: &Camera,
    coding: DepthCoding,
) -> Result<StripResponse, ResidualError> {
    let vertices = mesh.vertices.iter().map(WireVertex::from).collect();
    let z: Vec<f32> = mesh.vertices.iter().map(|v| v.depth).collect();
    let depths = match coding.bits {
        None => Depths::Exact(z),
        Some(bits) => {
            let ij: Vec<(u16, u16)> = mesh.vertices.iter().map(|v| (v.i, v.j)).collect();
            Depths::Residual(ResidualDepths::encode(
                &ij,
                &z,
                bits,
                coding.root_side,
                coding.raw_grid,
            )?)
        }
    };
    let indices = match mesh.strips_u16() {
        Some(short) => Indices::U16(short),
        None => Indices::U32(mesh.strips.clone()),
    };
    Ok(StripResponse {
        version: PROTOCOL_VERSION,
        scene: scene.to_string(),
        view: view.to_string(),
        lod: mesh.lod,
        camera: camera.into(),
        vertices,
        depths,
        indices,
        triangles: u32::try_from(mesh.triangles.len()).unwrap_or(u32::MAX),
        extract_ms: mesh.extract_ms,
        reach: mesh.reach.as_ref().map(|r| WireReach {
            view: (&r.view).into(),
            clearance: r.clearance,
            culled: r
                .culled
                .iter()
                .map(|&[x, y, z, radius]| {
                    // Rounding moves a centre by at most half an ulp per axis;
                    // the radius grows by their sum (and its own rounding, up).
                    let c = [x as f32, y as f32, z as f32];
                    let slack: f64 = [x, y, z].iter().zip(c).map(|(&v, f)| (v - f64::from(f)).abs()).sum();
                    let r = (radius + slack) as f32;
                    let r = if f64::from(r) < radius + slack { r.next_up() } else { r };
                    [c[0], c[1], c[2], r]
                })
                .collect(),
        }),
        cuts: mesh.cuts.clone(),
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::image::DepthImage;
    use crate::mesh::{decode_strips, Hierarchy, Lod, Segmentation};

    #[test]
    fn the_wire_strips_draw_the_mesh_triangles() {
        let cam = Camera::perspective(33, 17, 30.0, 30.0, 16.0, 8.0).unwrap();
        let z = (0..33 * 17)
            .map(|i| 2.0 + ((i % 33) as f32 * 0.3).sin() * 0.2)
            .collect();
        let depth = DepthImage::from_z(33, 17, z).unwrap();
        let mesh = Hierarchy::build(&depth, &cam, &Segmentation::default())
            .unwrap()
            .extract(Lod::Epsilon(0.001))
            .unwrap();
        let wire = strip_response(&mesh, "s", "v", &cam, DepthCoding::default()).unwrap();
        let bytes = dmesh_proto::to_bincode(&wire).unwrap();
        let back: StripResponse = dmesh_proto::from_bincode(&bytes).unwrap();
        assert!(matches!(back.indices, Indices::U16(_)), "expected 16-bit indices");
        let widened = back.indices.to_u32();
        let canon = |mut t: [u32; 3]| {
            t.sort_unstable();
            t
        };
        let mut drawn: Vec<_> = decode_strips(&widened).into_iter().map(canon).collect();
        let mut want: Vec<_> = mesh.triangles.iter().copied().map(canon).collect();
        drawn.sort_unstable();
        want.sort_unstable();
        assert_eq!(drawn, want);
        assert_eq!(mesh_vertices(&back).unwrap(), mesh.vertices);
        assert_eq!(back.triangles as usize, mesh.triangles.len());
    }

    /// A 65 x 40 view of a wavy surface with a step, so that segmentation
    /// drops triangles and the depth coders meet vertices without parents.
    pub(crate) fn stepped() -> (Camera, DepthImage) {
        let cam = Camera::perspective(65, 40, 60.0, 60.0, 32.0, 20.0).unwrap();
        let z: Vec<f32> = (0..65 * 40)
            .map(|k| {
                let (x, y) = ((k % 65) as f32, (k / 65) as f32);
                if x > 40.0 {
                    6.0
                } else {
                    2.0 + 0.01 * x + (y * 0.2).sin() * 0.1
                }
            })
            .collect();
        (cam, DepthImage::from_z(65, 40, z).unwrap())
    }

    #[test]
    fn residual_depths_of_a_real_mesh_decode_within_their_bound() {
        let (cam, depth) = stepped();
        let h = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
        let mesh = h.extract(Lod::Epsilon(0.0005)).unwrap();
        for bits in [0, 1, 4, 8, 12, 16] {
            let coding = DepthCoding {
                bits: Some(bits),
                root_side: h.grid().side(),
                raw_grid: None,
            };
            let wire = strip_response(&mesh, "s", "v", &cam, coding).unwrap();
            let Depths::Residual(r) = &wire.depths else {
                panic!("expected residual depths")
            };
            let back = mesh_vertices(&wire).unwrap();
            for (a, b) in back.iter().zip(&mesh.vertices) {
                assert!((a.depth - b.depth).abs() <= r.max_error, "bits {bits}");
                assert!(a.depth.is_finite() && a.depth > 0.0, "bits {bits}: {}", a.depth);
            }
            if bits > 0 {
                assert!(f64::from(r.max_error) <= r.step() / 2.0 + 1e-6, "bits {bits}");
            }
        }
    }
}
