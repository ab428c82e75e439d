//! Verlani et al.'s experiments on their own terms (issue 29, part 3), on
//! the simulated demo scene (16 references of 256 x 192, 8 novel views
//! around it, exact ground truth):
//!
//! - Table 2: compression ratio against the zipped 16-bit depth maps, and
//!   PSNR, per depth bit-plane of the compact stream (protocol 6);
//! - Table 1: JPEG on 8-bit depth maps, quality 10-100, and the stream at
//!   the same bytes;
//! - Fig. 5: PSNR against the angle of the novel view between two
//!   references 70 degrees apart, with and without depth noise;
//! - Table 3: quality levels (references, tolerance, bit-planes) in bytes
//!   and PSNR;
//! - the `exp(-k theta)` weight beside `cos^k`.
//!
//! Every PSNR is over the pixels every row of its table covers (the common
//! mask) and valid in the truth, with each row's own coverage beside it; no
//! gap filling. "Zipped" is deflate (zlib, level 6) as Verlani zips.
//! Prints Markdown for `docs/papers.md`; writes the plot of Fig. 5 to the
//! path given (`.png` and `.svg`).
//!
//! Usage: `cargo run --release -p dmesh-client --example papers_verlani -- [--quick] PLOT_BASE`.
//! `--quick` runs every table on a few settings, for the test that keeps
//! this example from rotting; its figures mean little.

use std::io::Write;

use anyhow::Result;
use dmesh_client::blend::{blend, BlendOptions, Blended, Texture, ViewInput};
use dmesh_client::report::cases::{self, Case};
use dmesh_client::report::plot::Chart;
use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Lod, Mesh};
use dmesh_engine::render_plan;
use dmesh_engine::scene::Weighted;
use dmesh_engine::wire_compact::{mesh_stream, strip_response};
use dmesh_proto::StripResponse;

/// `--quick`: a few settings of everything.
static QUICK: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn quick() -> bool {
    QUICK.load(std::sync::atomic::Ordering::Relaxed)
}

/// `full` normally, `short` when quick.
fn pick<T: Clone>(full: &[T], short: &[T]) -> Vec<T> {
    if quick() { short } else { full }.to_vec()
}

/// Deflated size (zlib, level 6), as a zip file holds it.
fn zipped(bytes: &[u8]) -> usize {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    let _ = e.write_all(bytes);
    e.finish().map_or(usize::MAX, |v| v.len())
}

/// A depth map as `bits`-bit samples over its range (0: invalid), and the
/// range.
fn quantise(z: &[f32], bits: u32) -> (Vec<u16>, f32, f32) {
    let valid = z.iter().copied().filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = valid.fold((f32::INFINITY, 0f32), |(a, b), v| (a.min(v), b.max(v)));
    let top = f64::from((1u32 << bits) - 2);
    let span = f64::from((hi - lo).max(f32::MIN_POSITIVE));
    let q = z
        .iter()
        .map(|&v| {
            if v.is_finite() && v > 0.0 {
                1 + (f64::from(v - lo) / span * top).round() as u16
            } else {
                0
            }
        })
        .collect();
    (q, lo, hi)
}

/// Zipped bytes of a depth map quantised to `bits` (8 or 16) bits.
fn zipped_depth(z: &[f32], bits: u32) -> usize {
    let (q, _, _) = quantise(z, bits);
    let bytes: Vec<u8> = if bits <= 8 {
        q.iter().map(|&v| v as u8).collect()
    } else {
        q.iter().flat_map(|v| v.to_le_bytes()).collect()
    };
    zipped(&bytes)
}

/// The scene, its hierarchies and each novel view's selection.
struct Scene {
    case: Case,
    hierarchies: Vec<Hierarchy>,
    selections: Vec<Vec<Weighted>>,
}

impl Scene {
    fn new(case: Case, max_views: Option<u32>) -> Result<Self> {
        let hierarchies = case
            .references
            .iter()
            .map(|r| Hierarchy::build(&r.depth, &r.camera, &Default::default()))
            .collect::<Result<Vec<_>, _>>()?;
        let cameras: Vec<Camera> = case.references.iter().map(|r| r.camera).collect();
        let selections = case
            .novels
            .iter()
            .map(|n| render_plan::select(&n.camera, &cameras, dmesh_proto::Selection::Dmesh, max_views, None))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            case,
            hierarchies,
            selections,
        })
    }
}

