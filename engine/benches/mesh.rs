//! Build and extraction benchmarks (criterion), plus a table of mesh sizes.
//!
//! `cargo bench -p dmesh-engine --bench mesh` measures:
//! - `build/<scene>`: the hierarchy build from a depth image on one thread;
//! - `build2t/<scene>`: the same with the normals on a second thread (what
//!   `Hierarchy::build` does on a machine with two cores);
//! - `static/<scene>`: extraction at a static epsilon (0.5 % of the median depth);
//! - `tau1/<scene>`: view-dependent extraction at tau = 1 px from a camera
//!   10 % of the depth to the side of the reference and turned towards it;
//! - `tau1-tunnelled/synthetic-513x513`: the same with tunnelled strips.
//!
//! Before timing it prints, per scene, the triangles, vertices, indices per
//! triangle of each strip order, the traversal's strips and the median
//! extraction time with tunnelled strips over three runs.

#![allow(missing_docs)] // criterion_group! generates undocumented items

mod scenes;

/// The server's allocator (see the root `Cargo.toml`), so the figures are
/// the binary's.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Lod, Mesh, Segmentation, StripOrder, Threads};

fn all_scenes() -> Vec<(String, DepthImage, Camera)> {
    let mut out: Vec<(String, DepthImage, Camera)> = Vec::new();
    for (w, h) in [(513, 513), (1025, 1025), (1920, 1080)] {
        let (d, c) = scenes::synthetic(w, h);
        out.push((format!("synthetic-{w}x{h}"), d, c));
    }
    for name in ["cones", "teddy", "art", "books"] {
        if let Some((d, c)) = scenes::middlebury(name) {
            out.push((name.to_string(), d, c));
        }
    }
    out
}

fn median_depth(d: &DepthImage) -> f64 {
    let mut v: Vec<f32> = d.z.iter().copied().filter(|&z| z > 0.0).collect();
    v.sort_unstable_by(f32::total_cmp);
    f64::from(v.get(v.len() / 2).copied().unwrap_or(1.0))
}

fn side_view(c: &Camera, depth: f64) -> Camera {
    let shift = 0.1 * depth;
    let angle = -(0.1f64).atan();
    Camera::new(
        c.width,
        c.height,
        c.projection,
        glam::DQuat::from_rotation_y(angle),
        glam::DVec3::new(shift, 0.0, 0.0),
    )
    .unwrap()
}

fn row(name: &str, what: &str, h: &Hierarchy, lod: Lod<'_>) {
    let m = h.extract(lod).unwrap();
    let g = h.extract_with(lod, StripOrder::Greedy).unwrap();
    let mut runs: Vec<Mesh> = (0..3)
        .map(|_| h.extract_with(lod, StripOrder::Tunnelled).unwrap())
        .collect();
    runs.sort_by(|a, b| a.extract_ms.total_cmp(&b.extract_ms));
    let t = &runs[1];
    let tris = m.triangles.len();
    let ipt = |m: &Mesh| m.strips.len() as f64 / tris.max(1) as f64;
    println!(
        "{name:<22} {what:<14} {tris:>10} {:>10} {:>9.3} {:>9.3} {:>9.3} {:>8} {:>9.1}",
        m.vertices.len(),
        ipt(&m),
        ipt(&g),
        ipt(t),
        m.strip_count(),
        t.extract_ms
    );
}

fn bench(c: &mut Criterion) {
    let scenes = all_scenes();
    println!(
        "{:<22} {:<14} {:>10} {:>10} {:>9} {:>9} {:>9} {:>8} {:>9}",
        "scene", "extraction", "triangles", "vertices", "idx/tri", "greedy", "tunnelled", "strips", "tun. ms"
    );
    for (name, depth, cam) in &scenes {
        let h = Hierarchy::build(depth, cam, &Segmentation::default()).unwrap();
        let eps = 0.005 * median_depth(depth);
        let view = side_view(cam, median_depth(depth));
        row(name, &format!("eps={eps:.4}"), &h, Lod::Epsilon(eps));
        row(name, "tau=1", &h, Lod::Tau { tau: 1.0, view: &view });
        row(name, "tau=0 (full)", &h, Lod::Tau { tau: 0.0, view: cam });
    }
    let mut g = c.benchmark_group("mesh");
    g.sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    for (name, depth, cam) in &scenes {
        let seg = Segmentation::default();
        g.bench_function(format!("build/{name}"), |b| {
            b.iter(|| Hierarchy::build_with(black_box(depth), cam, &seg, Threads::Single).unwrap())
        });
        g.bench_function(format!("build2t/{name}"), |b| {
            b.iter(|| Hierarchy::build_with(black_box(depth), cam, &seg, Threads::Parallel).unwrap())
        });
        let h = Hierarchy::build(depth, cam, &seg).unwrap();
        let eps = 0.005 * median_depth(depth);
        let view = side_view(cam, median_depth(depth));
        g.bench_function(format!("static/{name}"), |b| {
            b.iter(|| h.extract(Lod::Epsilon(black_box(eps))).unwrap())
        });
        g.bench_function(format!("tau1/{name}"), |b| {
            b.iter(|| {
                h.extract(Lod::Tau {
                    tau: black_box(1.0),
                    view: &view,
                })
                .unwrap()
            })
        });
        if name == "synthetic-513x513" {
            g.bench_function(format!("tau1-tunnelled/{name}"), |b| {
                b.iter(|| {
                    h.extract_with(
                        Lod::Tau {
                            tau: black_box(1.0),
                            view: &view,
                        },
                        StripOrder::Tunnelled,
                    )
                    .unwrap()
                })
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default();
    targets = bench
}
criterion_main!(benches);
