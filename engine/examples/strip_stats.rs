//! Strip statistics of the demo scene per strip order: indices per
//! triangle, strips, swaps, and a lower bound that holds for any stripifier.
//!
//! The bound: every index of a strip (a repeated one for a swap included) is
//! a corner of at most three consecutive triangles, so a vertex with `k`
//! incident triangles is written at least `ceil(k / 3)` times; the sum over
//! vertices, divided by the triangles, bounds the indices per triangle from
//! below (restarts not counted). Beside the strips, the fewest strips any
//! stripifier needs (triangles with one neighbour end a strip, those with
//! none are one) and the extraction time. Usage:
//! `cargo run --release -p dmesh-engine --example strip_stats`.
use dmesh_engine::mesh::{Hierarchy, Lod, Mesh, StripOrder, RESTART};

/// Indices per triangle no stripification of `m` can go below.
fn bound(m: &Mesh) -> f64 {
    let mut incident = vec![0u32; m.vertices.len()];
    for t in &m.triangles {
        for &v in t {
            incident[v as usize] += 1;
        }
    }
    let writes: u64 = incident.iter().map(|&k| u64::from(k.div_ceil(3))).sum();
    writes as f64 / m.triangles.len().max(1) as f64
}

fn main() {
    let (d, c) = dmesh_engine::synthetic::terrain_with_boxes(513, 513);
    let h = Hierarchy::build(&d, &c, &Default::default()).expect("the demo scene builds");
    let view = dmesh_engine::camera::Camera::new(
        513,
        513,
        c.projection,
        glam::DQuat::from_rotation_y(-0.1),
        glam::DVec3::new(0.5, 0.0, 0.0),
    )
    .expect("a valid camera");
    for (name, lod) in [
        ("eps 1cm", Lod::Epsilon(0.01)),
        ("tau 1", Lod::Tau { tau: 1.0, view: &view }),
        ("full", Lod::Epsilon(0.0)),
    ] {
        for order in [StripOrder::Traversal, StripOrder::Greedy, StripOrder::Tunnelled] {
            let m = h.extract_with(lod, order).expect("extracts");
            let strips = m.strip_count();
            let t = m.triangles.len();
            let idx = m.strips.len();
            let degenerate: usize = m
                .strips
                .split(|&i| i == RESTART)
                .map(|r| {
                    r.windows(3)
                        .filter(|w| w[0] == w[1] || w[1] == w[2] || w[0] == w[2])
                        .count()
                })
                .sum();
            let singles = m.strips.split(|&i| i == RESTART).filter(|r| r.len() == 3).count();
            println!(
                "{name:8} {order:?}: {t} tris, {idx} idx ({:.3}, bound {:.3}), {strips} strips (min {}, {singles} single), {degenerate} swaps, {:.2} ms",
                idx as f64 / t as f64,
                bound(&m), min_strips(&m), m.extract_ms
            );
        }
    }
}

/// Lower bound on strips: every triangle with one neighbour ends a strip and
/// every triangle with none is a strip of its own.
fn min_strips(m: &Mesh) -> usize {
    let mut edges = std::collections::HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0u32) += 1;
        }
    }
    let (mut d0, mut d1) = (0usize, 0usize);
    for t in &m.triangles {
        let deg = (0..3)
            .filter(|&k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges[&(a.min(b), a.max(b))] > 1
            })
            .count();
        if deg == 0 {
            d0 += 1;
        }
        if deg == 1 {
            d1 += 1;
        }
    }
    (d1 + 2 * d0).div_ceil(2)
}
