//! `dmesh-client report`: what accuracy costs in time and bytes.
//!
//! Sweeps the level of detail (tau, epsilon, residual bits, triangle
//! budget) over scenes with ground truth, runs the server's render plan in
//! process (`dmesh_engine::render_plan`: select views, share the level of
//! detail by weight, extract, encode the strip responses in bincode), decodes
//! them as a client, blends the novel view and
//! compares it with the truth: PSNR and inverse-depth RMSE (Naik's
//! protocol), triangles, bytes and milliseconds. Tables go to `report.md`
//! and `report.json`, curves to SVG and PNG.
//!
//! Every PSNR says its mask. `psnr` is over the pixels a setting covers
//! (its own mask, `coverage` of the image), which flatters a setting that
//! covers less; `psnr_common` is over the pixels every setting of the scene
//! covers (`common_mask` of the image), and the curves compare settings on
//! it.

pub mod baselines;
mod baselines_table;
pub mod baselines_verdicts;
pub mod cases;
pub mod plot;
pub mod verdict;

use std::path::PathBuf;
use std::time::Instant;

use dmesh_engine::mesh::{Hierarchy, Segmentation};
use dmesh_engine::render_plan::{self, Ask};
use dmesh_proto::Lod as WireLod;
use serde::Serialize;

use crate::blend::{blend, BlendOptions, ViewInput};
use crate::compare::compare;
use cases::Case;

/// What to sweep and where to write.
#[derive(Clone, Debug)]
pub struct Options {
    /// Fewer settings, the exact simulated scene only (for tests).
    pub quick: bool,
    /// Folder of the Middlebury scenes; `None` leaves them out.
    pub data: Option<PathBuf>,
    /// Timings are the median of this many runs.
    pub repeats: usize,
}

/// One swept parameter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Sweep {
    /// View-dependent tolerance, pixels.
    Tau,
    /// Static tolerance as a fraction of the scene's typical depth.
    Epsilon,
    /// Residual bits at tau = 1.
    Bits,
    /// Triangle budget over the selected views.
    Budget,
}

impl Sweep {
    fn settings(self, quick: bool) -> Vec<f64> {
        match (self, quick) {
            (Self::Tau, false) => vec![0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0],
            (Self::Tau, true) => vec![0.0, 1.0, 8.0],
            (Self::Epsilon, false) => vec![0.0, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2],
            (Self::Epsilon, true) => vec![1e-3],
            (Self::Bits, false) => vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 16.0],
            (Self::Bits, true) => vec![0.0, 8.0, 16.0],
            (Self::Budget, false) => vec![1e3, 3e3, 1e4, 3e4, 1e5],
            (Self::Budget, true) => vec![1e4],
        }
    }

    /// Column heading of the setting.
    pub fn unit(self) -> &'static str {
        match self {
            Self::Tau => "tau (px)",
            Self::Epsilon => "epsilon (x depth)",
            Self::Bits => "bits (tau 1)",
            Self::Budget => "max triangles",
        }
    }
}

/// One row: a setting on one scene, averaged over its novel views.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Scene name.
    pub scene: String,
    /// What was swept.
    pub sweep: Sweep,
    /// Its setting.
    pub setting: f64,
    /// Triangles over the selected views.
    pub triangles: f64,
    /// Vertices over the selected views.
    pub vertices: f64,
    /// Bincode bytes of the strip responses.
    pub bytes: f64,
    /// Hierarchy build time per reference view.
    pub build_ms: f64,
    /// Extraction time over the selected views.
    pub extract_ms: f64,
    /// Blend time of the novel view.
    pub blend_ms: f64,
    /// PSNR on the pixels this setting covers and the truth holds, dB.
    pub psnr: f64,
    /// Share of the image this setting covers (where the truth holds).
    pub coverage: f64,
    /// PSNR on the pixels every setting of the scene covers, dB.
    pub psnr_common: f64,
    /// Share of the image in that common mask.
    pub common_mask: f64,
    /// RMSE of inverse depth on the valid mask.
    pub inverse_depth_rmse: f64,
    /// Largest decoded depth error stated by residual coding, metres (0 for exact depths).
    pub depth_error: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// The scenes of a report.
