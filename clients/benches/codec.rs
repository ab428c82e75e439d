//! The compact stream's coder and Rust decoder per triangle, by stage
//! (issue 60's benchmark): what the server spends per answer beyond the
//! extraction, and what a client spends before it draws.
//!
//! Rows (meshes extracted as the server extracts them, outlines cut, 10
//! depth planes):
//! - `demo tau 1 px`: the demo scene's novel view (`examples/cameras/
//!   demo-novel.json`), the server's five selected references;
//! - `art epsilon 10 mm`: Middlebury Art's left view at 1 cm;
//! - `synthetic 513 tau 1 px`: the throughput bench's served scene, one
//!   513 x 513 view from the first camera of its orbit.
//!
//! Per row, the median over `RUNS` runs (each the whole row, repeated until
//! it takes at least 50 ms) of:
//! - `extract`: the extraction alone, outlines refined and cut (as served);
//! - `first cut extraction`: the first cut extraction of a fresh hierarchy,
//!   which computes the cutting errors (`cut_errors.rs`), the build not
//!   counted: what a live view pays per frame;
//! - `encode`: `wire_compact::mesh_stream`, as a served answer runs it
//!   (connectivity walk, cuts, bit planes, header);
//! - `zstd`: the body's content coding at tower-http's level 3;
//! - `decode`: `MeshStream::decode`, then the derived normals and rho
//!   (`wire_compact::strip_response`, what `dmesh-client` runs).
//!
//! Rates are drawn triangles (a cut triangle's parts) per second, one
//! thread. The encoder's goal is 30 M/s, the decoder's 30 M/s (issue 60);
//! the verdicts are computed here from the medians.
//!
//! Usage: `cargo bench -p dmesh-client --bench codec [-- DATA_DIR [RUNS]]`
//! (a relative DATA_DIR is the repository root's; defaults `../shared/data`, 7 runs). `--profile ROW` instead encodes that
//! row (`demo` or `art`) in a loop for 20 s, for `perf record`; with
//! `PROFILE_EXTRACT=1` it extracts instead, with `PROFILE_DECODE=1` it
//! encodes and decodes, with `PROFILE_FIRST=1` it makes first cut
//! extractions.

mod support;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use dmesh_client::report::cases::{middlebury, simulated};
use dmesh_engine::camera::Camera;
use dmesh_engine::mesh::{Hierarchy, Mesh, Outlines, Segmentation};
use dmesh_engine::render_plan::{self, Ask};
use dmesh_engine::wire_compact::{mesh_stream, strip_response};
use dmesh_proto::compact::{MeshBody, MeshStream};
use dmesh_proto::RawGrid;

/// Depth planes of every row.
const PLANES: u8 = 10;
/// The goal for the coder and the decoder, triangles per second.
const GOAL: f64 = 30e6;

/// One reference of a row, extracted.
struct View {
    camera: Camera,
    depth: dmesh_engine::image::DepthImage,
    ask: Ask,
    hierarchy: Hierarchy,
    raw_grid: Option<RawGrid>,
    mesh: Mesh,
}

impl View {
    fn new(
        camera: Camera,
        depth: &dmesh_engine::image::DepthImage,
        raw_grid: Option<RawGrid>,
        ask: &Ask,
    ) -> Result<Self> {
        let hierarchy = Hierarchy::build(depth, &camera, &Segmentation::default())?;
        let (mesh, _) = render_plan::extract_mesh(&hierarchy, ask, Outlines::Cut, |ms| ms * 1e4)?;
        Ok(Self {
            camera,
            depth: depth.clone(),
            ask: *ask,
            hierarchy,
            raw_grid,
            mesh,
        })
    }

    /// The extraction as served (outlines cut; the cut errors are computed
    /// on the first, before timing).
    fn extract(&self, outlines: Outlines) -> Result<Mesh> {
        Ok(render_plan::extract_mesh(&self.hierarchy, &self.ask, outlines, |ms| ms * 1e4)?.0)
    }

