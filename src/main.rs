//! `dmesh`: command-line front end of the depth-mesh engine.
//!
//! - `dmesh demo`: meshes a built-in synthetic scene, no files needed;
//! - `dmesh mesh`: meshes one depth image (EXR, PNG, PFM) for a camera and
//!   writes a summary, JSON figures and optionally a binary PLY.
//!
//! Every failure exits non-zero with one line naming the problem.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{anyhow, bail, Context, Result};
use clap::{ArgGroup, Parser, Subcommand, ValueEnum};
use dmesh::camera::{camera_from_json, Camera};
use dmesh::image::{decode_color, decode_depth, decode_mask, ColorImage, DepthKind, DepthOptions, Limits};
use dmesh::mesh::{DepthMesh, Lod, Mesh, Method, Segmentation, StripOrder, Threads};

#[derive(Parser)]
#[command(
    name = "dmesh",
    version,
    about = "Multiresolution depth-meshes from depth images (DMesh)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Mesh one depth image.
    Mesh(Box<MeshArgs>),
    /// Serve views over HTTP from the embedded store or an object store.
    Serve(ServeArgs),
    /// Mesh a built-in synthetic scene (terrain with boxes) at several tolerances.
    Demo {
        /// Image width and height of the scene.
        #[arg(long, default_value_t = 513)]
        size: u32,
        /// Write the epsilon = 0.01 mesh to this binary PLY file.
        #[arg(long)]
        ply: Option<PathBuf>,
    },
}