pub fn cases(options: &Options) -> anyhow::Result<Vec<Case>> {
    let mut out = vec![cases::simulated("demo", false, if options.quick { 1 } else { 3 })?];
    if !options.quick {
        out.push(cases::simulated("demo-noisy", true, 3)?);
    }
    if let Some(data) = &options.data {
        for scene in ["cones", "teddy"] {
            out.push(cases::middlebury(data, scene)?);
        }
    }
    Ok(out)
}

/// Sweeps every setting over `case`.
pub fn sweep(case: &Case, options: &Options) -> anyhow::Result<Vec<Row>> {
    let repeats = options.repeats.max(1);
    let mut build_ms = Vec::new();
    let hierarchies: Vec<Hierarchy> = case
        .references
        .iter()
        .map(|r| {
            let mut best = None;
            for _ in 0..repeats {
                let h = Hierarchy::build(&r.depth, &r.camera, &Segmentation::default())?;
                build_ms.push(h.stats().build_ms);
                best = Some(h);
            }
            best.ok_or_else(|| anyhow::anyhow!("no build"))
        })
        .collect::<anyhow::Result<_>>()?;
    let build_ms = median(build_ms);
    let selections = case.selections(None)?;
    let mut rows = Vec::new();
    // Per row, per novel view, each pixel's squared error (-1: not covered).
    let mut per_pixel: Vec<Vec<Vec<f32>>> = Vec::new();
    for sweep in [Sweep::Tau, Sweep::Epsilon, Sweep::Bits, Sweep::Budget] {
        for setting in sweep.settings(options.quick) {
            // As the server does (`render_plan::afford`): a budget leaves
            // out the views whose share no mesh of theirs fits, and the rest
            // share it; a budget below even the heaviest view's coarsest
            // mesh is refused, so it has no row.
            let sweep_selections: Vec<Vec<dmesh_engine::scene::Weighted>> = match sweep {
                Sweep::Budget => selections
                    .iter()
                    .map(|sel| {
                        let weights: Vec<f64> = sel.iter().map(|w| w.weight).collect();
                        let coarsest: Vec<u64> =
                            sel.iter().map(|w| hierarchies[w.index].coarsest_triangles()).collect();
                        render_plan::afford(&weights, &coarsest, setting)
                            .into_iter()
                            .zip(sel)
                            .filter(|(w, _)| *w > 0.0)
                            .map(|(weight, v)| dmesh_engine::scene::Weighted { weight, ..*v })
                            .collect()
                    })
                    .collect(),
                _ => selections.clone(),
            };
            let budget = Ask::new(WireLod::MaxTriangles(setting as u32), None, None)?;
            let attainable = |sel: &Vec<dmesh_engine::scene::Weighted>| {
                sel.iter().all(|w| {
                    matches!(budget.share(w.weight).wire_lod(),
                        WireLod::MaxTriangles(m) if u64::from(m) >= hierarchies[w.index].coarsest_triangles())
                })
            };
            if sweep == Sweep::Budget && !sweep_selections.iter().all(attainable) {
                eprintln!(
                    "{}: max_triangles {setting} is below the coarsest mesh of the heaviest selected view; no row",
                    case.name
                );
                continue;
            }
            let mut acc = Row {
                scene: case.name.clone(),
                sweep,
                setting,
                triangles: 0.0,
                vertices: 0.0,
                bytes: 0.0,
                build_ms,
                extract_ms: 0.0,
                blend_ms: 0.0,
                psnr: 0.0,
                coverage: 0.0,
                psnr_common: f64::NAN,
                common_mask: f64::NAN,
                inverse_depth_rmse: 0.0,
                depth_error: 0.0,
            };
            let mut errors = Vec::new();
            for (novel, selected) in case.novels.iter().zip(&sweep_selections) {
                let mut responses = Vec::new();
                for w in selected {
                    let (h, r) = (&hierarchies[w.index], &case.references[w.index]);
                    // The server's render plan, step by step: the share of
                    // the request's level of detail, resolved by the view.
                    let (lod, novel_camera) = match sweep {
                        Sweep::Tau => (WireLod::Tau(setting), Some(novel.camera)),
                        Sweep::Bits => (WireLod::Tau(1.0), Some(novel.camera)),
                        Sweep::Epsilon => (WireLod::Epsilon(setting * case.depth_scale), None),
                        Sweep::Budget => (WireLod::MaxTriangles(setting as u32), Some(novel.camera)),
                    };
                    let bits = (sweep == Sweep::Bits).then_some(setting as u8);
                    let ask = Ask::new(lod, novel_camera, bits)?.share(w.weight);
                    let mut times = Vec::new();
                    let mut answer = None;
                    for _ in 0..repeats {
                        let out = render_plan::extract(h, r.raw_grid, &case.name, "v", &ask, |ms| ms)?;
                        times.push(out.response.extract_ms);
                        answer = Some(out);
                    }
                    let wire = answer.ok_or_else(|| anyhow::anyhow!("no extraction"))?.response;
                    acc.extract_ms += median(times);
                    let bytes = dmesh_proto::to_bincode(&wire)?;
                    acc.bytes += bytes.len() as f64;
                    acc.triangles += f64::from(wire.triangles);
                    acc.vertices += wire.vertices.len() as f64;
                    let back: dmesh_proto::StripResponse = dmesh_proto::from_bincode(&bytes)?;
                    if let dmesh_proto::Depths::Residual(res) = &back.depths {
                        acc.depth_error = acc.depth_error.max(f64::from(res.max_error));
                    }
                    responses.push((w.weight, back, &r.texture));
                }
                let inputs = ViewInput::of_responses(&responses);
                let mut times = Vec::new();
                let mut blended = None;
                for _ in 0..repeats {
                    let t = Instant::now();
                    let b = blend(&novel.camera, &inputs, &BlendOptions::default())?;
                    times.push(t.elapsed().as_secs_f64() * 1e3);
                    blended = Some(b);
                }
                let b = blended.ok_or_else(|| anyhow::anyhow!("no blend"))?;
                acc.blend_ms += median(times);
                let c = compare(&b.rgb, &novel.rgb, Some((&b.depth, &novel.depth)))?;
                acc.psnr += c.psnr;
                acc.coverage += c.valid_fraction;
                acc.inverse_depth_rmse += c.inverse_depth_rmse.unwrap_or(0.0);
                errors.push(squared_errors(&b.rgb, &b.depth, novel));
            }
            per_pixel.push(errors);
            let n = case.novels.len().max(1) as f64;
            for v in [
                &mut acc.triangles,
                &mut acc.vertices,
                &mut acc.bytes,
                &mut acc.extract_ms,
                &mut acc.blend_ms,
                &mut acc.psnr,
                &mut acc.coverage,
                &mut acc.inverse_depth_rmse,
            ] {
                *v /= n;
            }
            rows.push(acc);
        }
    }
    // The common mask: per novel view, the pixels every row covers.
    for row in &mut rows {
        (row.psnr_common, row.common_mask) = (0.0, 0.0);
    }
    let views = case.novels.len().max(1) as f64;
    for (k, novel) in case.novels.iter().enumerate() {
        let n = novel.depth.len();
        let common: Vec<bool> = (0..n).map(|i| per_pixel.iter().all(|row| row[k][i] >= 0.0)).collect();
        let inside = common.iter().filter(|&&c| c).count();
        for (row, errors) in rows.iter_mut().zip(&per_pixel) {
            let se: f64 = (0..n).filter(|&i| common[i]).map(|i| f64::from(errors[k][i])).sum();
            row.psnr_common += psnr_of(se / inside.max(1) as f64) / views;
            row.common_mask += inside as f64 / n as f64 / views;
        }
    }
    Ok(rows)
}