/// How a reference's mesh is extracted for a novel view.
#[derive(Clone, Copy)]
enum Detail {
    /// Lossless: epsilon 0.
    Exact,
    /// View-dependent at tau pixels.
    Tau(f64),
}

fn extract(h: &Hierarchy, detail: Detail, novel: &Camera) -> Result<Mesh> {
    Ok(match detail {
        Detail::Exact => h.extract(Lod::Epsilon(0.0))?,
        Detail::Tau(tau) => h.extract(Lod::Tau { tau, view: novel })?,
    })
}

/// One novel view through the compact stream: the zipped bytes of its
/// selected views' streams and what the client decodes from them.
fn streamed(
    h: &Hierarchy,
    camera: &Camera,
    mesh: &Mesh,
    planes: Option<u8>,
    novel: &Camera,
) -> Result<(Vec<u8>, StripResponse)> {
    let s = mesh_stream(mesh, h.grid(), "demo", "v", camera, None, planes, String::new())?;
    let body = dmesh_proto::to_bincode(&s)?;
    Ok((body, strip_response(&s, Some(novel))?))
}

/// A blend without gap filling, optionally with an angular weight.
fn blended(novel: &Camera, views: &[(f64, StripResponse, &Texture)], options: BlendOptions) -> Result<Blended> {
    let inputs = ViewInput::of_responses(views);
    blend(
        novel,
        &inputs,
        &BlendOptions {
            fill_gaps: 0,
            ..options
        },
    )
}

/// Every novel view of `scene` through the stream at `detail` and
/// `planes`: the blends and the zipped bytes per novel view.
fn through_stream(
    scene: &Scene,
    detail: Detail,
    planes: Option<u8>,
    options: BlendOptions,
) -> Result<(Vec<Blended>, f64)> {
    let (mut out, mut bytes) = (Vec::new(), 0usize);
    for (novel, selected) in scene.case.novels.iter().zip(&scene.selections) {
        let (mut body, mut views) = (Vec::new(), Vec::new());
        for w in selected {
            let (h, r) = (&scene.hierarchies[w.index], &scene.case.references[w.index]);
            let mesh = extract(h, detail, &novel.camera)?;
            let (b, strips) = streamed(h, &r.camera, &mesh, planes, &novel.camera)?;
            body.extend_from_slice(&b);
            views.push((w.weight, strips, &r.texture));
        }
        bytes += zipped(&body);
        out.push(blended(&novel.camera, &views, options)?);
    }
    Ok((out, bytes as f64 / scene.case.novels.len() as f64))
}

/// PSNR (dB) of each row over the pixels every row covers and the truth
/// holds (the common mask), and each row's coverage of the image.
fn scores(case: &Case, rows: &[Vec<Blended>]) -> Vec<(f64, f64)> {
    let mut se = vec![(0f64, 0usize); rows.len()];
    let mut cover = vec![0f64; rows.len()];
    for (k, novel) in case.novels.iter().enumerate() {
        let n = novel.depth.len();
        for i in 0..n {
            let truth = novel.depth[i] > 0.0;
            let common = truth && rows.iter().all(|r| r[k].depth[i] > 0.0);
            for (j, r) in rows.iter().enumerate() {
                if r[k].depth[i] > 0.0 {
                    cover[j] += 1.0 / n as f64;
                }
                if common {
                    let e: f64 = (0..3)
                        .map(|c| (f64::from(r[k].rgb[3 * i + c]) - f64::from(novel.rgb[3 * i + c])).powi(2))
                        .sum::<f64>()
                        / 3.0;
                    se[j] = (se[j].0 + e, se[j].1 + 1);
                }
            }
        }
    }
    let novels = case.novels.len().max(1) as f64;
    se.iter()
        .zip(&cover)
        .map(|(&(e, count), c)| {
            let mse = e / count.max(1) as f64;
            (10.0 * (255.0f64 * 255.0 / mse.max(1e-12)).log10(), 100.0 * c / novels)
        })
        .collect()
}

