//! How far strips of the demo meshes are from a lower bound.
//!
//! Every index of a strip (a repeated one for a swap included) is a corner of
//! at most three consecutive triangles, so a vertex with `k` incident
//! triangles is written at least `ceil(k / 3)` times: the sum over vertices,
//! divided by the triangles, bounds the indices per triangle from below
//! whatever the stripifier (restarts not counted). Usage:
//! `cargo run --release --example strip_bound`.
use dmesh::mesh::{DepthMesh, Lod, StripOrder};

fn main() {
    let (d, c) = dmesh::synthetic::terrain_with_boxes(513, 513);
    let h = DepthMesh::build(&d, &c, &Default::default()).expect("the demo scene builds");
    let view = dmesh::camera::Camera::new(
        513,
        513,
        c.projection,
        glam::DQuat::from_rotation_y(-0.1),
        glam::DVec3::new(0.5, 0.0, 0.0),
    )
    .expect("a valid camera");
    println!("{:<8} {:>9} {:>8} {:>10} {:>8}   vertices by incident triangles 1..8", "mesh", "triangles", "bound", "traversal", "greedy");
    for (name, lod) in [
        ("eps 1cm", Lod::Epsilon(0.01)),
        ("tau 1", Lod::Tau { tau: 1.0, view: &view }),
        ("full", Lod::Epsilon(0.0)),
    ] {
        let traversal = h.extract_with(lod, StripOrder::Traversal).expect("extracts");
        let greedy = h.extract_with(lod, StripOrder::Greedy).expect("extracts");
        let mut incident = vec![0u32; greedy.vertices.len()];
        for t in &greedy.triangles {
            for &v in t {
                incident[v as usize] += 1;
            }
        }
        let writes: u64 = incident.iter().map(|&k| u64::from(k.div_ceil(3))).sum();
        let mut by_count = [0usize; 8];
        for &k in &incident {
            by_count[(k as usize).clamp(1, 8) - 1] += 1;
        }
        let t = greedy.triangles.len() as f64;
        println!(
            "{name:<8} {:>9} {:>8.3} {:>10.3} {:>8.3}   {by_count:?}",
            greedy.triangles.len(),
            writes as f64 / t,
            traversal.strips.len() as f64 / t,
            greedy.strips.len() as f64 / t,
        );
    }
}
