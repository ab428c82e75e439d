//! Draws an extracted mesh's edges over its colour image, to look at.
//!
//! Usage: `wireframe DEPTH.png COLOR.png CAMERA.json SCALE OFFSET FOCAL_BASELINE EPSILON OUT.png [cut]`
//! (disparity PNGs, as the Middlebury scenes ship them). With `cut`, the
//! outlines are cut (`Outlines::Cut`): the cut triangles' parts are drawn
//! in yellow, their cuts in cyan.
use dmesh_engine::image::{decode_depth, DepthKind, DepthOptions, Limits};
use dmesh_engine::mesh::{Hierarchy, Lod, Outlines, Segmentation, StripOrder};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() != 8 && !(a.len() == 9 && a[8] == "cut") {
        return Err("usage: wireframe DEPTH COLOR CAMERA SCALE OFFSET FOCAL_BASELINE EPSILON OUT [cut]".into());
    }
    let outlines = if a.len() == 9 { Outlines::Cut } else { Outlines::Kept };
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
    let mesh = Hierarchy::build(&depth, &camera, &Segmentation::default())?.extract_as(
        Lod::Epsilon(a[6].parse()?),
        StripOrder::Traversal,
        outlines,
    )?;
    let (w, h) = img.dimensions();
    let mut line = |p: [f64; 2], q: [f64; 2], colour: [u8; 3]| {
        let steps = ((p[0] - q[0]).abs().max((p[1] - q[1]).abs()).ceil() as u32).max(1);
        for s in 0..=steps {
            let f = f64::from(s) / f64::from(steps);
            let x = (p[0] + f * (q[0] - p[0])).round() as u32;
            let y = (p[1] + f * (q[1] - p[1])).round() as u32;
            if x < w && y < h {
                img.put_pixel(x, y, image::Rgb(colour));
            }
        }
    };
    let at = |v: &dmesh_engine::mesh::MeshVertex| [f64::from(v.i), f64::from(v.j)];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (p, q) = (&mesh.vertices[t[k] as usize], &mesh.vertices[t[(k + 1) % 3] as usize]);
            line(at(p), at(q), [255, 40, 40]);
        }
    }
    for c in &mesh.cuts {
        for t in c.parts() {
            for k in 0..3 {
                let (p, q) = (t[k], t[(k + 1) % 3]);
                line([p[0], p[1]], [q[0], q[1]], [255, 220, 0]);
            }
        }
        let [p, q] = c.crossings();
        line(p, q, [0, 230, 255]);
    }
    img.save(&a[7])?;
    println!("{} triangles drawn ({} cut)", mesh.drawn_triangles(), mesh.cuts.len());
    Ok(())
}
