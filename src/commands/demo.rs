//! `dmesh demo`: a built-in synthetic scene meshed at several tolerances,
//! no files needed.

use std::path::Path;

use anyhow::{bail, Result};
use dmesh_engine::camera::Camera;
use dmesh_engine::mesh::{Hierarchy, Lod, Mesh, Segmentation, StripOrder};

pub fn run(size: u32, ply: Option<&Path>) -> Result<()> {
    if !(2..=8193).contains(&size) {
        bail!("demo size is {size}; it must be between 2 and 8193");
    }
    let (depth, camera) = dmesh_engine::synthetic::terrain_with_boxes(size, size);
    let hierarchy = Hierarchy::build(&depth, &camera, &Segmentation::default())?;
    let stats = hierarchy.stats();
    println!(
        "synthetic terrain with boxes, {size}x{size}: {} grid vertices, {} bytes, {} segmented triangles, built in {:.2} ms",
        stats.grid_vertices, stats.heap_bytes, stats.segmented_triangles, stats.build_ms
    );
    println!(
        "{:<22} {:>10} {:>9} | {:^19} | {:^19} | {:^19}",
        "", "", "", "traversal strips", "greedy strips", "tunnelled strips"
    );
    println!(
        "{:<22} {:>10} {:>9} | {:>8} {:>10} | {:>8} {:>10} | {:>8} {:>10}",
        "level of detail",
        "triangles",
        "vertices",
        "idx/tri",
        "extract ms",
        "idx/tri",
        "extract ms",
        "idx/tri",
        "extract ms"
    );
    let side = Camera::new(
        size,
        size,
        camera.projection,
        glam::DQuat::from_rotation_y(-0.1),
        glam::DVec3::new(0.5, 0.0, 0.0),
    )?;
    let far = Camera::new(
        size,
        size,
        camera.projection,
        glam::DQuat::IDENTITY,
        glam::DVec3::new(0.0, 0.0, -20.0),
    )?;
    let lods = [
        ("epsilon 0 (full)", Lod::Epsilon(0.0)),
        ("epsilon 1 mm", Lod::Epsilon(0.001)),
        ("epsilon 1 cm", Lod::Epsilon(0.01)),
        ("epsilon 10 cm", Lod::Epsilon(0.1)),
        ("tau 1 px, side view", Lod::Tau { tau: 1.0, view: &side }),
        ("tau 1 px, 20 m back", Lod::Tau { tau: 1.0, view: &far }),
    ];
    for (name, lod) in lods {
        let m = hierarchy.extract(lod)?;
        let g = hierarchy.extract_with(lod, StripOrder::Greedy)?;
        let t = hierarchy.extract_with(lod, StripOrder::Tunnelled)?;
        let ipt = |m: &Mesh| m.strips.len() as f64 / m.triangles.len().max(1) as f64;
        println!(
            "{name:<22} {:>10} {:>9} | {:>8.3} {:>10.3} | {:>8.3} {:>10.3} | {:>8.3} {:>10.3}",
            m.triangles.len(),
            m.vertices.len(),
            ipt(&m),
            m.extract_ms,
            ipt(&g),
            g.extract_ms,
            ipt(&t),
            t.extract_ms
        );
    }
    if let Some(p) = ply {
        super::mesh::write_ply(p, &hierarchy.extract(Lod::Epsilon(0.01))?, &camera, None)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
