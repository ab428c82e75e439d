//! `dmesh-client render`: a novel view blended on the CPU from the server's
//! strips (DMesh Sec. 6.3-6.4), with its depth and coverage on request.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use dmesh_client::blend::BlendOptions;
use dmesh_client::http::Server;
use dmesh_client::loadtest::Detail;
use dmesh_client::novel::render_novel;

use super::detail::DetailArgs;
use crate::{png, read};

/// Options of `render`.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// Server base URL.
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub server: String,
    /// Scene id.
    #[arg(long)]
    pub scene: String,
    /// The novel camera (JSON).
    #[arg(long)]
    pub camera: PathBuf,
    #[command(flatten)]
    pub detail: DetailArgs,
    /// Output PNG.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the rendered depth (PFM).
    #[arg(long)]
    pub depth_out: Option<PathBuf>,
    /// Also write which views contributed (PNG, a colour per view).
    #[arg(long)]
    pub coverage_out: Option<PathBuf>,
    /// Verlani's per-pixel cos^k weights.
    #[arg(long)]
    pub cos_k: Option<f64>,
    /// Verlani's per-pixel exp(-k theta) weights (theta in radians).
    #[arg(long)]
    pub exp_k: Option<f64>,
    /// Relight with the vertex normals (diffuse + specular from a light above and behind the camera).
    #[arg(long)]
    pub relight: bool,
    /// Fill seams of at most this many pixels between covered pixels of one surface (0: leave every hole).
    #[arg(long, default_value_t = 2)]
    pub fill_gaps: u32,
    /// Colour texture cache directory.
    #[arg(long, default_value = "./dmesh-cache")]
    pub cache: PathBuf,
}

/// Renders the view and writes the PNG (and the depth and coverage asked for).
pub fn run(args: RenderArgs, rt: &tokio::runtime::Runtime) -> Result<()> {
    let RenderArgs {
        server,
        scene,
        camera,
        detail,
        out,
        depth_out,
        coverage_out,
        cos_k,
        exp_k,
        relight,
        fill_gaps,
        cache,
    } = args;
    let relight = relight.then(|| (glam::DVec3::new(0.3, 1.0, 0.4).normalize(), 32.0));
    let options = BlendOptions {
        cos_k,
        exp_k,
        relight,
        fill_gaps,
        ..Default::default()
    };
    let b = rt.block_on(render(&server, &scene, &camera, detail.detail()?, &options, &cache))?;
    std::fs::write(&out, png(b.width, b.height, &b.rgb)?).with_context(|| format!("cannot write {}", out.display()))?;
    if let Some(p) = depth_out {
        std::fs::write(&p, dmesh_engine::image::encode_pfm(b.width, b.height, &b.depth))?;
    }
    if let Some(p) = coverage_out {
        std::fs::write(&p, coverage_png(&b)?)?;
    }
    println!("wrote {}", out.display());
    Ok(())
}

async fn render(
    server: &str,
    scene: &str,
    camera: &Path,
    detail: Detail,
    options: &BlendOptions,
    cache: &Path,
) -> Result<dmesh_client::blend::Blended> {
    let s = Server::new(server, Some(cache.to_path_buf())).with_wire(detail.wire);
    let wire: dmesh_proto::Camera = serde_json::from_slice(&read(camera)?).context("camera JSON")?;
    render_novel(&s, scene, &detail.request(wire), options).await
}

fn coverage_png(b: &dmesh_client::blend::Blended) -> Result<Vec<u8>> {
    let palette = [
        [230, 25, 75],
        [60, 180, 75],
        [255, 225, 25],
        [0, 130, 200],
        [245, 130, 48],
        [145, 30, 180],
        [70, 240, 240],
        [240, 50, 230],
    ];
    let mut rgb = vec![0u8; b.rgb.len()];
    for (i, &mask) in b.coverage.iter().enumerate() {
        let (mut c, mut n) = ([0u32; 3], 0u32);
        for (k, p) in palette.iter().enumerate() {
            if mask & (1 << k) != 0 {
                (0..3).for_each(|j| c[j] += p[j]);
                n += 1;
            }
        }
        if n > 0 {
            (0..3).for_each(|j| rgb[3 * i + j] = (c[j] / n) as u8);
        }
    }
    png(b.width, b.height, &rgb)
}