/// Table 2: the stream per bit-plane.
fn table2(scene: &Scene) -> Result<()> {
    println!("### Table 2: compression ratio and PSNR per bit-plane\n");
    println!(
        "Each novel view receives the compact stream (protocol 6) of the references the DMesh rule selects, zipped; the ratio is the zipped 16-bit depth maps of those references (16 bits over each map's range) over it, as Verlani computes it. \
         Verlani sends a 1030-triangle proxy and the residues' bit planes of the whole depth map; dmesh sends the restricted quadtree's mesh and its vertices' depth planes (the coarsest vertices' planes first). \
         Lossless meshes (epsilon 0) and view-dependent ones (tau = 1 px). PSNR over the common mask of each mesh's rows.\n"
    );
    let novels = &scene.case.novels;
    let reference_bytes: f64 = scene
        .selections
        .iter()
        .map(|sel| {
            sel.iter()
                .map(|w| zipped_depth(&scene.case.references[w.index].depth.z, 16))
                .sum::<usize>() as f64
        })
        .sum::<f64>()
        / novels.len() as f64;
    let planes: Vec<Option<u8>> = pick(&[0u8, 1, 2, 3, 4, 6, 8, 10, 12, 14, 16], &[0, 8])
        .into_iter()
        .map(Some)
        .chain([None])
        .collect();
    println!("| bit-planes | CR, epsilon 0 | PSNR dB | CR, tau 1 px | PSNR dB |");
    println!("|---|---|---|---|---|");
    let mut columns = Vec::new();
    for detail in [Detail::Exact, Detail::Tau(1.0)] {
        let mut rows = Vec::new();
        let mut bytes = Vec::new();
        for &p in &planes {
            let (b, n) = through_stream(scene, detail, p, BlendOptions::default())?;
            rows.push(b);
            bytes.push(n);
        }
        columns.push((bytes, scores(&scene.case, &rows)));
    }
    for (k, p) in planes.iter().enumerate() {
        let name = p.map_or("all".to_string(), |p| p.to_string());
        let cell = |c: usize| {
            let (bytes, s) = &columns[c];
            format!("{:.2} | {:.2}", reference_bytes / bytes[k], s[k].0)
        };
        println!("| {name} | {} | {} |", cell(0), cell(1));
    }
    let cover = |c: usize| {
        let v = columns[c].1.iter().map(|s| s.1);
        let (lo, hi) = v.fold((f64::INFINITY, 0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
        format!("{lo:.1}-{hi:.1} %")
    };
    println!(
        "\nZipped 16-bit depth maps of the selected references: {:.0} bytes per novel view on average. Coverage {} (epsilon 0) and {} (tau 1 px) over the plane counts.\n",
        reference_bytes,
        cover(0),
        cover(1)
    );
    Ok(())
}

/// A depth map through 8-bit JPEG at `quality` and back.
fn jpeg_depth(depth: &DepthImage, quality: u8) -> Result<(DepthImage, usize)> {
    let (q, lo, hi) = quantise(&depth.z, 8);
    let gray: Vec<u8> = q.iter().map(|&v| v as u8).collect();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, quality).encode(
        &gray,
        depth.width,
        depth.height,
        image::ExtendedColorType::L8,
    )?;
    let back = image::load_from_memory(&jpeg)?.to_luma8();
    let span = hi - lo;
    let z = back
        .as_raw()
        .iter()
        .map(|&v| {
            // 0 was invalid; JPEG's ringing makes it 0-2.
            if v < 3 {
                0.0
            } else {
                lo + f32::from(v - 1) / 254.0 * span
            }
        })
        .collect();
    Ok((DepthImage::from_z(depth.width, depth.height, z)?, jpeg.len()))
}

/// Table 1: JPEG on depth maps, and the stream at the same bytes.
fn table1(scene: &Scene) -> Result<()> {
    println!("### Table 1: JPEG on depth maps, and the stream at the same bytes\n");
    println!(
        "Every reference's depth as 8 bits over its range, JPEG-coded at each quality; the ratio is the zipped 8-bit maps over the JPEG files, over all 16 references, as Verlani computes it. \
         The decoded maps are meshed losslessly (epsilon 0) and blended into the 8 novel views. \
         Beside it, the stream at the same bytes per novel view: for all depth planes, 8 and 4, the finest view-dependent mesh (tau up to 64 px) whose zipped stream of the selected references is no larger than their JPEG files; the best of the three. \
         PSNR over the pixels both settings of the row and the truth cover.\n"
    );
    let refs = &scene.case.references;
    let zipped8: usize = refs.iter().map(|r| zipped_depth(&r.depth.z, 8)).sum();
    println!("| JPEG quality | CR | PSNR dB | JPEG bytes per novel view | stream tau px | stream planes | stream bytes | stream PSNR dB |");
    println!("|---|---|---|---|---|---|---|---|");
    for quality in pick(&[10u8, 20, 30, 40, 50, 60, 70, 80, 90, 100], &[50]) {
        let mut decoded = Vec::new();
        let mut jpeg_bytes = Vec::new();
        for r in refs {
            let (d, n) = jpeg_depth(&r.depth, quality)?;
            decoded.push(Hierarchy::build(&d, &r.camera, &Default::default())?);
            jpeg_bytes.push(n);
        }
        let mut jpeg_rows = Vec::new();
        let mut target = Vec::new();
        for (novel, selected) in scene.case.novels.iter().zip(&scene.selections) {
            let mut views = Vec::new();
            let mut bytes = 0;
            for w in selected {
                let r = &refs[w.index];
                let m = decoded[w.index].extract(Lod::Epsilon(0.0))?;
                let (_, strips) = streamed(&decoded[w.index], &r.camera, &m, None, &novel.camera)?;
                views.push((w.weight, strips, &r.texture));
                bytes += jpeg_bytes[w.index];
            }
            target.push(bytes);
            jpeg_rows.push(blended(&novel.camera, &views, BlendOptions::default())?);
        }
        // Per plane count (all, 8, 4), the stream's finest tau whose mean
        // bytes are at most the JPEG's, by bisection on log tau; the best
        // PSNR of the three.
        let mean_target = target.iter().sum::<usize>() as f64 / target.len() as f64;
        // tau, planes, bytes, the blends, PSNR.
        type Fit = (f64, Option<u8>, f64, Vec<Blended>, f64);
        let mut best: Option<Fit> = None;
        for planes in pick(&[None, Some(8u8), Some(4)], &[Some(8)]) {
            let (mut lo, mut hi) = (0.05f64.ln(), 64f64.ln());
            let mut fit = None;
            for _ in 0..if quick() { 3 } else { 9 } {
                let mid = 0.5 * (lo + hi);
                let (rows, bytes) = through_stream(scene, Detail::Tau(mid.exp()), planes, BlendOptions::default())?;
                if bytes <= mean_target {
                    fit = Some((mid.exp(), bytes, rows));
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            if let Some((tau, bytes, rows)) = fit {
                let psnr = scores(&scene.case, &[jpeg_rows.clone(), rows.clone()])[1].0;
                if best.as_ref().is_none_or(|b| psnr > b.4) {
                    best = Some((tau, planes, bytes, rows, psnr));
                }
            }
        }
        let total_jpeg: usize = jpeg_bytes.iter().sum();
        let Some((tau, planes, bytes, rows, _)) = best else {
            println!(
                "| {quality} | {:.2} | {:.2} | {mean_target:.0} | - | - | - | the coarsest stream is larger |",
                zipped8 as f64 / total_jpeg as f64,
                scores(&scene.case, &[jpeg_rows])[0].0
            );
            continue;
        };
        let s = scores(&scene.case, &[jpeg_rows, rows]);
        println!(
            "| {quality} | {:.2} | {:.2} | {mean_target:.0} | {tau:.2} | {} | {bytes:.0} | {:.2} |",
            zipped8 as f64 / total_jpeg as f64,
            s[0].0,
            planes.map_or("all".into(), |p| p.to_string()),
            s[1].0
        );
    }
    println!();
    Ok(())
}

/// Fig. 5: PSNR against the angle from one reference to another 70 degrees
/// away, with and without depth noise.
fn fig5(plot: &std::path::Path) -> Result<()> {
    use dmesh_engine::sim::{render_view, rig, SceneSpec};
    use glam::DVec3;
    println!("### Fig. 5: locality\n");
    println!(
        "Two references of the demo scene 70 degrees apart on a circle of radius 3.3 m at 1.8 m height, looking at (0, 0.4, 0); novel views every 2 degrees from the first to the second, blended from both (DMesh's positional weights, lossless meshes, no gap filling), against the exact ground truth. \
         Depth noise is the simulator's Gaussian noise (standard deviation in metres). PSNR over the pixels the truth and the blend cover; the plot is `docs/papers/verlani-fig5.png`.\n"
    );
    let base = SceneSpec::demo();
    let target = DVec3::new(0.0, 0.4, 0.0);
    let at = |deg: f64| -> Result<Camera> {
        let a = deg.to_radians();
        let eye = DVec3::new(3.3 * a.sin(), 1.8, 3.3 * a.cos());
        Ok(rig::camera(base.width, base.height, base.fov_deg, eye, target)?)
    };
    let refs = [at(0.0)?, at(70.0)?];
    let mut series = Vec::new();
    // The table's columns: every 10 degrees (the ends only when quick).
    let columns = pick(&[0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0], &[0.0, 70.0]);
    let heads: Vec<String> = columns.iter().map(|d| format!("{d:.0}")).collect();
    println!(
        "| noise | PSNR dB at {} degrees | lowest | largest difference from no noise |",
        heads.join(" | ")
    );
    println!("|---|{}---|---|", "---|".repeat(columns.len()));
    for noise in pick(&[None, Some(0.003), Some(0.01), Some(0.03)], &[None, Some(0.01)]) {
        let mut spec = base.clone();
        spec.effects.noise = noise;
        let mut views = Vec::new();
        for (k, cam) in refs.iter().enumerate() {
            let v = render_view(&spec, cam, true, k as u64)?;
            let h = Hierarchy::build(&v.depth, cam, &Default::default())?;
            let texture = Texture {
                width: v.color.width,
                height: v.color.height,
                rgb: v.color.rgb,
            };
            views.push((h, texture));
        }
        let mut points = Vec::new();
        let every = if quick() { 35 } else { 1 };
        for step in (0..=35).step_by(every) {
            let deg = 2.0 * f64::from(step);
            let novel = at(deg)?;
            let truth = base.ground_truth(&novel)?;
            let selected = render_plan::select(&novel, &refs, dmesh_proto::Selection::Dmesh, Some(2), None)?;
            let mut inputs = Vec::new();
            for w in &selected {
                let (h, texture) = &views[w.index];
                let m = h.extract(Lod::Epsilon(0.0))?;
                let (_, strips) = streamed(h, &refs[w.index], &m, None, &novel)?;
                inputs.push((w.weight, strips, texture));
            }
            let b = blended(&novel, &inputs, BlendOptions::default())?;
            let (mut se, mut count) = (0f64, 0usize);
            for i in 0..truth.depth.z.len() {
                if truth.depth.z[i] > 0.0 && b.depth[i] > 0.0 {
                    se += (0..3)
                        .map(|c| (f64::from(b.rgb[3 * i + c]) - f64::from(truth.color.rgb[3 * i + c])).powi(2))
                        .sum::<f64>()
                        / 3.0;
                    count += 1;
                }
            }
            points.push((deg, 10.0 * (255.0f64 * 255.0 / (se / count.max(1) as f64)).log10()));
        }
        let name = noise.map_or("none".to_string(), |n| format!("{:.0} mm", n * 1e3));
        let at_angle = |deg: f64| points.iter().find(|p| p.0 == deg).map_or(f64::NAN, |p| p.1);
        let lowest = points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let exact: &[(f64, f64)] = series
            .first()
            .map_or(&points[..], |(_, p): &(String, Vec<(f64, f64)>)| &p[..]);
        let apart = points
            .iter()
            .zip(exact)
            .map(|(a, b)| (a.1 - b.1).abs())
            .fold(0f64, f64::max);
        println!(
            "| {name} | {} | {lowest:.2} | {apart:.2} |",
            columns
                .iter()
                .map(|&d| format!("{:.2}", at_angle(d)))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        series.push((format!("noise {name}"), points));
    }
    Chart {
        title: "Verlani Fig. 5: PSNR between two references 70 degrees apart",
        x_label: "angle from the first reference (degrees)",
        y_label: "PSNR (dB)",
        series,
        linear_x: true,
        log_y: false,
        legend: plotters::prelude::SeriesLabelPosition::LowerRight,
    }
    .write(plot)?;
    println!();
    Ok(())
}

/// Table 3: quality levels in bytes and PSNR.
fn table3(scene: &Scene) -> Result<()> {
    println!("### Table 3: quality levels\n");
    println!(
        "What a client receives per novel view (zipped compact stream) and the PSNR of its blend, for the number of references (all 16 of the rig, or every second or fourth), the tolerance and the depth planes; the ratio is against the zipped 8-bit depth maps of the references in use, as Verlani's Table 3. PSNR over the pixels every row covers.\n"
    );
    let mut rows = Vec::new();
    let mut labels = Vec::new();
    let levels = [
        (1usize, Detail::Exact, None),
        (1, Detail::Tau(1.0), None),
        (1, Detail::Tau(1.0), Some(8u8)),
        (1, Detail::Tau(4.0), Some(8)),
        (1, Detail::Tau(4.0), Some(4)),
        (1, Detail::Tau(16.0), Some(0)),
        (2, Detail::Tau(1.0), None),
        (2, Detail::Tau(4.0), Some(8)),
        (4, Detail::Tau(1.0), None),
        (4, Detail::Tau(4.0), Some(8)),
    ];
    for (every, detail, planes) in pick(&levels, &levels[8..10]) {
        let mut case = scene.case.clone();
        case.references = case.references.into_iter().step_by(every).collect();
        let kept: Vec<usize> = (0..scene.case.references.len()).step_by(every).collect();
        let sub = Scene {
            hierarchies: kept.iter().map(|&k| scene.hierarchies[k].clone()).collect(),
            selections: {
                let cameras: Vec<Camera> = case.references.iter().map(|r| r.camera).collect();
                case.novels
                    .iter()
                    .map(|n| render_plan::select(&n.camera, &cameras, dmesh_proto::Selection::Dmesh, None, None))
                    .collect::<Result<Vec<_>, _>>()?
            },
            case,
        };
        let (b, bytes) = through_stream(&sub, detail, planes, BlendOptions::default())?;
        let zipped8: f64 = sub
            .selections
            .iter()
            .map(|sel| {
                sel.iter()
                    .map(|w| zipped_depth(&sub.case.references[w.index].depth.z, 8))
                    .sum::<usize>() as f64
            })
            .sum::<f64>()
            / sub.case.novels.len() as f64;
        labels.push((sub.case.references.len(), detail, planes, bytes, zipped8 / bytes));
        rows.push(b);
    }
    let s = scores(&scene.case, &rows);
    println!("| references | tolerance | depth planes | bytes per novel view | CR | PSNR dB | coverage |");
    println!("|---|---|---|---|---|---|---|");
    for ((n, detail, planes, bytes, cr), (psnr, cover)) in labels.iter().zip(&s) {
        let tol = match detail {
            Detail::Exact => "epsilon 0".to_string(),
            Detail::Tau(t) => format!("tau {t} px"),
        };
        let planes = planes.map_or("all".to_string(), |p| p.to_string());
        println!("| {n} | {tol} | {planes} | {bytes:.0} | {cr:.2} | {psnr:.2} | {cover:.1} % |");
    }
    println!();
    Ok(())
}

/// The angular weights: none, cos^k and exp(-k theta).
fn weights(scene: &Scene) -> Result<()> {
    println!("### The angular weights: cos^k against exp(-k theta)\n");
    println!(
        "The 8 novel views from the references the DMesh rule selects, lossless meshes, blended with each per-pixel weight on top of DMesh's (view weight times rho); theta is the angle at the surface point between the rays to the reference and to the novel eye. PSNR over the common mask.\n"
    );
    let settings: Vec<(String, BlendOptions)> = vec![
        ("none".into(), BlendOptions::default()),
        (
            "cos^4".into(),
            BlendOptions {
                cos_k: Some(4.0),
                ..Default::default()
            },
        ),
        (
            "cos^16".into(),
            BlendOptions {
                cos_k: Some(16.0),
                ..Default::default()
            },
        ),
        (
            "exp(-2 theta)".into(),
            BlendOptions {
                exp_k: Some(2.0),
                ..Default::default()
            },
        ),
        (
            "exp(-8 theta)".into(),
            BlendOptions {
                exp_k: Some(8.0),
                ..Default::default()
            },
        ),
        (
            "exp(-32 theta)".into(),
            BlendOptions {
                exp_k: Some(32.0),
                ..Default::default()
            },
        ),
    ];
    let settings = pick(&settings, &settings[..2]);
    let mut rows = Vec::new();
    for (_, options) in &settings {
        rows.push(through_stream(scene, Detail::Exact, None, *options)?.0);
    }
    let s = scores(&scene.case, &rows);
    println!("| weight | PSNR dB |");
    println!("|---|---|");
    for ((name, _), (psnr, _)) in settings.iter().zip(&s) {
        println!("| {name} | {psnr:.2} |");
    }
    println!();
    Ok(())
}

fn main() -> Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(k) = args.iter().position(|a| a == "--quick") {
        args.remove(k);
        QUICK.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    let plot = std::path::PathBuf::from(
        args.first()
            .cloned()
            .unwrap_or_else(|| "docs/papers/verlani-fig5".into()),
    );
    if let Some(dir) = plot.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let scene = Scene::new(cases::simulated("demo", false, if quick() { 2 } else { 8 })?, None)?;
    table2(&scene)?;
    table1(&scene)?;
    fig5(&plot)?;
    table3(&scene)?;
    weights(&scene)?;
    Ok(())
}
