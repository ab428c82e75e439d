//! `dmesh mesh`: one depth image meshed for a camera; a summary, JSON figures
//! and optionally a binary PLY.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::ArgGroup;
use dmesh_engine::camera::{camera_from_json, Camera};
use dmesh_engine::image::{decode_view, ColorImage, DecodedView, DepthKind, DepthOptions, Limits, ViewFiles};
use dmesh_engine::mesh::segmentation;
use dmesh_engine::mesh::{Hierarchy, Mesh, Outlines, SegmentMethod, SegmentationSpec, StripOrder, Threads};
use dmesh_engine::render_plan::Ask;

#[derive(clap::Args)]
#[command(group(ArgGroup::new("lod").required(true).args(["epsilon", "tau", "max_triangles"])))]
pub struct MeshArgs {
    /// Depth image: OpenEXR (float), PNG (8/16-bit grey) or PFM.
    #[arg(long)]
    depth: PathBuf,
    /// What the depth samples measure.
    #[arg(long, value_parser = dmesh_cli::one_of(&DepthKind::NAMES), default_value = "z")]
    depth_kind: DepthKind,
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
    max_triangles: Option<u32>,
    /// Rubber-sheet test.
    #[arg(long, value_parser = dmesh_cli::one_of(&SegmentMethod::NAMES), default_value = "orthogonality")]
    segment: SegmentMethod,
    /// Orthogonality angle in degrees.
    #[arg(long, default_value_t = segmentation::OMEGA_DEG, allow_negative_numbers = true)]
    omega: f64,
    /// Disparity threshold (Eq. 9).
    #[arg(long, default_value_t = segmentation::SIGMA, allow_negative_numbers = true)]
    sigma: f64,
    /// Connectedness threshold (Eq. 6).
    #[arg(long, default_value_t = segmentation::KAPPA, allow_negative_numbers = true)]
    kappa: f64,
    /// Depth-range gate dz / z (Eq. 11).
    #[arg(long, default_value_t = segmentation::LAMBDA, allow_negative_numbers = true)]
    lambda: f64,
    /// Strip order: the traversal's (fastest), greedy (fewer indices) or
    /// tunnelled (fewest indices, slowest).
    #[arg(long, value_parser = dmesh_cli::one_of(&StripOrder::NAMES), default_value = "traversal")]
    strips: StripOrder,
    /// Drop whole a coarse triangle that a discontinuity crosses, as DMesh
    /// Sec. 5.3 does, instead of refining it down to the segmented cells
    /// (fewer triangles; the foreground's outline erodes by up to the
    /// triangle's size).
    #[arg(long, conflicts_with = "cut_outlines")]
    drop_outlines: bool,
    /// Cut a triangle that a discontinuity crosses along one straight line
    /// into two parts, each within the tolerance, instead of refining it
    /// down to the segmented cells (docs/engine.md "Outlines as cuts").
    /// --max-triangles then counts a cut triangle as the triangles it draws.
    #[arg(long)]
    cut_outlines: bool,
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
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

pub fn write_ply(path: &Path, mesh: &Mesh, camera: &Camera, color: Option<&ColorImage>) -> Result<()> {
    std::fs::write(path, dmesh_engine::ply::encode_ply(mesh, camera, color))
        .with_context(|| format!("cannot write PLY file {}", path.display()))
}

pub fn run(a: &MeshArgs) -> Result<()> {
    let camera = read_camera(&a.camera, "camera")?;
    let limits = Limits {
        max_pixels: a.max_pixels,
    };
    let options = DepthOptions {
        kind: a.depth_kind,
        scale: a.scale,
        offset: a.offset,
        focal_baseline: a.focal_baseline,
        channel: a.channel.clone(),
    };
    let (depth_bytes, mask_bytes, color_bytes) = (
        read(&a.depth, "depth")?,
        a.mask.as_deref().map(|p| read(p, "mask")).transpose()?,
        a.color.as_deref().map(|p| read(p, "colour")).transpose()?,
    );
    let files = ViewFiles {
        depth: &depth_bytes,
        mask: mask_bytes.as_deref(),
        color: color_bytes.as_deref(),
    };
    let DecodedView { depth, color } =
        decode_view(files, &options, &camera, &limits).with_context(|| format!("view {}", a.depth.display()))?;
    // The files' bytes are freed before the build, which then reuses their
    // pages: a fresh process pays for every page it touches first.
    drop((depth_bytes, mask_bytes, color_bytes));
    let seg = SegmentationSpec {
        method: a.segment,
        omega: a.omega,
        sigma: a.sigma,
        kappa: a.kappa,
        lambda: a.lambda,
    }
    .to_engine();
    let threads = if a.threads == 1 {
        Threads::Single
    } else {
        Threads::available()
    };
    let hierarchy = Hierarchy::build_with(&depth, &camera, &seg, threads)?;
    let view = a.view.as_deref().map(|p| read_camera(p, "view camera")).transpose()?;
    // The request as the server states it (one level of detail, with its
    // camera), so the command meshes what a strip request would.
    let wire = dmesh_proto::Lod::exactly_one(a.epsilon, a.tau, a.max_triangles, None).map_err(anyhow::Error::msg)?;
    // --view is for tau and budgets; with --epsilon it is not used.
    let view = view.filter(|_| a.epsilon.is_none());
    let ask = Ask::new(wire, view, None)?;
    let (lod, _) = ask.lod(&hierarchy, |_| 0.0);
    let order = a.strips;
    let outlines = if a.drop_outlines {
        Outlines::Dropped
    } else if a.cut_outlines {
        Outlines::Cut
    } else {
        Outlines::Kept
    };
    let mesh = hierarchy.extract_as(lod, order, outlines)?;
    // The tolerance used (a budget's resolution).
    let (lod_name, lod_value) = match mesh.lod {
        dmesh_proto::Lod::Tau(t) => ("tau", t),
        dmesh_proto::Lod::Epsilon(e) => ("epsilon", e),
        // Not produced: an extraction states the tolerance it used.
        other => bail!("the extraction stated {other:?}"),
    };
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
            "cut_triangles": mesh.cuts.len(),
            "drawn_triangles": mesh.drawn_triangles(),
            "strips": mesh.strip_count(),
            "indices": mesh.strips.len(),
            "segmented_triangles": stats.segmented_triangles,
            "build_ms": stats.build_ms,
            "stages_ms": {
                "depths": stats.stages.depths_ms,
                "normals_and_rho": stats.stages.normals_ms,
                "segmentation": stats.stages.flags_ms,
                "finest_level": stats.stages.finest_ms,
                "coarse_levels": stats.stages.coarse_ms,
                "border": stats.stages.border_ms,
            },
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
        if !mesh.cuts.is_empty() {
            println!(
                "{} cut triangles drawing {} more: {} triangles drawn",
                mesh.cuts.len(),
                mesh.drawn_triangles() - mesh.triangles.len(),
                mesh.drawn_triangles()
            );
        }
        if let Some(p) = &a.ply {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
