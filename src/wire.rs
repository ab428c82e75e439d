//! From engine values to wire values (`dmesh-proto`): an extracted mesh as a
//! strip response, 16-bit indices when the vertex count allows.

use dmesh_proto::{Indices, Lod as WireLod, StripResponse, WireVertex, PROTOCOL_VERSION};

use crate::camera::Camera;
use crate::mesh::{Lod, Mesh, MeshVertex};

impl From<&MeshVertex> for WireVertex {
    fn from(v: &MeshVertex) -> Self {
        Self {
            i: v.i,
            j: v.j,
            depth: v.depth,
            normal: v.normal,
            rho: v.rho,
        }
    }
}

impl From<&WireVertex> for MeshVertex {
    fn from(v: &WireVertex) -> Self {
        Self {
            i: v.i,
            j: v.j,
            depth: v.depth,
            normal: v.normal,
            rho: v.rho,
        }
    }
}

/// The wire form of `lod` (the requesting camera travels separately).
pub fn wire_lod(lod: &Lod<'_>) -> WireLod {
    match *lod {
        Lod::Epsilon(e) => WireLod::Epsilon(e),
        Lod::Tau { tau, .. } => WireLod::Tau(tau),
    }
}

/// `mesh`, extracted from the view `scene/view` seen by `camera` at `lod`, as a strip response.
pub fn strip_response(mesh: &Mesh, scene: &str, view: &str, lod: WireLod, camera: &Camera) -> StripResponse {
    let vertices = mesh.vertices.iter().map(WireVertex::from).collect();
    let indices = match mesh.strips_u16() {
        Some(short) => Indices::U16(short),
        None => Indices::U32(mesh.strips.clone()),
    };
    StripResponse {
        version: PROTOCOL_VERSION,
        scene: scene.to_string(),
        view: view.to_string(),
        lod,
        camera: camera.into(),
        vertices,
        indices,
        triangles: u32::try_from(mesh.triangles.len()).unwrap_or(u32::MAX),
        extract_ms: mesh.extract_ms,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::DepthImage;
    use crate::mesh::{decode_strips, DepthMesh, Segmentation};

    #[test]
    fn the_wire_strips_draw_the_mesh_triangles() {
        let cam = Camera::perspective(33, 17, 30.0, 30.0, 16.0, 8.0).unwrap();
        let z = (0..33 * 17)
            .map(|i| 2.0 + ((i % 33) as f32 * 0.3).sin() * 0.2)
            .collect();
        let depth = DepthImage::from_z(33, 17, z).unwrap();
        let mesh = DepthMesh::build(&depth, &cam, &Segmentation::default())
            .unwrap()
            .extract(Lod::Epsilon(0.001))
            .unwrap();
        let wire = strip_response(&mesh, "s", "v", WireLod::Epsilon(0.001), &cam);
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
        assert_eq!(back.vertices.len(), mesh.vertices.len());
        assert_eq!(back.triangles as usize, mesh.triangles.len());
    }
}
