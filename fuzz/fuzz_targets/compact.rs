//! Protocol 6, the compact mesh stream, as a client decodes it: a strip
//! route's body (a mesh, or planes for a held one) and a render body, then
//! the mesh itself: an error, or vertices inside the reference image,
//! triangles indexing them, and finite positive depths.
#![no_main]

use dmesh_proto::compact::{MeshBody, MeshStream, RenderStream};
use dmesh_proto::from_bincode;
use libfuzzer_sys::fuzz_target;

fn decodes_soundly(s: &MeshStream) {
    if let Ok(m) = s.decode() {
        assert_eq!(m.shape.triangles.len(), s.triangles as usize);
        assert_eq!(m.depths.len(), m.shape.vertices.len());
        assert!(m.depths.iter().all(|&z| z.is_finite() && z > 0.0));
        let n = m.shape.vertices.len() as u32;
        assert!(m.shape.triangles.iter().flatten().all(|&v| v < n));
        assert!(m.shape.vertices.iter().all(|&(i, j)| i < s.camera.width && j < s.camera.height));
    }
}

fuzz_target!(|data: &[u8]| {
    if let Ok(MeshBody::Mesh(s)) = from_bincode::<MeshBody>(data) {
        decodes_soundly(&s);
    }
    if let Ok(r) = from_bincode::<RenderStream>(data) {
        r.views.iter().for_each(|v| decodes_soundly(&v.mesh));
    }
});