    /// The first cut extraction of a fresh hierarchy, which computes the
    /// cutting errors: seconds, the build not counted.
    fn first_cut(&self) -> Result<f64> {
        let fresh = Hierarchy::build(&self.depth, &self.camera, &Segmentation::default())?;
        let start = Instant::now();
        std::hint::black_box(render_plan::extract_mesh(&fresh, &self.ask, Outlines::Cut, |ms| {
            ms * 1e4
        })?);
        Ok(start.elapsed().as_secs_f64())
    }

    fn encode(&self) -> Result<MeshStream> {
        Ok(mesh_stream(
            &self.mesh,
            self.hierarchy.grid(),
            "s",
            "v",
            &self.camera,
            self.raw_grid,
            Some(PLANES),
            String::new(),
        )?)
    }

    /// Triangles a client draws: whole ones and the cut triangles' parts.
    fn drawn(&self) -> usize {
        self.mesh.triangles.len() + self.mesh.cuts.iter().map(|c| c.drawn()).sum::<usize>()
    }
}

/// A row: its references and the novel camera their reach refers to.
struct Row {
    name: &'static str,
    views: Vec<View>,
    novel: Option<Camera>,
}

fn rows(data: &std::path::Path) -> Result<Vec<Row>> {
    let demo = simulated("demo", false, 0)?;
    let novel: Camera = dmesh_engine::camera::camera_from_json(&std::fs::read_to_string(
        root().join("examples/cameras/demo-novel.json"),
    )?)?;
    let cams: Vec<Camera> = demo.references.iter().map(|r| r.camera).collect();
    let selected = render_plan::select(&novel, &cams, dmesh_proto::Selection::Dmesh, None, None)?;
    let ask = Ask::new(dmesh_proto::Lod::Tau(1.0), Some(novel), None)?;
    let views = selected
        .iter()
        .map(|w| {
            let r = &demo.references[w.index];
            View::new(r.camera, &r.depth, r.raw_grid, &ask.share(w.weight))
        })
        .collect::<Result<Vec<_>>>()?;
    let art = middlebury(data, "art")?;
    let r = &art.references[0];
    let ask = Ask::new(dmesh_proto::Lod::Epsilon(0.01), None, None)?;
    let (depth, camera) = dmesh_engine::synthetic::terrain_with_boxes(513, 513);
    let orbit = support::orbit(&camera, &depth, 32)?;
    let orbit_ask = Ask::new(dmesh_proto::Lod::Tau(1.0), Some(orbit[0]), None)?;
    let served = View::new(camera, &depth, None, &orbit_ask)?;
    Ok(vec![
        Row {
            name: "demo tau 1 px",
            views,
            novel: Some(novel),
        },
        Row {
            name: "art epsilon 10 mm",
            views: vec![View::new(r.camera, &r.depth, r.raw_grid, &ask)?],
            novel: None,
        },
        Row {
            name: "synthetic 513 tau 1 px",
            views: vec![served],
            novel: Some(orbit[0]),
        },
    ])
}

/// The repository's root (benches run in the package's directory).
fn root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

/// Median seconds per call of `f`, each run repeated until it takes 50 ms.
fn time(runs: usize, mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    let mut per_call = Vec::with_capacity(runs);
    for _ in 0..runs {
        let (start, mut calls) = (Instant::now(), 0u32);
        while calls == 0 || start.elapsed().as_secs_f64() < 0.05 {
            f()?;
            calls += 1;
        }
        per_call.push(start.elapsed().as_secs_f64() / f64::from(calls));
    }
    per_call.sort_by(f64::total_cmp);
    Ok(per_call[runs / 2])
}

