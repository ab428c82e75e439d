//! Rate and distortion per novel view (issue 59) on the demo scene: PSNR
//! against the bytes a client receives for one novel view, every curve on
//! one common mask:
//!
//! - protocol 7 as served (outlines cut) and protocol 6's meshes (outlines
//!   refined), each at tau 1-64 px and 4, 6, 8 or all depth planes, zipped
//!   as Verlani zips (the stream of the selected references);
//! - JPEG depth maps (8 bits over each map's range, quality 10-100), the
//!   selected references' files, meshed losslessly (epsilon 0) and blended;
//! - the zipped 16-bit depth maps of the selected references, meshed at
//!   full resolution (epsilon 0: per-pixel DIBR with the samples as vertices).
//!
//! A curve is drawn as its upper envelope: a point counts when no cheaper
//! point of its curve scores higher. The verdict compares protocol 7's
//! envelope with every other curve's points within protocol 7's byte range.

use std::path::Path;

use anyhow::Result;
use dmesh_client::blend::{BlendOptions, Blended};
use dmesh_client::report::plot::Chart;
use dmesh_engine::mesh::Outlines;

use super::jpeg_blends;
use super::pipeline::{pick, scores, through_stream_as, zipped_depth, Detail, Scene};

/// One point of a curve: its setting and bytes per novel view.
struct Point {
    curve: usize,
    setting: String,
    bytes: f64,
}

const CURVES: [&str; 4] = [
    "protocol 7 (outlines cut)",
    "protocol 6 (outlines refined)",
    "JPEG depth maps, meshed losslessly",
    "zipped 16-bit depth maps, per pixel",
];

/// The upper envelope of `points` (bytes, PSNR): sorted by bytes, each
/// scoring above every cheaper one.
fn envelope(mut points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    points.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.total_cmp(&a.1)));
    let mut out: Vec<(f64, f64)> = Vec::new();
    for p in points {
        if out.last().is_none_or(|q| p.1 > q.1) {
            out.push(p);
        }
    }
    out
}

/// Runs every setting, prints the table and the verdict, and writes the
/// figure to `base` (`.png` and `.svg`).
pub(crate) fn rd(scene: &Scene, base: &Path) -> Result<()> {
    let refs = &scene.case.references;
    let mut rows: Vec<Vec<Blended>> = Vec::new();
    let mut points = Vec::new();
    for (curve, outlines) in [(0, Outlines::Cut), (1, Outlines::Kept)] {
        for planes in pick(&[Some(4u8), Some(6), Some(8), None], &[Some(6)]) {
            for tau in pick(&[1.0f64, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0], &[4.0]) {
                let (blends, bytes) =
                    through_stream_as(scene, (Detail::Tau(tau), outlines), planes, BlendOptions::default())?;
                rows.push(blends);
                let planes = planes.map_or("all".to_string(), |p| p.to_string());
                points.push(Point {
                    curve,
                    setting: format!("tau {tau} px, {planes} planes"),
                    bytes,
                });
            }
        }
    }
    // Bytes per novel view of the selected references' own files.
    let per_novel = |bytes: &[usize]| -> f64 {
        let total: usize = scene.selections.iter().flatten().map(|w| bytes[w.index]).sum();
        total as f64 / scene.selections.len() as f64
    };
    for quality in pick(&[10u8, 20, 30, 40, 50, 60, 70, 80, 90, 100], &[50]) {
        let (blends, sizes) = jpeg_blends(scene, quality)?;
        rows.push(blends);
        points.push(Point {
            curve: 2,
            setting: format!("quality {quality}"),
            bytes: per_novel(&sizes),
        });
    }
    let (blends, _) = through_stream_as(scene, (Detail::Exact, Outlines::Kept), None, BlendOptions::default())?;
    rows.push(blends);
    let zipped16: Vec<usize> = refs.iter().map(|r| zipped_depth(&r.depth.z, 16)).collect();
    points.push(Point {
        curve: 3,
        setting: "lossless".to_string(),
        bytes: per_novel(&zipped16),
    });
    let scored = scores(&scene.case, &rows);
    println!("### Rate and distortion per novel view\n");
    println!(
        "The demo scene's 8 novel views; bytes per novel view as a client receives them (the stream zipped, the selected references' JPEG files, or their zipped 16-bit maps); PSNR over the pixels every row below and the truth cover (one common mask, within {:.1} % of the image each row covers), each row's coverage of the image beside it. \
         QEM meshes coded with Draco are not in this run.\n",
        scored.iter().map(|s| s.1).fold(f64::INFINITY, f64::min)
    );
    println!("| curve | setting | bytes per novel view | PSNR dB | coverage % |");
    println!("|---|---|---|---|---|");
    for (p, s) in points.iter().zip(&scored) {
        println!(
            "| {} | {} | {:.0} | {:.2} | {:.2} |",
            CURVES[p.curve], p.setting, p.bytes, s.0, s.1
        );
    }
    println!();
    let of = |curve: usize| -> Vec<(f64, f64)> {
        points
            .iter()
            .zip(&scored)
            .filter(|(p, _)| p.curve == curve)
            .map(|(p, s)| (p.bytes, s.0))
            .collect()
    };
    // The verdict: at every other curve's point within protocol 7's byte
    // range, protocol 7's envelope at those bytes (its best point no
    // larger) scores at least as high.
    let p7 = envelope(of(0));
    let (lo, hi) = (
        p7.first().map_or(f64::INFINITY, |p| p.0),
        p7.last().map_or(0.0, |p| p.0),
    );
    let (mut compared, mut below, mut outside) = (0, Vec::new(), 0);
    for (curve, name) in CURVES.iter().enumerate().skip(1) {
        for (bytes, psnr) in of(curve) {
            if bytes < lo || bytes > hi {
                outside += 1;
                continue;
            }
            compared += 1;
            let best = p7
                .iter()
                .filter(|p| p.0 <= bytes)
                .map(|p| p.1)
                .fold(f64::NEG_INFINITY, f64::max);
            if best < psnr {
                below.push(format!("{name} at {bytes:.0} B ({psnr:.2} dB against {best:.2})"));
            }
        }
    }
    let verdict = match (compared, below.is_empty()) {
        (0, _) => "not judged (no point to compare)",
        (_, true) => "met",
        (_, false) => "not met",
    };
    println!(
        "- **Protocol 7 on or above every other curve** (criterion: at each other curve's point within protocol 7's bytes, {lo:.0}-{hi:.0} B, protocol 7's best point of no more bytes scores at least as high): {} of {compared} points above it, {outside} outside its range: {verdict}.{}",
        below.len(),
        if below.is_empty() { String::new() } else { format!(" Above it: {}.", below.join("; ")) }
    );
    println!();
    Chart {
        title: "Demo scene: PSNR against bytes per novel view",
        x_label: "bytes per novel view",
        y_label: "PSNR (dB)",
        series: (0..CURVES.len())
            .map(|c| (CURVES[c].to_string(), envelope(of(c))))
            .collect(),
        linear_x: false,
        log_y: false,
        legend: plotters::prelude::SeriesLabelPosition::LowerRight,
    }
    .write(base)?;
    Ok(())
}
