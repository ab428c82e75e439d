//! Builds the 1025² synthetic scene repeatedly (for profilers).
#[path = "../benches/scenes.rs"]
mod scenes;
fn main() {
    let (d, c) = scenes::synthetic(1025, 1025);
    let t = std::time::Instant::now();
    for _ in 0..10 {
        std::hint::black_box(dmesh::mesh::DepthMesh::build(&d, &c, &Default::default()).unwrap());
    }
    println!("{:?} per build", t.elapsed() / 10);
}