fn verdict(rate: f64) -> &'static str {
    if rate >= GOAL {
        "met"
    } else {
        "not met"
    }
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    let profile = args
        .iter()
        .position(|a| a == "--profile")
        .map(|k| args.get(k + 1).cloned());
    let rest: Vec<&String> = args
        .iter()
        .enumerate()
        .filter(|(k, _)| {
            profile.is_none()
                || !matches!(args.iter().position(|a| a == "--profile"), Some(p) if *k == p || *k == p + 1)
        })
        .map(|(_, a)| a)
        .collect();
    // Relative to the repository's root, where the bench is usually called.
    let data = root().join(rest.first().map_or("../shared/data", |s| s.as_str()));
    let runs: usize = rest
        .get(1)
        .map_or(Ok(7), |s| s.parse())
        .context("RUNS must be a count")?;
    let rows = rows(&data)?;
    if let Some(which) = profile {
        let which = which.context("--profile needs a row: demo or art")?;
        let row = rows
            .iter()
            .find(|r| r.name.starts_with(which.as_str()))
            .with_context(|| format!("no row {which}"))?;
        let start = Instant::now();
        while start.elapsed().as_secs() < 20 {
            for v in &row.views {
                if std::env::var("PROFILE_FIRST").is_ok() {
                    std::hint::black_box(v.first_cut()?);
                } else if std::env::var("PROFILE_DECODE").is_ok() {
                    std::hint::black_box(strip_response(&v.encode()?, row.novel.as_ref())?);
                } else if std::env::var("PROFILE_EXTRACT").is_ok() {
                    std::hint::black_box(v.extract(Outlines::Cut)?);
                } else {
                    std::hint::black_box(v.encode()?);
                }
            }
        }
        return Ok(());
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!("machine: {cores} cores, {runs} runs, {PLANES} planes, one thread\n");
    println!(
        "| row | drawn triangles | extract ms, outlines refined | extract ms, cut | first cut extraction ms | encode ms | encode M/s | zstd ms | decode ms | decode M/s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut rates = Vec::new();
    for row in &rows {
        let drawn: usize = row.views.iter().map(View::drawn).sum();
        let bodies: Vec<Vec<u8>> = row
            .views
            .iter()
            .map(|v| Ok(dmesh_proto::to_bincode(&MeshBody::Mesh(Box::new(v.encode()?)))?))
            .collect::<Result<_>>()?;
        let streams: Vec<MeshStream> = row.views.iter().map(View::encode).collect::<Result<_>>()?;
        let extract = |outlines: Outlines| {
            time(runs, || {
                for v in &row.views {
                    std::hint::black_box(v.extract(outlines)?);
                }
                Ok(())
            })
        };
        let (refined, cut) = (extract(Outlines::Kept)?, extract(Outlines::Cut)?);
        let mut firsts = (0..runs)
            .map(|_| row.views.iter().map(View::first_cut).sum::<Result<f64>>())
            .collect::<Result<Vec<f64>>>()?;
        firsts.sort_by(f64::total_cmp);
        let first = firsts[runs / 2];
        let encode = time(runs, || {
            for v in &row.views {
                std::hint::black_box(v.encode()?);
            }
            Ok(())
        })?;
        let zstd = time(runs, || {
            for b in &bodies {
                std::hint::black_box(zstd::bulk::compress(b, 3)?);
            }
            Ok(())
        })?;
        let decode = time(runs, || {
            for s in &streams {
                std::hint::black_box(strip_response(s, row.novel.as_ref())?);
            }
            Ok(())
        })?;
        let (enc_rate, dec_rate) = (drawn as f64 / encode, drawn as f64 / decode);
        rates.push((row.name, enc_rate, dec_rate));
        println!(
            "| {} | {drawn} | {:.2} | {:.2} | {:.1} | {:.2} | {:.1} | {:.2} | {:.2} | {:.1} |",
            row.name,
            refined * 1e3,
            cut * 1e3,
            first * 1e3,
            encode * 1e3,
            enc_rate / 1e6,
            zstd * 1e3,
            decode * 1e3,
            dec_rate / 1e6
        );
    }
    println!();
    for (name, enc, dec) in rates {
        println!(
            "- {name}: encoder at least {} M triangles/s: {}; decoder at least {} M/s: {}",
            GOAL / 1e6,
            verdict(enc),
            GOAL / 1e6,
            verdict(dec)
        );
    }
    Ok(())
}
