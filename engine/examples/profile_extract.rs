//! Extracts the synthetic scene at tau = 1 px repeatedly and prints the
//! first (which computes the outline the extraction keeps, once per
//! hierarchy), minimum and median time, for profiling. Usage:
//! `profile_extract [SIZE] [ITERATIONS] [traversal|greedy|tunnelled] [kept|dropped]`.
fn main() {
    let mut args = std::env::args().skip(1);
    let size: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(513);
    let iterations: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(100);
    let order = args.next().map_or(Default::default(), |given| {
        let names = dmesh_engine::mesh::StripOrder::NAMES;
        names
            .iter()
            .find(|(name, _)| *name == given)
            .map_or(Default::default(), |&(_, order)| order)
    });
    let outlines = match args.next().as_deref() {
        Some("dropped") => dmesh_engine::mesh::Outlines::Dropped,
        _ => dmesh_engine::mesh::Outlines::Kept,
    };
    let (d, c) = dmesh_engine::synthetic::terrain_with_boxes(size, size);
    let h = dmesh_engine::mesh::Hierarchy::build(&d, &c, &Default::default()).unwrap();
    let view = dmesh_engine::camera::Camera::new(
        size,
        size,
        c.projection,
        glam::DQuat::from_rotation_y(-0.1),
        glam::DVec3::new(0.5, 0.0, 0.0),
    )
    .unwrap();
    let mut times = Vec::new();
    let mut tris = 0;
    for _ in 0..iterations.max(1) {
        let t = std::time::Instant::now();
        tris = std::hint::black_box(
            h.extract_as(dmesh_engine::mesh::Lod::Tau { tau: 1.0, view: &view }, order, outlines)
                .unwrap(),
        )
        .triangles
        .len();
        times.push(t.elapsed());
    }
    let first = times[0];
    times.sort();
    println!(
        "first {first:?} min {:?} median {:?}, {tris} triangles",
        times[0],
        times[times.len() / 2]
    );
}
