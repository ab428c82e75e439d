//! Builds the synthetic scene repeatedly, for profilers (`perf`, `valgrind
//! --tool=callgrind`). Usage: `profile_build [SIZE] [ITERATIONS]`.
fn main() {
    let mut args = std::env::args().skip(1);
    let size: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(1025);
    let iterations: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(10);
    let (d, c) = dmesh::synthetic::terrain_with_boxes(size, size);
    let t = std::time::Instant::now();
    for _ in 0..iterations {
        std::hint::black_box(dmesh::mesh::DepthMesh::build(&d, &c, &Default::default()).unwrap());
    }
    println!("{:?} per build", t.elapsed() / iterations.max(1));
}
