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
//! - with `--rd RD_BASE` instead, the rate-distortion figure of outlines
//!   cut against refined, JPEG depth and zipped maps (`rd.rs`), alone.
//!
//! Usage: `cargo run --release -p dmesh-client --example papers_verlani -- [--quick] PLOT_BASE`
//! or `... -- [--quick] --rd RD_BASE`.
//! `--quick` runs every table on a few settings, for the test that keeps
//! this example from rotting; its figures mean little.

use anyhow::Result;
use dmesh_client::blend::{BlendOptions, Blended};
use dmesh_client::report::cases;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Lod};

mod fig5;
mod pipeline;
mod rd;
use fig5::fig5;
use pipeline::{blended, pick, quantise, quick, scores, streamed, through_stream, zipped_depth, Detail, Scene, QUICK};

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

/// Every reference's depth through JPEG at `quality`, meshed losslessly
/// (epsilon 0) and blended into each novel view of `scene`: the blends,
/// and each reference's JPEG bytes.
fn jpeg_blends(scene: &Scene, quality: u8) -> Result<(Vec<Blended>, Vec<usize>)> {
    let refs = &scene.case.references;
    let mut decoded = Vec::new();
    let mut sizes = Vec::new();
    for r in refs {
        let (d, n) = jpeg_depth(&r.depth, quality)?;
        decoded.push(Hierarchy::build(&d, &r.camera, &Default::default())?);
        sizes.push(n);
    }
    let mut blends = Vec::new();
    for (novel, selected) in scene.case.novels.iter().zip(&scene.selections) {
        let mut views = Vec::new();
        for w in selected {
            let r = &refs[w.index];
            let m = decoded[w.index].extract(Lod::Epsilon(0.0))?;
            let (_, strips) = streamed(&decoded[w.index], &r.camera, &m, None, &novel.camera)?;
            views.push((w.weight, strips, &r.texture));
        }
        blends.push(blended(&novel.camera, &views, BlendOptions::default())?);
    }
    Ok((blends, sizes))
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
        let (jpeg_rows, jpeg_bytes) = jpeg_blends(scene, quality)?;
        let target: Vec<usize> = scene
            .selections
            .iter()
            .map(|selected| selected.iter().map(|w| jpeg_bytes[w.index]).sum())
            .collect();
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
            selections: case.selections(None)?,
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
    if let Some(k) = args.iter().position(|a| a == "--rd") {
        let base = std::path::PathBuf::from(args.get(k + 1).cloned().unwrap_or_else(|| "docs/stream/rd-demo".into()));
        if let Some(dir) = base.parent() {
            std::fs::create_dir_all(dir)?;
        }
        let scene = Scene::new(cases::simulated("demo", false, if quick() { 2 } else { 8 })?, None)?;
        return rd::rd(&scene, &base);
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