/// PSNR in dB of a mean squared error of 8-bit colour (peak 255).
fn psnr_of(mse: f64) -> f64 {
    if mse <= 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    }
}

/// Per pixel of a blended view, the mean of its three channels' squared
/// errors against the truth where both hold a surface, -1 elsewhere.
fn squared_errors(rgb: &[u8], depth: &[f32], truth: &cases::Novel) -> Vec<f32> {
    (0..truth.depth.len())
        .map(|i| {
            if depth[i] > 0.0 && truth.depth[i] > 0.0 {
                let e: f64 = (0..3)
                    .map(|c| (f64::from(rgb[3 * i + c]) - f64::from(truth.rgb[3 * i + c])).powi(2))
                    .sum();
                (e / 3.0) as f32
            } else {
                -1.0
            }
        })
        .collect()
}

/// The Markdown tables: one per scene, then PSNR against residual bits.
pub fn markdown(rows: &[Row]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    for scene in &scenes {
        let _ = writeln!(out, "### {scene}\n");
        let _ = writeln!(
            out,
            "| sweep | setting | triangles | bytes | build ms | extract ms | blend ms | PSNR dB, common mask | PSNR dB, own mask | coverage | inv-depth RMSE |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|");
        for r in rows.iter().filter(|r| r.scene == *scene) {
            let _ = writeln!(
                out,
                "| {} | {} | {:.0} | {:.0} | {:.2} | {:.3} | {:.2} | {:.2} | {:.2} | {:.1} % | {:.5} |",
                r.sweep.unit(),
                r.setting,
                r.triangles,
                r.bytes,
                r.build_ms,
                r.extract_ms,
                r.blend_ms,
                r.psnr_common,
                r.psnr,
                100.0 * r.coverage,
                r.inverse_depth_rmse
            );
        }
        if let Some(r) = rows.iter().find(|r| r.scene == *scene) {
            let _ = writeln!(
                out,
                "\nThe common mask (every setting covers it) is {:.1} % of the image.",
                100.0 * r.common_mask
            );
        }
        let _ = writeln!(out);
    }
    let _ = writeln!(
        out,
        "### PSNR against residual bits (tau = 1; Verlani Table 2's trade-off)\n"
    );
    let _ = writeln!(
        out,
        "| scene | bits | bytes | bytes per vertex | ratio to exact f32 | max depth error (m) | PSNR dB, common mask |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    for scene in &scenes {
        let exact = rows
            .iter()
            .find(|r| r.scene == *scene && r.sweep == Sweep::Tau && r.setting == 1.0)
            .map_or(f64::NAN, |r| r.bytes);
        for r in rows.iter().filter(|r| r.scene == *scene && r.sweep == Sweep::Bits) {
            let _ = writeln!(
                out,
                "| {scene} | {} | {:.0} | {:.2} | {:.2} | {:.2e} | {:.2} |",
                r.setting,
                r.bytes,
                r.bytes / r.vertices.max(1.0),
                r.bytes / exact,
                r.depth_error,
                r.psnr_common
            );
        }
    }
    out
}

