//! Builds the synthetic scene repeatedly and prints the minimum and median
//! time, for profiling. Usage: `profile_build [SIZE] [ITERATIONS] [THREADS]`
//! (threads 1 or 2, default as `DepthMesh::build`).
fn main() {
    let mut args = std::env::args().skip(1);
    let size: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(513);
    let iterations: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(20);
    let threads = match args.next().as_deref() {
        Some("1") => dmesh::mesh::Threads::Single,
        Some("2") => dmesh::mesh::Threads::Parallel,
        _ => dmesh::mesh::Threads::available(),
    };
    let (d, c) = dmesh::synthetic::terrain_with_boxes(size, size);
    let mut times = Vec::new();
    for _ in 0..iterations.max(1) {
        let t = std::time::Instant::now();
        std::hint::black_box(dmesh::mesh::DepthMesh::build_with(&d, &c, &Default::default(), threads).unwrap());
        times.push(t.elapsed());
    }
    times.sort();
    println!("min {:?} median {:?}", times[0], times[times.len() / 2]);
}
