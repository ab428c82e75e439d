//! Binary little-endian PLY output, as MeshLab and Blender read it.
//!
//! Vertices carry their position in the reference camera frame (`x, y, z`,
//! float), normal (`nx, ny, nz`, float), `quality` (float, rho in `[0, 1]`) and,
//! when a colour image is given, `red, green, blue` (uchar) sampled at the
//! vertex's pixel; faces are the indexed triangle list. A cut triangle's
//! parts (`mesh/cut.rs`) follow, each with corners of its own (a
//! crossing's two sides differ in depth), the part's face normal and the
//! colour of the nearest pixel.

use glam::DVec3;

use crate::camera::Camera;
use crate::image::ColorImage;
use crate::mesh::normals::oct_decode;
use crate::mesh::Mesh;

/// A cut triangle's part as written: its corners' positions in the camera
/// frame, its face's normal and its corners' pixels `(u, v)`.
type Part = ([DVec3; 3], DVec3, [(f64, f64); 3]);

/// Encodes `mesh`, built for `camera`, as a binary PLY file; `color` (same
/// size as the depth image) adds per-vertex colours.
pub fn encode_ply(mesh: &Mesh, camera: &Camera, color: Option<&ColorImage>) -> Vec<u8> {
    // The cut parts: their corners' positions, the face's normal, and the
    // corners' pixels.
    let mut parts: Vec<Part> = Vec::new();
    for t in mesh.cuts.iter().flat_map(|c| c.parts()) {
        let p = t.map(|[u, v, z]| camera.back_project(u, v, z));
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        // Facing the reference camera, as the vertices' normals do.
        let n = match n {
            DVec3::ZERO => -p[0].normalize_or_zero(),
            n if n.dot(p[0]) > 0.0 => -n,
            n => n,
        };
        parts.push((p, n, t.map(|[u, v, _]| (u, v))));
    }
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
        mesh.vertices.len() + 3 * parts.len(),
        mesh.triangles.len() + parts.len()
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
    for (p, n, uv) in &parts {
        for (p, (u, v)) in p.iter().zip(uv) {
            let rho = n.dot(p.normalize_or_zero()).abs();
            for f in [p.x, p.y, p.z, n.x, n.y, n.z, rho] {
                out.extend_from_slice(&(f as f32).to_le_bytes());
            }
            if let Some(c) = color {
                let (i, j) = (
                    (u.round().max(0.0) as usize).min(c.width as usize - 1),
                    (v.round().max(0.0) as usize).min(c.height as usize - 1),
                );
                let at = 3 * (j * c.width as usize + i);
                out.extend_from_slice(c.rgb.get(at..at + 3).unwrap_or(&[0, 0, 0]));
            }
        }
    }
    let first_part = mesh.vertices.len();
    let faces = mesh
        .triangles
        .iter()
        .copied()
        .chain((0..parts.len()).map(|k| [0, 1, 2].map(|c| (first_part + 3 * k + c) as u32)));
    for t in faces {
        out.push(3);
        for i in t {
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

    /// A cut mesh's parts are written too, each with three corners of its
    /// own: a step's near and far sides, and an image of a size that pads.
    #[test]
    fn cut_parts_are_written() {
        let (w, h) = (10, 7);
        let z = (0..w * h).map(|i| if i % w < 4 { 1.0 } else { 2.0 }).collect();
        let cam = Camera::perspective(w, h, 10.0, 10.0, 4.5, 3.0).unwrap();
        let depth = DepthImage::from_z(w, h, z).unwrap();
        let mesh = Hierarchy::build(&depth, &cam, &Segmentation::default())
            .unwrap()
            .extract_as(
                Lod::Epsilon(0.01),
                crate::mesh::StripOrder::Traversal,
                crate::mesh::Outlines::Cut,
            )
            .unwrap();
        let drawn = mesh.drawn_triangles() - mesh.triangles.len();
        assert!(drawn > 0, "nothing cut");
        let bytes = encode_ply(&mesh, &cam, None);
        let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let header = std::str::from_utf8(&bytes[..end]).unwrap();
        let (vertices, faces) = (mesh.vertices.len() + 3 * drawn, mesh.drawn_triangles());
        assert!(header.contains(&format!("element vertex {vertices}")), "{header}");
        assert!(header.contains(&format!("element face {faces}")), "{header}");
        assert_eq!(bytes.len() - end, vertices * 7 * 4 + faces * 13);
        // Every float is finite, and every face's indices are in range.
        for k in 0..vertices * 7 {
            let f = f32::from_le_bytes(bytes[end + 4 * k..end + 4 * k + 4].try_into().unwrap());
            assert!(f.is_finite(), "float {k} is {f}");
        }
        let faces_at = end + vertices * 28;
        for k in 0..faces {
            let at = faces_at + 13 * k + 1;
            for c in 0..3 {
                let i = i32::from_le_bytes(bytes[at + 4 * c..at + 4 * c + 4].try_into().unwrap());
                assert!((0..vertices as i32).contains(&i), "face {k} index {i}");
            }
        }
    }
}
