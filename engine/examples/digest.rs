//! Prints a digest of the per-vertex data and extracted meshes of several
//! builds (sizes, segmentations, invalid samples), to check that a change
//! meant to be only faster leaves every result bit for bit the same: run it
//! before and after and compare. Usage: `cargo run --release -p dmesh-engine --example digest`.
use dmesh_engine::mesh::{Hierarchy, Lod, Method, Segmentation};
use std::hash::{Hash, Hasher};
fn digest(name: &str, d: &dmesh_engine::image::DepthImage, c: &dmesh_engine::camera::Camera, seg: &Segmentation) {
    let m = Hierarchy::build(d, c, seg).expect("the scene builds");
    let g = *m.grid();
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for y in 0..g.gh() {
        for x in 0..g.gw() {
            m.error((x, y)).to_bits().hash(&mut h);
            m.radius((x, y)).to_bits().hash(&mut h);
            m.cell_segmented((x, y), 0).hash(&mut h);
            m.cell_segmented((x, y), 1).hash(&mut h);
        }
    }
    let a = h.finish();
    let mut h2 = std::collections::hash_map::DefaultHasher::new();
    for lod in [
        Lod::Epsilon(0.0),
        Lod::Epsilon(0.001),
        Lod::Epsilon(0.01),
        Lod::Epsilon(0.1),
    ] {
        let e = m.extract(lod).expect("extracts");
        e.triangles.hash(&mut h2);
        e.strips.hash(&mut h2);
        for v in &e.vertices {
            (v.i, v.j, v.depth.to_bits(), v.normal, v.rho).hash(&mut h2);
        }
    }
    println!("{name}: {a:016x} {:016x}", h2.finish());
}
fn main() {
    for (w, hh) in [(513, 513), (3, 7), (640, 480), (100, 37)] {
        let (mut d, c) = dmesh_engine::synthetic::terrain_with_boxes(w, hh);
        for seg in [
            Segmentation::default(),
            Segmentation {
                method: Method::None,
                ..Default::default()
            },
            Segmentation {
                method: Method::Connectedness { kappa: 0.5 },
                ..Default::default()
            },
        ] {
            digest(&format!("{w}x{hh} {:?}", seg.method), &d, &c, &seg);
        }
        // Holes and noise.
        let mut s = 12345u64;
        for z in d.z.iter_mut() {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let r = (s >> 33) as f32 / (1u64 << 31) as f32;
            if r < 0.03 {
                *z = 0.0
            } else {
                *z += 0.01 * r;
            }
        }
        digest(&format!("{w}x{hh} holes"), &d, &c, &Segmentation::default());
    }
    let (d, c) = dmesh_engine::synthetic::height_field(257);
    digest("height field", &d, &c, &Segmentation::default());
}
