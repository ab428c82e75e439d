//! The meshes of the stream comparison (`engine/benches/peer/stream.sh`): each case
//! is extracted as the server extracts it, with outlines refined (the
//! compact stream without cuts: protocol 6's mesh, `p6_*`) and cut
//! (protocol 7 as served, `p7_*`), encoded at 8, 10 and 12 planes and all
//! of them, and as protocol 5 bincode, and coded as the
//! server's content coding codes it (zstd 3, brotli 4, gzip 6: tower-http's
//! defaults). Prints one JSON line per case and plane count, with the body
//! broken into connectivity, depths and the rest, the Rust decode time per
//! 100,000 triangles, and the source depth map coded losslessly (16-bit PNG,
//! zstd of its samples, zlib of them: Verlani's "zipped depth map"). Writes
//! each mesh (camera-frame positions and triangles) for the peers' encoders.
//!
//! Usage: `cargo run --release -p dmesh-client --example stream_table -- DATA_DIR OUT_DIR`

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use dmesh_client::report::cases::{middlebury, simulated};
use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Mesh, Outlines, Segmentation};
use dmesh_engine::render_plan::{self, Ask};
use dmesh_engine::wire::{strip_response, DepthCoding};
use dmesh_engine::wire_compact::{mesh_stream, render_response};
use dmesh_proto::compact::{CompactView, MeshBody, MeshStream, RenderStream};
use dmesh_proto::{RawGrid, RenderResponse, RenderedView, Timings};

/// One reference view of a case and its extracted mesh.
struct Part {
    name: String,
    camera: Camera,
    depth: DepthImage,
    hierarchy: Hierarchy,
    raw_grid: Option<RawGrid>,
    /// Outlines refined.
    mesh: Mesh,
    /// Outlines cut.
    cut: Mesh,
    weight: f64,
}

/// A row of the table: a scene at a tolerance, one view or a render's views.
struct Case {
    name: String,
    parts: Vec<Part>,
    /// The novel camera of a render (its views' reach refers to it).
    novel: Option<Camera>,
}

/// The timings of a render body built here, not served.
const NO_TIMINGS: Timings = Timings {
    select_ms: 0.0,
    extract_ms: 0.0,
    total_ms: 0.0,
};

/// Where a view's colour would be served.
fn color_url(p: &Part) -> String {
    format!("/v1/scenes/s/views/{}/color", p.name)
}

fn zstd(b: &[u8]) -> usize {
    zstd::bulk::compress(b, 3).map_or(usize::MAX, |v| v.len())
}

fn zstd_max(b: &[u8]) -> usize {
    zstd::bulk::compress(b, 19).map_or(usize::MAX, |v| v.len())
}

fn gzip(b: &[u8]) -> usize {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::new(6));
    let _ = e.write_all(b);
    e.finish().map_or(usize::MAX, |v| v.len())
}

fn zlib_best(b: &[u8]) -> usize {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    let _ = e.write_all(b);
    e.finish().map_or(usize::MAX, |v| v.len())
}

fn br(b: &[u8]) -> usize {
    let mut out = Vec::new();
    let params = brotli::enc::BrotliEncoderParams {
        quality: 4,
        ..Default::default()
    };
    match brotli::BrotliCompress(&mut &b[..], &mut out, &params) {
        Ok(_) => out.len(),
        Err(_) => usize::MAX,
    }
}

fn part(
    name: &str,
    camera: Camera,
    depth: DepthImage,
    raw_grid: Option<RawGrid>,
    ask: &Ask,
    weight: f64,
) -> Result<Part> {
    let hierarchy = Hierarchy::build(&depth, &camera, &Segmentation::default())?;
    let (mesh, _) = render_plan::extract_mesh(&hierarchy, ask, Outlines::Kept, |ms| ms * 1e4)?;
    let (cut, _) = render_plan::extract_mesh(&hierarchy, ask, Outlines::Cut, |ms| ms * 1e4)?;
    Ok(Part {
        name: name.to_string(),
        camera,
        depth,
        hierarchy,
        raw_grid,
        mesh,
        cut,
        weight,
    })
}

