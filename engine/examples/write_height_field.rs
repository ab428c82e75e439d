//! Writes the synthetic 513 x 513 height field (`dmesh_engine::synthetic::height_field`)
//! as a PFM file and its orthographic camera as JSON, for the martini
//! comparison in `engine/benches/peer/martini.sh`.
//!
//! Usage: `cargo run --release -p dmesh-engine --example write_height_field -- OUT_DIR [SIZE]`

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = std::path::PathBuf::from(args.next().ok_or("usage: write_height_field OUT_DIR [SIZE]")?);
    let size: u32 = args.next().map_or(Ok(513), |s| s.parse())?;
    let (depth, camera) = dmesh_engine::synthetic::height_field(size);
    std::fs::write(
        dir.join("height.pfm"),
        dmesh_engine::image::encode_pfm(depth.width, depth.height, &depth.z),
    )?;
    let wire = dmesh_proto::Camera::from(&camera);
    std::fs::write(dir.join("camera.json"), serde_json::to_string(&wire)?)?;
    Ok(())
}
