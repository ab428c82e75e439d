//! Binary little-endian PLY output, as MeshLab and Blender read it.
//!
//! Vertices carry their position in the reference camera frame (`x, y, z`,
//! float), normal (`nx, ny, nz`, float) and `quality` (float, rho in `[0, 1]`);
//! faces are the indexed triangle list.

use crate::camera::Camera;
use crate::mesh::normals::oct_decode;
use crate::mesh::Mesh;

/// Encodes `mesh`, built for `camera`, as a binary PLY file.
pub fn encode_ply(mesh: &Mesh, camera: &Camera) -> Vec<u8> {
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment dmesh depth-mesh, reference camera frame (x right, y down, z forward)\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty float quality\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.vertices.len(),
        mesh.triangles.len()
    );
    let mut out =
        Vec::with_capacity(header.len() + mesh.vertices.len() * 28 + mesh.triangles.len() * 13);
    out.extend_from_slice(header.as_bytes());
    for v in &mesh.vertices {
        let p = camera.back_project(f64::from(v.i), f64::from(v.j), f64::from(v.depth));
        let n = oct_decode(v.normal);
        for f in [p.x, p.y, p.z, n.x, n.y, n.z, f64::from(v.rho) / 255.0] {
            out.extend_from_slice(&(f as f32).to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        out.push(3);
        for &i in t {
            out.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    out
}
