//! Renders the demo scene's (or a scene file's) reference views to PNG files,
//! colour and depth side by side, to look at.
//!
//! Usage: `simulate OUT_DIR [SCENE.json]`
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = std::path::PathBuf::from(args.next().ok_or("usage: simulate OUT_DIR [SCENE.json]")?);
    let scene = match args.next() {
        Some(p) => dmesh_engine::sim::SceneSpec::from_json(&std::fs::read_to_string(p)?)?,
        None => dmesh_engine::sim::SceneSpec::demo(),
    };
    std::fs::create_dir_all(&out)?;
    for (k, v) in scene.reference_views()?.iter().enumerate() {
        let (w, h) = (v.camera.width, v.camera.height);
        let zmax = v.depth.z.iter().copied().fold(0f32, f32::max).max(1e-6);
        let img = image::RgbImage::from_fn(2 * w, h, |x, y| {
            if x < w {
                let i = 3 * (y * w + x) as usize;
                image::Rgb([v.color.rgb[i], v.color.rgb[i + 1], v.color.rgb[i + 2]])
            } else {
                let z = v.depth.z[(y * w + x - w) as usize];
                let g = if z > 0.0 { (255.0 * (1.0 - z / zmax)) as u8 } else { 0 };
                image::Rgb([g, g, g])
            }
        });
        img.save(out.join(format!("view{k:02}.png")))?;
    }
    Ok(())
}