#[derive(clap::Args)]
struct ServeArgs {
    /// Address to listen on.
    #[arg(long, default_value_t = std::net::SocketAddr::from(([127, 0, 0, 1], dmesh::http::DEFAULT_PORT)))]
    listen: std::net::SocketAddr,
    /// Data directory of the embedded store.
    #[arg(long, default_value = dmesh::http::DEFAULT_DATA_DIR, conflicts_with = "store")]
    data: PathBuf,
    /// Keep views in an S3-compatible object store instead, `s3://BUCKET/PREFIX`,
    /// so that replicas can share them. Endpoint, region and credentials come
    /// from AWS_ENDPOINT_URL, AWS_REGION, AWS_ACCESS_KEY_ID and
    /// AWS_SECRET_ACCESS_KEY; AWS_ALLOW_HTTP=true for a plain-HTTP endpoint.
    #[arg(long, value_name = "URL")]
    store: Option<String>,
    /// With --store: the longest a cached view or scene listing is served
    /// without checking its version in the store (how long another
    /// replica's replace may go unseen).
    #[arg(long, default_value_t = 0)]
    revalidate_ms: u64,
    /// Bytes of built hierarchies kept in memory.
    #[arg(long, default_value_t = 1 << 30)]
    cache_bytes: usize,
    /// Largest request body, bytes.
    #[arg(long, default_value_t = 256 << 20)]
    max_upload_bytes: usize,
    /// Largest decoded image, pixels.
    #[arg(long, default_value_t = 64 << 20)]
    max_pixels: u64,
    /// Reads (renders, strips, summaries) served at once; more wait up to
    /// --queue-wait-ms for a slot, then are answered 503 with Retry-After
    /// [default: the number of cores].
    #[arg(long)]
    max_concurrency: Option<usize>,
    /// Uploads served at once, apart from reads [default: half the cores, at least 1].
    #[arg(long)]
    max_uploads: Option<usize>,
    /// Milliseconds a request may wait for a free slot before it is shed.
    #[arg(long, default_value_t = 5)]
    queue_wait_ms: u64,
    /// Request timeout, seconds.
    #[arg(long, default_value_t = 30)]
    timeout_secs: u64,
    /// Ingest the simulated demo scene (scene id `demo`) when it is not stored yet.
    #[arg(long)]
    demo: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum KindArg {
    Z,
    Range,
    Disparity,
    #[value(alias = "inverse_depth")]
    Inverse,
}

#[derive(Clone, Copy, ValueEnum)]
enum StripsArg {
    Traversal,
    Greedy,
    Tunnelled,
}

#[derive(Clone, Copy, ValueEnum)]
enum SegmentArg {
    Orthogonality,
    Disparity,
    Connectedness,
    None,
}

#[derive(clap::Args)]
#[command(group(ArgGroup::new("lod").required(true).args(["epsilon", "tau", "max_triangles"])))]
struct MeshArgs {
    /// Depth image: OpenEXR (float), PNG (8/16-bit grey) or PFM.
    #[arg(long)]
    depth: PathBuf,
    /// What the depth samples measure.
    #[arg(long, value_enum, default_value = "z")]
    depth_kind: KindArg,
    /// Multiplies every raw sample.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    scale: f64,
    /// Added to every sample after scaling (Middlebury: dmin times the scale).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    offset: f64,
    /// Focal length in pixels times baseline, for --depth-kind disparity.
    #[arg(long, allow_negative_numbers = true)]
    focal_baseline: Option<f64>,
    /// EXR channel to read (default: the first float channel).
    #[arg(long)]
    channel: Option<String>,
    /// Reference camera JSON.
    #[arg(long)]
    camera: PathBuf,
    /// Validity mask (PNG of the same size, non-zero = valid).
    #[arg(long)]
    mask: Option<PathBuf>,
    /// Colour image (PNG or JPEG) of the same size; adds vertex colours to the PLY.
    #[arg(long)]
    color: Option<PathBuf>,
    /// Static object-space tolerance in metres (0: full resolution).
    #[arg(long, allow_negative_numbers = true)]
    epsilon: Option<f64>,
    /// View-dependent tolerance in pixels of --view (0: full resolution).
    #[arg(long, requires = "view", allow_negative_numbers = true)]
    tau: Option<f64>,
    /// Requesting camera JSON for --tau (or --max-triangles, view-dependent).
    #[arg(long)]
    view: Option<PathBuf>,
    /// At most this many triangles: the finest tolerance that provably meets
    /// it (view-dependent with --view, else static) is chosen and printed.
    #[arg(long)]
    max_triangles: Option<u64>,
    /// Rubber-sheet test.
    #[arg(long, value_enum, default_value = "orthogonality")]
    segment: SegmentArg,
    /// Orthogonality angle in degrees.
    #[arg(long, default_value_t = 5.0, allow_negative_numbers = true)]
    omega: f64,
    /// Disparity threshold (Eq. 9).
    #[arg(long, default_value_t = 0.05, allow_negative_numbers = true)]
    sigma: f64,
    /// Connectedness threshold (Eq. 6).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    kappa: f64,
    /// Depth-range gate dz / z (Eq. 11).
    #[arg(long, default_value_t = 0.02, allow_negative_numbers = true)]
    lambda: f64,
    /// Strip order: the traversal's (fastest), greedy (fewer indices) or
    /// tunnelled (fewest indices, slowest).
    #[arg(long, value_enum, default_value = "traversal")]
    strips: StripsArg,
    /// Largest accepted image, in pixels.
    #[arg(long, default_value_t = 64 << 20)]
    max_pixels: u64,
    /// Build threads: 2 (where the machine has them) computes deviations and
    /// normals beside the error pass; the result is the same.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=2))]
    threads: u8,
    /// Write the mesh as binary little-endian PLY.
    #[arg(long)]
    ply: Option<PathBuf>,
    /// Print one JSON object of figures instead of the summary.
    #[arg(long)]
    json: bool,
}

fn read(path: &Path, what: &str) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("cannot read {what} file {}", path.display()))
}

fn read_camera(path: &Path, what: &str) -> Result<Camera> {
    let bytes = read(path, what)?;
    let text = String::from_utf8(bytes).map_err(|_| anyhow!("{what} file {} is not UTF-8 text", path.display()))?;
    camera_from_json(&text).with_context(|| format!("{what} file {}", path.display()))
}

/// Peak resident set size of this process, from /proc (Linux); 0 elsewhere.
fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

fn write_ply(path: &Path, mesh: &Mesh, camera: &Camera, color: Option<&ColorImage>) -> Result<()> {
    std::fs::write(path, dmesh::ply::encode_ply(mesh, camera, color))
        .with_context(|| format!("cannot write PLY file {}", path.display()))
}