/// Writes `report.md`, `report.json` and the curves (`psnr-vs-extract-ms`,
/// `psnr-vs-bytes`, each SVG and PNG) into `out`.
pub fn write(rows: &[Row], out: &std::path::Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("report.md"), markdown(rows))?;
    std::fs::write(out.join("report.json"), serde_json::to_string_pretty(rows)?)?;
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    let curve = |scene: &str, sweep: Sweep, x: fn(&Row) -> f64| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.scene == scene && r.sweep == sweep)
            .map(|r| (x(r), r.psnr_common))
            .collect()
    };
    plot::Chart {
        title: "PSNR against extraction time (tau sweep)",
        x_label: "extraction ms over the selected views (log)",
        y_label: "PSNR dB (pixels every setting covers)",
        linear_x: false,
        log_y: false,
        legend: plotters::prelude::SeriesLabelPosition::LowerRight,
        series: scenes
            .iter()
            .map(|s| (s.to_string(), curve(s, Sweep::Tau, |r| r.extract_ms)))
            .collect(),
    }
    .write(&out.join("psnr-vs-extract-ms"))?;
    plot::Chart {
        title: "PSNR against response bytes (tau and bits sweeps)",
        x_label: "bincode bytes over the selected views (log)",
        y_label: "PSNR dB (pixels every setting covers)",
        linear_x: false,
        log_y: false,
        legend: plotters::prelude::SeriesLabelPosition::LowerRight,
        series: scenes
            .iter()
            .flat_map(|s| {
                [
                    (format!("{s} tau"), curve(s, Sweep::Tau, |r| r.bytes)),
                    (format!("{s} bits"), curve(s, Sweep::Bits, |r| r.bytes)),
                ]
            })
            .collect(),
    }
    .write(&out.join("psnr-vs-bytes"))?;
    Ok(())
}
