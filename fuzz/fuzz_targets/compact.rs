//! Protocol 7, the compact mesh stream, as a client decodes it: a strip
//! route's body (a mesh, a change from a held one, or planes for a held
//! one) and a render body, then the mesh itself: an error, or vertices
//! inside the reference image, triangles indexing them, finite positive
//! depths, and cut triangles whose parts are finite with positive depths,
//! at most three each. A change is applied to nothing held, and to the mesh
//! its own bits decode to without a held one.
#![no_main]

use dmesh_proto::compact::{CompactError, DecodedMesh, MeshBody, MeshStream, RenderStream};
use dmesh_proto::from_bincode;
use libfuzzer_sys::fuzz_target;

fn decodes_soundly(s: &MeshStream) {
    sound(s, s.decode());
}

fn sound(s: &MeshStream, m: Result<DecodedMesh, CompactError>) {
    if let Ok(m) = m {
        assert_eq!(m.shape.triangles.len(), s.triangles as usize);
        assert_eq!(m.depths.len(), m.shape.vertices.len());
        assert!(m.depths.iter().all(|&z| z.is_finite() && z > 0.0));
        let n = m.shape.vertices.len() as u32;
        assert!(m.shape.triangles.iter().flatten().all(|&v| v < n));
        assert!(m.shape.vertices.iter().all(|&(i, j)| i < s.camera.width && j < s.camera.height));
        assert_eq!(m.cuts.len(), s.cut_triangles as usize);
        for c in &m.cuts {
            assert!(c.drawn() <= 3);
            assert!(c.parts().flatten().all(|p| p.iter().all(|v| v.is_finite()) && p[2] > 0.0));
        }
    }
}

fuzz_target!(|data: &[u8]| {
    match from_bincode::<MeshBody>(data) {
        Ok(MeshBody::Mesh(s)) => decodes_soundly(&s),
        Ok(MeshBody::Change(c)) => {
            let nothing = DecodedMesh {
                shape: Default::default(),
                depths: Vec::new(),
                cuts: Vec::new(),
                max_error: 0.0,
                planes: 0,
                lattice: c.mesh.lattice,
                complete: true,
            };
            sound(&c.mesh, c.apply(&nothing));
            if let Ok(held) = c.mesh.decode() {
                sound(&c.mesh, c.apply(&held));
            }
        }
        _ => {}
    }
    if let Ok(r) = from_bincode::<RenderStream>(data) {
        r.views.iter().for_each(|v| decodes_soundly(&v.mesh));
    }
});
