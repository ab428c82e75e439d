//! Draws an extracted mesh's edges over its colour image, to look at.
//!
//! Usage: `wireframe DEPTH.png COLOR.png CAMERA.json SCALE OFFSET FOCAL_BASELINE EPSILON OUT.png`
//! (disparity PNGs, as the Middlebury scenes ship them).
use dmesh_engine::image::{decode_depth, DepthKind, DepthOptions, Limits};
use dmesh_engine::mesh::{Hierarchy, Lod, Segmentation};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() != 8 {
        return Err("usage: wireframe DEPTH COLOR CAMERA SCALE OFFSET FOCAL_BASELINE EPSILON OUT".into());
    }
    let camera = dmesh_engine::camera::camera_from_json(&std::fs::read_to_string(&a[2])?)?;
    let opts = DepthOptions {
        kind: DepthKind::Disparity,
        scale: a[3].parse()?,
        offset: a[4].parse()?,
        focal_baseline: Some(a[5].parse()?),
        channel: None,
    };
    let depth = decode_depth(&std::fs::read(&a[0])?, &opts, &camera, &Limits::default())?;
    let mut img = image::open(&a[1])?.to_rgb8();
    let mesh = Hierarchy::build(&depth, &camera, &Segmentation::default())?.extract(Lod::Epsilon(a[6].parse()?))?;
    for t in &mesh.triangles {
        for k in 0..3 {
            let (p, q) = (mesh.vertices[t[k] as usize], mesh.vertices[t[(k + 1) % 3] as usize]);
            let steps = u32::from(p.i.abs_diff(q.i).max(p.j.abs_diff(q.j))).max(1);
            for s in 0..=steps {
                let f = f64::from(s) / f64::from(steps);
                let x = (f64::from(p.i) + f * (f64::from(q.i) - f64::from(p.i))).round() as u32;
                let y = (f64::from(p.j) + f * (f64::from(q.j) - f64::from(p.j))).round() as u32;
                img.put_pixel(x, y, image::Rgb([255, 40, 40]));
            }
        }
    }
    img.save(&a[7])?;
    println!("{} triangles", mesh.triangles.len());
    Ok(())
}
