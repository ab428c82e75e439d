//! `dmesh-client ingest`: uploads a simulated scene or a folder of views.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use dmesh_client::http::Server;

use crate::{png, read, scene_spec};

/// Options of `ingest`.
#[derive(clap::Args, Debug)]
pub struct IngestArgs {
    /// Server base URL.
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub server: String,
    /// Scene id.
    #[arg(long)]
    pub scene: String,
    /// A scene file (JSON), or `demo` for the built-in box scene.
    #[arg(long, conflicts_with = "dir", required_unless_present = "dir")]
    pub simulate: Option<String>,
    /// A folder of views: NAME.json (camera), NAME.depth.{pfm,png,exr}, NAME.color.{png,jpg}.
    #[arg(long)]
    pub dir: Option<PathBuf>,
}

/// Uploads every view of the scene file or folder, one after another.
pub fn run(args: IngestArgs, rt: &tokio::runtime::Runtime) -> Result<()> {
    rt.block_on(ingest(
        &args.server,
        &args.scene,
        args.simulate.as_deref(),
        args.dir.as_deref(),
    ))
}

async fn ingest(server: &str, scene: &str, simulate: Option<&str>, dir: Option<&Path>) -> Result<()> {
    let s = Server::new(server, None);
    let views: Vec<(String, String, Vec<u8>, Vec<u8>)> = match (simulate, dir) {
        (Some(name), _) => scene_spec(name)?
            .reference_views()?
            .iter()
            .enumerate()
            .map(|(k, v)| {
                let cam = serde_json::to_string(&dmesh_proto::Camera::from(&v.camera))?;
                let depth = dmesh_engine::image::encode_pfm(v.depth.width, v.depth.height, &v.depth.z);
                Ok((
                    format!("v{k:02}"),
                    cam,
                    depth,
                    png(v.color.width, v.color.height, &v.color.rgb)?,
                ))
            })
            .collect::<Result<_>>()?,
        (None, Some(dir)) => {
            let mut out = Vec::new();
            let mut names: Vec<_> = std::fs::read_dir(dir)
                .with_context(|| format!("cannot list {}", dir.display()))?
                .filter_map(|e| e.ok()?.file_name().to_str()?.strip_suffix(".json").map(str::to_string))
                .collect();
            names.sort();
            for name in names {
                let find = |stem: &str, exts: &[&str]| {
                    exts.iter()
                        .map(|e| dir.join(format!("{name}.{stem}.{e}")))
                        .find(|p| p.exists())
                };
                let depth =
                    find("depth", &["pfm", "png", "exr"]).with_context(|| format!("no depth for view {name}"))?;
                let color =
                    find("color", &["png", "jpg", "jpeg"]).with_context(|| format!("no colour for view {name}"))?;
                let cam = String::from_utf8(read(&dir.join(format!("{name}.json")))?)?;
                out.push((name, cam, read(&depth)?, read(&color)?));
            }
            out
        }
        _ => bail!("give --simulate SCENE_FILE (or demo) or --dir DIR"),
    };
    if views.is_empty() {
        bail!("nothing to upload");
    }
    for (k, (name, cam, depth, color)) in views.iter().enumerate() {
        let summary = s.put_view(scene, name, cam, depth, color).await?;
        eprint!(
            "\ruploaded {}/{} views ({} built in {:.1} ms)   ",
            k + 1,
            views.len(),
            summary.view,
            summary.build_ms
        );
        let _ = std::io::stderr().flush();
    }
    eprintln!();
    Ok(())
}
