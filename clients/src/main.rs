//! `dmesh-client`: ingest views, render novel views by blending, compare images.
//!
//! - `dmesh-client ingest --server URL --scene ID (--simulate SCENE_FILE|demo | --dir DIR)`
//! - `dmesh-client render --server URL --scene ID --camera CAM.json [--tau T | --epsilon E]
//!   --out OUT.png [--depth-out OUT.pfm] [--coverage-out COV.png] [--cos-k K] [--exp-k K] [--max-views N]`
//! - `dmesh-client compare A.png B.png [--depth-a A.pfm --depth-b B.pfm] [--json]`
//!
//! Every failure exits non-zero with one line naming the problem.

// The command-line glue both binaries share (`dmesh-cli`).
use dmesh_cli as cli;
mod commands;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use dmesh_client::blend::BlendOptions;
use dmesh_client::compare::compare;
use dmesh_client::http::Server;
use dmesh_client::loadtest::Detail;
use dmesh_client::novel::render_novel;

#[derive(Parser)]
#[command(name = "dmesh-client", version, about = "Thin client of a dmesh server")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Upload a simulated scene or a folder of views.
    Ingest {
        /// Server base URL.
        #[arg(long, default_value = "http://127.0.0.1:8080")]
        server: String,
        /// Scene id.
        #[arg(long)]
        scene: String,
        /// A scene file (JSON), or `demo` for the built-in box scene.
        #[arg(long, conflicts_with = "dir", required_unless_present = "dir")]
        simulate: Option<String>,
        /// A folder of views: NAME.json (camera), NAME.depth.{pfm,png,exr}, NAME.color.{png,jpg}.
        #[arg(long)]
        dir: Option<PathBuf>,
    },
    /// Render a novel view by blending the server's strips.
    Render {
        /// Server base URL.
        #[arg(long, default_value = "http://127.0.0.1:8080")]
        server: String,
        /// Scene id.
        #[arg(long)]
        scene: String,
        /// The novel camera (JSON).
        #[arg(long)]
        camera: PathBuf,
        #[command(flatten)]
        detail: DetailArgs,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
        /// Also write the rendered depth (PFM).
        #[arg(long)]
        depth_out: Option<PathBuf>,
        /// Also write which views contributed (PNG, a colour per view).
        #[arg(long)]
        coverage_out: Option<PathBuf>,
        /// Verlani's per-pixel cos^k weights.
        #[arg(long)]
        cos_k: Option<f64>,
        /// Verlani's per-pixel exp(-k theta) weights (theta in radians).
        #[arg(long)]
        exp_k: Option<f64>,
        /// Relight with the vertex normals (diffuse + specular from a light above and behind the camera).
        #[arg(long)]
        relight: bool,
        /// Fill seams of at most this many pixels between covered pixels of one surface (0: leave every hole).
        #[arg(long, default_value_t = 2)]
        fill_gaps: u32,
        /// Colour texture cache directory.
        #[arg(long, default_value = "./dmesh-cache")]
        cache: PathBuf,
    },
    /// Load the server's /render with novel cameras on an orbit (bounded; loopback only by default).
    Loadtest {
        /// Server base URL.
        #[arg(long, default_value = "http://127.0.0.1:8080")]
        server: String,
        /// Scene id.
        #[arg(long)]
        scene: String,
        /// Requests in flight.
        #[arg(long, default_value_t = 8)]
        concurrency: usize,
        /// Stop after this many requests.
        #[arg(long, conflicts_with = "duration", required_unless_present = "duration")]
        requests: Option<u64>,
        /// Stop after this many seconds.
        #[arg(long)]
        duration: Option<f64>,
        #[command(flatten)]
        detail: DetailArgs,
        /// Viewpoints on the orbit.
        #[arg(long, default_value_t = 32)]
        viewpoints: usize,
        /// Allow a target that is not on this machine's loopback interface.
        #[arg(long)]
        allow_remote: bool,
        /// Print JSON: requests, errors, throughput_rps, p50_ms, p90_ms, p99_ms, max_ms, bytes, seconds (per second: at, requests, errors, p99_ms).
        #[arg(long)]
        json: bool,
    },
    /// Sweep tau, epsilon, residual bits and triangle budgets over scenes with
    /// ground truth (simulated, and Middlebury with --data): tables and curves.
    /// With --baselines, compare the thesis's meshers with the RQT instead.
    Report(commands::report::ReportArgs),
    /// Decode a compact body (protocol 6, `application/vnd.dmesh.mesh`) and
    /// print it as protocol 5 JSON: vertices, derived normals and rho, depths, triangles.
    Decode(commands::decode::DecodeArgs),
    /// Move along a camera path, drawing every frame from held meshes and
    /// fetching by strategy (Qu et al.'s workload balancing); prints the
    /// frame-time comparison of the strategies run.
    Walkthrough(commands::walkthrough::WalkthroughArgs),
    /// Replace one view's depth as a live sequence at a fixed rate (a folder
    /// of frames, or a simulated scene whose objects sway): progress, then
    /// the achieved rate and upload times.
    Stream(commands::stream::StreamArgs),
    /// PSNR (valid mask) and inverse-depth RMSE between two images.
    Compare {
        /// First image (PNG).
        a: PathBuf,
        /// Second image (PNG).
        b: PathBuf,
        /// Depth of the first (PFM); with --depth-b the valid mask is where both are positive.
        #[arg(long, requires = "depth_b")]
        depth_a: Option<PathBuf>,
        /// Depth of the second (PFM).
        #[arg(long, requires = "depth_a")]
        depth_b: Option<PathBuf>,
        /// Print JSON: psnr, valid_fraction, inverse_depth_rmse.
        #[arg(long)]
        json: bool,
    },
}