fn cases(data: &Path) -> Result<Vec<Case>> {
    let mut out = Vec::new();
    // The demo novel view at tau = 1: the server's selection of five views.
    let demo = simulated("demo", false, 0)?;
    let novel: Camera =
        dmesh_engine::camera::camera_from_json(&std::fs::read_to_string("examples/cameras/demo-novel.json")?)?;
    let cams: Vec<Camera> = demo.references.iter().map(|r| r.camera).collect();
    let selected = render_plan::select(&novel, &cams, dmesh_proto::Selection::Dmesh, None, None)?;
    let ask = Ask::new(dmesh_proto::Lod::Tau(1.0), Some(novel), None)?;
    let parts = selected
        .iter()
        .map(|w| {
            let r = &demo.references[w.index];
            part(
                &format!("v{:02}", w.index),
                r.camera,
                r.depth.clone(),
                r.raw_grid,
                &ask.share(w.weight),
                w.weight,
            )
        })
        .collect::<Result<Vec<_>>>()?;
    out.push(Case {
        name: "demo tau 1 px".into(),
        parts,
        novel: Some(novel),
    });
    // Middlebury: the left views of Art and Cones at static tolerances.
    for (scene, epsilons) in [("art", &[0.001, 0.005, 0.01, 0.02][..]), ("cones", &[0.005][..])] {
        let case = middlebury(data, scene)?;
        let r = &case.references[0];
        for &e in epsilons {
            let ask = Ask::new(dmesh_proto::Lod::Epsilon(e), None, None)?;
            out.push(Case {
                name: format!("{scene} epsilon {} mm", e * 1e3),
                parts: vec![part(scene, r.camera, r.depth.clone(), r.raw_grid, &ask, 1.0)?],
                novel: None,
            });
        }
    }
    // The 513 x 513 height field of engine/benches/peer/martini.sh at its tolerances.
    let (depth, camera) = dmesh_engine::synthetic::height_field(513);
    for e in [0.5, 2.0, 8.0] {
        let ask = Ask::new(dmesh_proto::Lod::Epsilon(e), None, None)?;
        out.push(Case {
            name: format!("terrain 513 epsilon {e}"),
            parts: vec![part("terrain", camera, depth.clone(), None, &ask, 1.0)?],
            novel: None,
        });
    }
    Ok(out)
}

fn stream(p: &Part, planes: Option<u8>, cut: bool) -> Result<MeshStream> {
    Ok(mesh_stream(
        if cut { &p.cut } else { &p.mesh },
        p.hierarchy.grid(),
        "s",
        &p.name,
        &p.camera,
        p.raw_grid,
        planes,
        String::new(),
    )?)
}

/// The body a client receives for the case: a render's or one view's,
/// outlines cut or not.
fn compact_body(c: &Case, planes: Option<u8>, cut: bool) -> Result<(Vec<u8>, Vec<MeshStream>)> {
    let streams = c
        .parts
        .iter()
        .map(|p| stream(p, planes, cut))
        .collect::<Result<Vec<_>>>()?;
    let body = match c.novel {
        Some(_) => dmesh_proto::to_bincode(&RenderStream {
            version: dmesh_proto::COMPACT_VERSION,
            views: streams
                .iter()
                .zip(&c.parts)
                .map(|(s, p)| CompactView {
                    weight: p.weight,
                    mesh: s.clone(),
                    color_url: color_url(p),
                })
                .collect(),
            timings: NO_TIMINGS,
        })?,
        None => dmesh_proto::to_bincode(&MeshBody::Mesh(Box::new(streams[0].clone())))?,
    };
    Ok((body, streams))
}

