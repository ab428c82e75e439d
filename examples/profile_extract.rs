//! Extracts the synthetic scene at tau = 1 px repeatedly, for profilers.
//! Usage: `profile_extract [SIZE] [ITERATIONS]`.
fn main() {
    let mut args = std::env::args().skip(1);
    let size: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(513);
    let iterations: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(100);
    let (d, c) = dmesh::synthetic::terrain_with_boxes(size, size);
    let h = dmesh::mesh::DepthMesh::build(&d, &c, &Default::default()).unwrap();
    let view = dmesh::camera::Camera::new(
        size,
        size,
        c.projection,
        glam::DQuat::from_rotation_y(-0.1),
        glam::DVec3::new(0.5, 0.0, 0.0),
    )
    .unwrap();
    let t = std::time::Instant::now();
    let mut tris = 0;
    for _ in 0..iterations {
        tris = std::hint::black_box(
            h.extract(dmesh::mesh::Lod::Tau {
                tau: 1.0,
                view: &view,
            })
            .unwrap(),
        )
        .triangles
        .len();
    }
    println!(
        "{:?} per extraction, {tris} triangles",
        t.elapsed() / iterations.max(1)
    );
}