fn run_mesh(a: &MeshArgs) -> Result<()> {
    let camera = read_camera(&a.camera, "camera")?;
    let limits = Limits {
        max_pixels: a.max_pixels,
    };
    let options = DepthOptions {
        kind: match a.depth_kind {
            KindArg::Z => DepthKind::Z,
            KindArg::Range => DepthKind::Range,
            KindArg::Disparity => DepthKind::Disparity,
            KindArg::Inverse => DepthKind::InverseDepth,
        },
        scale: a.scale,
        offset: a.offset,
        focal_baseline: a.focal_baseline,
        channel: a.channel.clone(),
    };
    let mut depth = decode_depth(&read(&a.depth, "depth")?, &options, &camera, &limits)
        .with_context(|| format!("depth file {}", a.depth.display()))?;
    if let Some(p) = &a.mask {
        let mask = decode_mask(&read(p, "mask")?, depth.width, depth.height, &limits)
            .with_context(|| format!("mask file {}", p.display()))?;
        depth.apply_mask(&mask)?;
    }
    let color = match &a.color {
        Some(p) => {
            let c =
                decode_color(&read(p, "colour")?, &limits).with_context(|| format!("colour file {}", p.display()))?;
            if (c.width, c.height) != (depth.width, depth.height) {
                bail!(
                    "colour image is {}x{} but the depth image is {}x{}; they must match",
                    c.width,
                    c.height,
                    depth.width,
                    depth.height
                );
            }
            Some(c)
        }
        None => None,
    };
    let seg = Segmentation {
        method: match a.segment {
            SegmentArg::Orthogonality => Method::Orthogonality { omega_deg: a.omega },
            SegmentArg::Disparity => Method::Disparity { sigma: a.sigma },
            SegmentArg::Connectedness => Method::Connectedness { kappa: a.kappa },
            SegmentArg::None => Method::None,
        },
        lambda: a.lambda,
    };
    let threads = if a.threads == 1 {
        Threads::Single
    } else {
        Threads::available()
    };
    let hierarchy = DepthMesh::build_with(&depth, &camera, &seg, threads)?;
    let view = a.view.as_deref().map(|p| read_camera(p, "view camera")).transpose()?;
    let lod = match (a.epsilon, a.tau, a.max_triangles, &view) {
        (Some(e), None, None, _) => Lod::Epsilon(e),
        (None, Some(t), None, Some(v)) => Lod::Tau { tau: t, view: v },
        (None, None, Some(m), v) => hierarchy
            .lod_for_triangles(m, v.as_ref())?
            .lod(v.as_ref().unwrap_or(&camera)),
        _ => bail!("give one of --epsilon E, --tau T with --view VIEWCAM.json, or --max-triangles N"),
    };
    let (lod_name, lod_value) = match lod {
        Lod::Epsilon(e) => ("epsilon", e),
        Lod::Tau { tau, .. } => ("tau", tau),
    };
    let order = match a.strips {
        StripsArg::Traversal => StripOrder::Traversal,
        StripsArg::Greedy => StripOrder::Greedy,
        StripsArg::Tunnelled => StripOrder::Tunnelled,
    };
    let mesh = hierarchy.extract_with(lod, order)?;
    if let Some(p) = &a.ply {
        write_ply(p, &mesh, &camera, color.as_ref())?;
    }
    let stats = hierarchy.stats();
    if a.json {
        let figures = serde_json::json!({
            "width": depth.width,
            "height": depth.height,
            "grid_vertices": stats.grid_vertices,
            "vertices": mesh.vertices.len(),
            "triangles": mesh.triangles.len(),
            "strips": mesh.strip_count(),
            "indices": mesh.strips.len(),
            "segmented_triangles": stats.segmented_triangles,
            "build_ms": stats.build_ms,
            "extract_ms": mesh.extract_ms,
            "peak_bytes": stats.build_peak_bytes,
            "peak_rss_bytes": peak_rss_bytes(),
            lod_name: lod_value,
        });
        println!("{figures}");
    } else {
        println!(
            "{}x{} depth image, {} grid vertices, {} segmented full-resolution triangles, built in {:.2} ms",
            depth.width, depth.height, stats.grid_vertices, stats.segmented_triangles, stats.build_ms
        );
        println!(
            "{lod_name} {lod_value}: {} vertices, {} triangles in {} strips ({} indices, {:.3} per triangle), extracted in {:.2} ms",
            mesh.vertices.len(),
            mesh.triangles.len(),
            mesh.strip_count(),
            mesh.strips.len(),
            mesh.strips.len() as f64 / mesh.triangles.len().max(1) as f64,
            mesh.extract_ms
        );
        if let Some(p) = &a.ply {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}

fn run_demo(size: u32, ply: Option<&Path>) -> Result<()> {
    if !(2..=8193).contains(&size) {
        bail!("demo size is {size}; it must be between 2 and 8193");
    }
    let (depth, camera) = dmesh::synthetic::terrain_with_boxes(size, size);
    let hierarchy = DepthMesh::build(&depth, &camera, &Segmentation::default())?;
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
        write_ply(p, &hierarchy.extract(Lod::Epsilon(0.01))?, &camera, None)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// Stores the simulated demo scene's reference views as scene `demo`, unless present.
fn ingest_demo(store: &dyn dmesh::store::ViewStore) -> Result<()> {
    use dmesh::store::{SegmentationSpec, StoredView};
    let scene = dmesh::sim::SceneSpec::demo();
    let existing = store.views("demo")?.unwrap_or_default();
    let views = scene.reference_views()?;
    for (k, v) in views.iter().enumerate() {
        let name = format!("v{k:02}");
        if existing.contains(&name) {
            continue;
        }
        let img =
            image::RgbImage::from_raw(v.color.width, v.color.height, v.color.rgb.clone()).context("demo colour")?;
        let mut color = Vec::new();
        image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut color), image::ImageFormat::Png)?;
        let stored = StoredView {
            camera: (&v.camera).into(),
            segmentation: SegmentationSpec::default(),
            z: v.depth.z.clone(),
            raw_grid: None,
            color,
        };
        store.put("demo", &name, &stored)?;
    }
    eprintln!("demo scene: {} simulated views in scene \"demo\"", views.len());
    eprintln!(
        "render a novel view: cargo run --release -p dmesh-client -- render --scene demo \\\n  --camera examples/cameras/demo-novel.json --out novel.png --coverage-out coverage.png"
    );
    Ok(())
}

fn run_serve(a: &ServeArgs) -> Result<()> {
    use dmesh::http::{serve, AppState, Pipeline, Settings};
    use dmesh::store::{FileStore, ObjectViewStore, ViewStore};
    let store: std::sync::Arc<dyn ViewStore> = match &a.store {
        Some(url) => {
            std::sync::Arc::new(ObjectViewStore::from_url(url).with_context(|| format!("object store {url}"))?)
        }
        None => std::sync::Arc::new(
            FileStore::open(&a.data).with_context(|| format!("data directory {}", a.data.display()))?,
        ),
    };
    let settings = Settings {
        max_upload_bytes: a.max_upload_bytes,
        limits: Limits {
            max_pixels: a.max_pixels,
        },
        cache_bytes: a.cache_bytes,
        revalidate: std::time::Duration::from_millis(a.revalidate_ms),
    };
    if a.demo {
        ingest_demo(store.as_ref())?;
    }
    let state = std::sync::Arc::new(AppState::new(store, settings));
    let defaults = Pipeline::default();
    let pipeline = Pipeline {
        max_concurrency: a.max_concurrency.unwrap_or(defaults.max_concurrency),
        max_uploads: a.max_uploads.unwrap_or(defaults.max_uploads),
        queue_wait: std::time::Duration::from_millis(a.queue_wait_ms),
        timeout: std::time::Duration::from_secs(a.timeout_secs),
    };
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    runtime
        .block_on(serve(a.listen, state, pipeline))
        .with_context(|| format!("serving on {}", a.listen))
}

fn main() -> ExitCode {
    let cli = match dmesh::cli::parse::<Cli>() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    dmesh::cli::finish(match &cli.command {
        Command::Mesh(a) => run_mesh(a),
        Command::Demo { size, ply } => run_demo(*size, ply.as_deref()),
        Command::Serve(a) => run_serve(a),
    })
}
