//! Strip statistics of the demo scene: strips, swaps and restarts per order.
use dmesh::mesh::{DepthMesh, Lod, StripOrder, RESTART};
fn main() {
    let (d, c) = dmesh::synthetic::terrain_with_boxes(513, 513);
    let h = DepthMesh::build(&d, &c, &Default::default()).unwrap();
    let view = dmesh::camera::Camera::new(
        513,
        513,
        c.projection,
        glam::DQuat::from_rotation_y(-0.1),
        glam::DVec3::new(0.5, 0.0, 0.0),
    )
    .unwrap();
    for (name, lod) in [
        ("eps 1cm", Lod::Epsilon(0.01)),
        ("tau 1", Lod::Tau { tau: 1.0, view: &view }),
        ("full", Lod::Epsilon(0.0)),
    ] {
        for order in [StripOrder::Traversal, StripOrder::Greedy] {
            let m = h.extract_with(lod, order).unwrap();
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
            let lens: Vec<usize> = m.strips.split(|&i| i == RESTART).map(|r| r.len()).collect();
            let singles = lens.iter().filter(|&&l| l == 3).count();
            println!("{name:8} {order:?}: {t} tris, {idx} idx ({:.3}), {strips} strips ({singles} single), {degenerate} swaps", idx as f64 / t as f64);
        }
    }
}