fn bincode_body(c: &Case, bits: Option<u8>) -> Result<Vec<u8>> {
    let responses = c
        .parts
        .iter()
        .map(|p| {
            let coding = DepthCoding {
                bits,
                root_side: p.hierarchy.grid().side(),
                raw_grid: p.raw_grid,
            };
            strip_response(&p.mesh, "s", &p.name, &p.camera, coding).map_err(|e| anyhow::anyhow!("{e}"))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(match c.novel {
        Some(_) => dmesh_proto::to_bincode(&RenderResponse {
            version: dmesh_proto::PROTOCOL_VERSION,
            views: responses
                .into_iter()
                .zip(&c.parts)
                .map(|(strips, p)| RenderedView {
                    weight: p.weight,
                    strips,
                    color_url: color_url(p),
                })
                .collect(),
            timings: NO_TIMINGS,
        })?,
        None => dmesh_proto::to_bincode(&responses[0])?,
    })
}

/// The depth maps of a case as 16 bits over each map's range (0: invalid),
/// coded losslessly: PNG, zstd 19 of the samples, zlib (best) of them.
fn depth_sources(c: &Case) -> Result<(usize, usize, usize)> {
    let (mut png, mut zs, mut zl) = (0, 0, 0);
    for p in &c.parts {
        let z = &p.depth.z;
        let valid = z.iter().filter(|v| v.is_finite() && **v > 0.0);
        let (lo, hi) = valid.fold((f32::INFINITY, 0f32), |(a, b), &v| (a.min(v), b.max(v)));
        let span = f64::from((hi - lo).max(f32::MIN_POSITIVE));
        let samples: Vec<u16> = z
            .iter()
            .map(|&v| {
                if v.is_finite() && v > 0.0 {
                    1 + (f64::from(v - lo) / span * 65534.0).round() as u16
                } else {
                    0
                }
            })
            .collect();
        let bytes: Vec<u8> = samples.iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut encoded = Vec::new();
        let img = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(p.depth.width, p.depth.height, samples)
            .context("depth image size")?;
        image::DynamicImage::ImageLuma16(img)
            .write_to(&mut std::io::Cursor::new(&mut encoded), image::ImageFormat::Png)?;
        png += encoded.len();
        zs += zstd_max(&bytes);
        zl += zlib_best(&bytes);
    }
    Ok((png, zs, zl))
}

/// Median milliseconds of decoding `streams` as a client does (mesh,
/// depths, derived normals and rho).
fn decode_ms(streams: &[MeshStream], novel: Option<&Camera>) -> Result<f64> {
    let mut times = Vec::new();
    for _ in 0..9 {
        let t = Instant::now();
        for s in streams {
            dmesh_engine::wire_compact::strip_response(s, novel)?;
        }
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

/// Writes the case's meshes for the peers: camera-frame positions (f32 xyz)
/// and triangles (u32), one pair of files per view.
fn write_peer_files(dir: &Path, k: usize, c: &Case) -> Result<()> {
    for (v, p) in c.parts.iter().enumerate() {
        let pos: Vec<u8> = p
            .mesh
            .vertices
            .iter()
            .flat_map(|x| {
                let q = p
                    .camera
                    .back_project(f64::from(x.i), f64::from(x.j), f64::from(x.depth));
                [q.x as f32, q.y as f32, q.z as f32]
            })
            .flat_map(f32::to_le_bytes)
            .collect();
        let tri: Vec<u8> = p
            .mesh
            .triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        std::fs::write(dir.join(format!("case{k}-view{v}.pos")), pos)?;
        std::fs::write(dir.join(format!("case{k}-view{v}.tri")), tri)?;
    }
    Ok(())
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let data = PathBuf::from(args.next().context("usage: stream_table DATA_DIR OUT_DIR")?);
    let out = PathBuf::from(args.next().context("usage: stream_table DATA_DIR OUT_DIR")?);
    std::fs::create_dir_all(&out)?;
    for (k, c) in cases(&data)?.iter().enumerate() {
        write_peer_files(&out, k, c)?;
        let triangles: usize = c.parts.iter().map(|p| p.mesh.triangles.len()).sum();
        let vertices: usize = c.parts.iter().map(|p| p.mesh.vertices.len()).sum();
        let (png16, zstd16, zlib16) = depth_sources(c)?;
        for planes in [Some(8u8), Some(10), Some(12), None] {
            // What the server spends coding the meshes (median of 5).
            let mut encode = Vec::new();
            for _ in 0..5 {
                let t = Instant::now();
                compact_body(c, planes, false)?;
                encode.push(t.elapsed().as_secs_f64() * 1e3);
            }
            encode.sort_by(f64::total_cmp);
            let encode_ms = encode[2];
            let extract_ms: f64 = c.parts.iter().map(|p| p.mesh.extract_ms).sum();
            let (body, streams) = compact_body(c, planes, false)?;
            let (cut_body, cut_streams) = compact_body(c, planes, true)?;
            let drawn: usize = c.parts.iter().map(|p| p.cut.drawn_triangles()).sum();
            let cuts: usize = c.parts.iter().map(|p| p.cut.cuts.len()).sum();
            let cut_error = cut_streams.iter().map(|s| s.max_error).fold(0f32, f32::max);
            let cut_ms = decode_ms(&cut_streams, c.novel.as_ref())?;
            // The parts on their own, each coded alone (what they cost).
            let field = |f: &dyn Fn(&MeshStream) -> Vec<u8>| -> usize { streams.iter().map(|s| zstd(&f(s))).sum() };
            let connectivity = field(&|s| [s.connectivity.split.clone(), s.connectivity.leaf.clone()].concat());
            let depths = field(&|s| [s.escapes.clone(), s.exact.clone(), s.planes.concat()].concat());
            let reach = field(&|s| {
                s.reach
                    .as_ref()
                    .map_or(Vec::new(), |r| dmesh_proto::to_bincode(r).unwrap_or_default())
            });
            if std::env::var("DEBUG_STREAM").is_ok() && planes == Some(10) {
                for st in &streams {
                    let levels: Vec<(u8, f32)> = st.levels.iter().map(|l| (l.planes, l.step)).collect();
                    let sizes: Vec<usize> = st.planes.iter().map(|p| zstd(p)).collect();
                    eprintln!(
                        "{} exact {} of {} triangles; split {} leaf {} bytes; levels {levels:?}; plane zstd {sizes:?}",
                        c.name,
                        st.exact.len() / 4,
                        st.triangles,
                        zstd(&st.connectivity.split),
                        zstd(&st.connectivity.leaf)
                    );
                }
            }
            let p5 = bincode_body(c, planes)?;
            let max_error = streams.iter().map(|s| s.max_error).fold(0f32, f32::max);
            let ms = decode_ms(&streams, c.novel.as_ref())?;
            // A render's answer decodes as the client blends it.
            if let Some(novel) = &c.novel {
                let r: RenderStream = dmesh_proto::from_bincode(&body)?;
                render_response(&r, novel)?;
            }
            let row = serde_json::json!({
                "case": k, "name": c.name, "views": c.parts.len(),
                "planes": planes.map_or("all".to_string(), |p| p.to_string()),
                "triangles": triangles, "vertices": vertices, "max_error": max_error,
                "p6_raw": body.len(), "p6_zstd": zstd(&body), "p6_br": br(&body), "p6_gzip": gzip(&body),
                "p5_raw": p5.len(), "p5_zstd": zstd(&p5),
                "connectivity_zstd": connectivity, "depths_zstd": depths, "reach_zstd": reach,
                "decode_ms": ms, "decode_ms_per_100k": ms * 1e5 / triangles.max(1) as f64,
                "p7_zstd": zstd(&cut_body), "p7_raw": cut_body.len(), "p7_drawn": drawn, "p7_cuts": cuts,
                "p7_max_error": cut_error, "p7_decode_ms_per_100k": cut_ms * 1e5 / drawn.max(1) as f64,
                "encode_ms": encode_ms, "extract_ms": extract_ms,
                "depth_png16": png16, "depth_zstd16": zstd16, "depth_zlib16": zlib16,
            });
            println!("{row}");
        }
    }
    Ok(())
}