/// One progress line on stderr, redrawn in place on a terminal (every 50
/// frames and at the end otherwise, so a log stays readable).
fn progress(what: &str, done: u32, total: u32, last_ms: f64) {
    use std::io::IsTerminal;
    let tty = std::io::stderr().is_terminal();
    if !tty && done % 50 != 0 && done != total {
        return;
    }
    let width = 30usize;
    let filled = (width as u64 * u64::from(done) / u64::from(total.max(1))) as usize;
    let bar: String = "#".repeat(filled) + &"-".repeat(width - filled);
    let end = if tty { "\r" } else { "\n" };
    eprint!("{what:>9} [{bar}] {done}/{total} frames, last {last_ms:.1} ms{end}");
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))
}

fn png(width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    let img = image::RgbImage::from_raw(width, height, rgb.to_vec()).context("image buffer size")?;
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)?;
    Ok(out)
}

fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    dmesh_engine::image::decode_pfm(&read(path)?, &Default::default())
        .with_context(|| format!("depth {}", path.display()))
}

/// A scene file, or `demo` for the built-in box scene.
fn scene_spec(name: &str) -> Result<dmesh_engine::sim::SceneSpec> {
    Ok(if name == "demo" {
        dmesh_engine::sim::SceneSpec::demo()
    } else {
        dmesh_engine::sim::SceneSpec::from_json(&String::from_utf8(read(Path::new(name))?)?)?
    })
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

/// The level of detail of `render` and `loadtest`: one of --tau (default 1
/// pixel), --epsilon, --max-triangles, --budget-ms; optionally --bits.
#[derive(clap::Args, Debug)]
struct DetailArgs {
    /// View-dependent tolerance in pixels (default 1).
    #[arg(long, conflicts_with_all = ["epsilon", "max_triangles", "budget_ms"])]
    tau: Option<f64>,
    /// Static tolerance in metres.
    #[arg(long, conflicts_with_all = ["max_triangles", "budget_ms"])]
    epsilon: Option<f64>,
    /// Triangle budget per answer, shared by its views (the server picks tau).
    #[arg(long, conflicts_with = "budget_ms")]
    max_triangles: Option<u32>,
    /// Extraction time budget per answer in milliseconds (the server picks tau).
    #[arg(long)]
    budget_ms: Option<f64>,
    /// Residual bit-depth of the depths (0..=16; exact f32 when absent).
    #[arg(long, value_parser = clap::value_parser!(u8).range(0..=16))]
    bits: Option<u8>,
    /// Most views per answer (server default 5).
    #[arg(long)]
    max_views: Option<u32>,
    /// How meshes travel: the compact stream (protocol 6, zstd) or protocol 5 bincode.
    #[arg(long, value_enum, default_value = "compact")]
    wire: dmesh_client::http::Wire,
}

impl DetailArgs {
    fn detail(&self) -> Detail {
        use dmesh_proto::Lod;
        // clap refuses two of them; with none, tau 1 pixel.
        let lod = (self.epsilon.map(Lod::Epsilon))
            .or(self.max_triangles.map(Lod::MaxTriangles))
            .or(self.budget_ms.map(Lod::BudgetMs))
            .unwrap_or(Lod::Tau(self.tau.unwrap_or(1.0)));
        Detail {
            lod,
            bits: self.bits,
            max_views: self.max_views,
            wire: self.wire,
        }
    }
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

fn run(cli: Cli) -> Result<()> {
    // One thread: the client waits on the network, and a load test on the
    // server's machine should take as little of it as it can.
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    match cli.command {
        Command::Ingest {
            server,
            scene,
            simulate,
            dir,
        } => rt.block_on(ingest(&server, &scene, simulate.as_deref(), dir.as_deref())),
        Command::Render {
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
        } => {
            let relight = relight.then(|| (glam::DVec3::new(0.3, 1.0, 0.4).normalize(), 32.0));
            let options = BlendOptions {
                cos_k,
                exp_k,
                relight,
                fill_gaps,
                ..Default::default()
            };
            let b = rt.block_on(render(&server, &scene, &camera, detail.detail(), &options, &cache))?;
            std::fs::write(&out, png(b.width, b.height, &b.rgb)?)
                .with_context(|| format!("cannot write {}", out.display()))?;
            if let Some(p) = depth_out {
                std::fs::write(&p, dmesh_engine::image::encode_pfm(b.width, b.height, &b.depth))?;
            }
            if let Some(p) = coverage_out {
                std::fs::write(&p, coverage_png(&b)?)?;
            }
            println!("wrote {}", out.display());
            Ok(())
        }
        Command::Loadtest {
            server,
            scene,
            concurrency,
            requests,
            duration,
            detail,
            viewpoints,
            allow_remote,
            json,
        } => {
            let detail = detail.detail();
            dmesh_client::loadtest::check_target(&server, allow_remote)?;
            let stop = match (requests, duration) {
                (Some(n), _) => dmesh_client::loadtest::Stop::Requests(n),
                (None, Some(s)) if s.is_finite() && s > 0.0 && s <= 86_400.0 => {
                    dmesh_client::loadtest::Stop::Duration(std::time::Duration::from_secs_f64(s))
                }
                _ => bail!("give --requests N or --duration S (seconds, at most a day)"),
            };
            let report = rt.block_on(async {
                let s = Server::new(&server, None).with_wire(detail.wire);
                let cameras = dmesh_client::loadtest::orbit(&s.cameras(&scene).await?, viewpoints)?;
                dmesh_client::loadtest::run(&s, &scene, &cameras, detail, concurrency, stop).await
            })?;
            if json {
                println!("{}", serde_json::to_string(&report)?);
            } else {
                println!(
                    "{} requests, {} errors, {:.1} req/s; latency p50 {:.2} ms, p90 {:.2} ms, p99 {:.2} ms, max {:.2} ms; \
                     server extraction p50 {:.2} ms; {} bytes",
                    report.requests,
                    report.errors,
                    report.throughput_rps,
                    report.p50_ms,
                    report.p90_ms,
                    report.p99_ms,
                    report.max_ms,
                    report.server_extract_p50_ms,
                    report.bytes
                );
            }
            Ok(())
        }
        Command::Report(args) => commands::report::run(args),
        Command::Decode(args) => commands::decode::run(args),
        Command::Walkthrough(args) => commands::walkthrough::run(args, &rt),
        Command::Stream(args) => commands::stream::run(args, &rt),
        Command::Compare {
            a,
            b,
            depth_a,
            depth_b,
            json,
        } => {
            let load = |p: &Path| -> Result<image::RgbImage> {
                Ok(image::load_from_memory(&read(p)?)
                    .with_context(|| format!("image {}", p.display()))?
                    .to_rgb8())
            };
            let (ia, ib) = (load(&a)?, load(&b)?);
            if ia.dimensions() != ib.dimensions() {
                bail!(
                    "{} is {:?} but {} is {:?}",
                    a.display(),
                    ia.dimensions(),
                    b.display(),
                    ib.dimensions()
                );
            }
            let depths = match (depth_a, depth_b) {
                (Some(da), Some(db)) => Some((read_pfm(&da)?.2, read_pfm(&db)?.2)),
                _ => None,
            };
            let c = compare(
                ia.as_raw(),
                ib.as_raw(),
                depths.as_ref().map(|(x, y)| (x.as_slice(), y.as_slice())),
            )?;
            if json {
                println!("{}", serde_json::to_string(&c)?);
            } else {
                println!(
                    "PSNR {:.2} dB over {:.1} % of the pixels",
                    c.psnr,
                    100.0 * c.valid_fraction
                );
                if let Some(r) = c.inverse_depth_rmse {
                    println!("inverse-depth RMSE {r:.6}");
                }
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    match cli::parse::<Cli>() {
        Ok(cli) => {
            cli::init_logging();
            cli::finish(run(cli))
        }
        Err(code) => code,
    }
}
