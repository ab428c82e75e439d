//! Binary little-endian PLY output, as MeshLab and Blender read it.
//!
//! Vertices carry their position in the reference camera frame (`x, y, z`,
//! float), normal (`nx, ny, nz`, float), `quality` (float, rho in `[0, 1]`) and,
//! when a colour image is given, `red, green, blue` (uchar) sampled at the
//! vertex's pixel; faces are the indexed triangle list.

use crate::camera::Camera;
use crate::image::ColorImage;
use crate::mesh::normals::oct_decode;
use crate::mesh::Mesh;

/// Encodes `mesh`, built for `camera`, as a binary PLY file; `color` (same
/// size as the depth image) adds per-vertex colours.
pub fn encode_ply(mesh: &Mesh, camera: &Camera, color: Option<&ColorImage>) -> Vec<u8> {
    let color_props = if color.is_some() {
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    } else {
        ""
    };
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment dmesh depth-mesh, reference camera frame (x right, y down, z forward)\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty float quality\n{color_props}\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.vertices.len(),
        mesh.triangles.len()
    );
    let mut out = Vec::with_capacity(header.len() + mesh.vertices.len() * 28 + mesh.triangles.len() * 13);
    out.extend_from_slice(header.as_bytes());
    for v in &mesh.vertices {
        let p = camera.back_project(f64::from(v.i), f64::from(v.j), f64::from(v.depth));
        let n = oct_decode(v.normal);
        for f in [p.x, p.y, p.z, n.x, n.y, n.z, f64::from(v.rho) / 255.0] {
            out.extend_from_slice(&(f as f32).to_le_bytes());
        }
        if let Some(c) = color {
            let at = 3 * (usize::from(v.j) * c.width as usize + usize::from(v.i));
            out.extend_from_slice(c.rgb.get(at..at + 3).unwrap_or(&[0, 0, 0]));
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::DepthImage;
    use crate::mesh::{Hierarchy, Lod, Segmentation};

    #[test]
    fn header_counts_match_the_body() {
        let cam = Camera::perspective(4, 3, 4.0, 4.0, 1.5, 1.0).unwrap();
        let depth = DepthImage::from_z(4, 3, vec![1.0; 12]).unwrap();
        let mesh = Hierarchy::build(&depth, &cam, &Segmentation::default())
            .unwrap()
            .extract(Lod::Epsilon(0.0))
            .unwrap();
        let color = ColorImage {
            width: 4,
            height: 3,
            rgb: vec![7; 36],
        };
        let bytes = encode_ply(&mesh, &cam, Some(&color));
        let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let header = std::str::from_utf8(&bytes[..end]).unwrap();
        assert!(header.contains(&format!("element vertex {}", mesh.vertices.len())));
        assert!(header.contains(&format!("element face {}", mesh.triangles.len())));
        assert_eq!(
            bytes.len() - end,
            mesh.vertices.len() * (7 * 4 + 3) + mesh.triangles.len() * 13
        );
    }
}
