//! Where a `/render` answer's time goes for one 513 x 513 view at tau = 1:
//! extraction, strip response (wire vertices, residual or exact depths,
//! 16-bit indices) and bincode encoding. `cargo run --release -p dmesh-engine --example response_cost`.

use std::time::Instant;

use dmesh_engine::mesh::{Hierarchy, Lod, Segmentation};
use dmesh_engine::wire::{strip_response, DepthCoding};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (depth, camera) = dmesh_engine::synthetic::terrain_with_boxes(513, 513);
    let h = Hierarchy::build(&depth, &camera, &Segmentation::default())?;
    let view = dmesh_engine::camera::Camera::new(
        513,
        513,
        camera.projection,
        dmesh_engine::sim::rig::look_at(glam::DVec3::new(0.8, 0.3, 0.0), glam::DVec3::new(0.0, 0.0, 5.0)),
        glam::DVec3::new(0.8, 0.3, 0.0),
    )?;
    let lod = Lod::Tau { tau: 1.0, view: &view };
    let n = 400;
    let (mut te, mut ts, mut tb, mut bytes) = (0.0, 0.0, 0.0, 0);
    for _ in 0..n {
        let t = Instant::now();
        let mesh = h.extract(lod)?;
        te += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let r = strip_response(&mesh, "s", "v", &camera, DepthCoding::default())?;
        ts += t.elapsed().as_secs_f64();
        let t = Instant::now();
        bytes = dmesh_proto::to_bincode(&r)?.len();
        tb += t.elapsed().as_secs_f64();
    }
    let ms = |s: f64| s * 1e3 / f64::from(n);
    println!(
        "extract {:.3} ms, strip response {:.3} ms, bincode {:.3} ms ({bytes} bytes)",
        ms(te),
        ms(ts),
        ms(tb)
    );
    Ok(())
}
