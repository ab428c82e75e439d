//! `dmesh-client report --baselines`: the thesis's comparison of depth-map
//! meshers (Naik Ch. 6) with the restricted quadtree among them.
//!
//! Per scene the left view is meshed by every mesher of
//! `dmesh_engine::baselines`, each driven to the reduction rates of
//! [`RATES`] (the full-resolution mesh's triangles over the triangles kept),
//! warped to the right view through the same blend as the strips of the
//! report, and compared with the right image: PSNR of colour (Eq. 6.2-6.3)
//! and MSE of disparity, the inverse depth `f B / z` in pixels (Eq. 6.4).
//!
//! The valid mask is where the warped full-resolution mesh and the right
//! view's ground truth both have depth, less the pixels a mesher leaves
//! uncovered (disocclusions and holes are excluded, as the thesis does);
//! `coverage` says how much of the mask a mesher covers. A mesher that
//! drops the hard pixels at depth edges would gain PSNR on its own mask, so
//! the scores that compare meshers (`psnr_common`, `disparity_mse_common`)
//! are taken on the *common* mask of a rate: the pixels every mesher covers
//! at that rate. Times are one meshing
//! at the knob setting that meets the rate (the median of up to `repeats`
//! runs, fewer once a mesher has taken [`TIME_BUDGET_MS`]), from depth
//! image to triangles, on one thread; the search for the setting is not
//! timed.

use std::path::Path;

use anyhow::Context;
use std::time::Instant;

use dmesh_engine::baselines::{self, full_mesh, Mesher, TriMesh};
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::cases::{self, Case};
use super::plot;
use crate::blend::{blend_surfaces, BlendOptions, Blended, Surface, SurfacePoint};
use crate::compare::compare;

/// The reduction rates of the comparison (Naik Figs. 6.2 and 6.3 span 5 to 70).
pub const RATES: [f64; 6] = [5.0, 10.0, 20.0, 30.0, 45.0, 70.0];
/// The thesis's scenes that are in the data folder.
pub const SCENES: [&str; 4] = ["art", "aloe", "reindeer", "cones"];
/// The row name of the full-resolution mesh, every scene's reference.
pub const FULL: &str = "full";
/// Relative miss of the reduction rate within which a row counts as
/// meeting it (the plots leave the others out).
pub const MET: f64 = 0.1;
/// No more repeats of a meshing once its runs have taken this long.
pub const TIME_BUDGET_MS: f64 = 3000.0;

/// One mesher at one rate on one scene.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Row {
    /// Scene name.
    pub scene: String,
    /// Mesher name ([`FULL`] for the full-resolution mesh).
    pub mesher: String,
    /// Reduction rate asked for.
    pub rate: f64,
    /// Triangles kept.
    pub triangles: usize,
    /// Reduction rate met: full-resolution triangles over `triangles`.
    pub achieved_rate: f64,
    /// The knob setting that met it.
    pub knob: f64,
    /// What the knob is (for the RQT, `tau` or, where `tau` cannot reach
    /// the rate, `epsilon`).
    pub knob_name: String,
    /// Meshing time, ms (median of the repeats).
    pub ms: f64,
    /// For the RQT, the extraction alone (its hierarchy is built once per
    /// depth image and serves every rate), ms, median of the repeats.
    pub per_level_ms: Option<f64>,
    /// PSNR of the warped view on the valid mask, dB.
    pub psnr: f64,
    /// MSE of disparity on the valid mask, pixels squared.
    pub disparity_mse: f64,
    /// Fraction of the full mesh's valid mask this mesh covers.
    pub coverage: f64,
    /// PSNR on the pixels every mesher covers at this rate, dB.
    pub psnr_common: f64,
    /// MSE of disparity on the same pixels, pixels squared.
    pub disparity_mse_common: f64,
    /// Fraction of the full mesh's valid mask that every mesher covers at this rate.
    pub common_mask: f64,
    /// Fraction of the common mask whose disparity is off by more than
    /// [`BAD_DISPARITY_PX`] (Middlebury's "bad pixels"): the pixels where a
    /// foreground and a background swapped at a depth edge, which carry
    /// nearly all of the MSE.
    pub bad_pixels_common: f64,
}

/// Disparity error, pixels, past which a pixel is "bad".
pub const BAD_DISPARITY_PX: f64 = 1.0;

/// What to compare.
#[derive(Clone, Debug)]
pub struct Options {
    /// Scene names under the data folder.
    pub scenes: Vec<String>,
    /// Reduction rates.
    pub rates: Vec<f64>,
    /// Timings are the median of this many meshings.
    pub repeats: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            scenes: SCENES.iter().map(|s| s.to_string()).collect(),
            rates: RATES.to_vec(),
            repeats: 3,
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// The left view's mesh warped into the right view.
fn warp(case: &Case, mesh: &TriMesh) -> Blended {
    let r = &case.references[0];
    let surface = Surface {
        camera: r.camera,
        weight: 1.0,
        texture: &r.texture,
        points: mesh
            .vertices
            .iter()
            .map(|&[u, v, z]| SurfacePoint {
                u: f64::from(u),
                v: f64::from(v),
                z: f64::from(z),
                rho: 1.0,
                normal: DVec3::NEG_Z,
            })
            .collect(),
        triangles: mesh.triangles.clone(),
    };
    blend_surfaces(&case.novels[0].camera, &[surface], &BlendOptions::default())
}

/// Fraction of `mask` whose disparity is off by more than [`BAD_DISPARITY_PX`].
fn bad_pixels(case: &Case, warped: &Blended, mask: &[bool]) -> f64 {
    let fb = case.focal_baseline.unwrap_or(1.0);
    let truth = &case.novels[0].depth;
    let (mut bad, mut n) = (0usize, 0usize);
    for i in (0..mask.len()).filter(|&i| mask[i] && warped.depth[i] > 0.0 && truth[i] > 0.0) {
        n += 1;
        let d = fb * (1.0 / f64::from(warped.depth[i]) - 1.0 / f64::from(truth[i]));
        bad += usize::from(d.abs() > BAD_DISPARITY_PX);
    }
    bad as f64 / n.max(1) as f64
}

/// Scores a warped view on `mask` (the full mesh's valid pixels).
fn score(case: &Case, warped: &Blended, mask: &[bool]) -> anyhow::Result<(f64, f64, f64)> {
    let novel = &case.novels[0];
    let depth: Vec<f32> = warped
        .depth
        .iter()
        .zip(mask)
        .map(|(&z, &m)| if m { z } else { 0.0 })
        .collect();
    let c = compare(&warped.rgb, &novel.rgb, Some((&depth, &novel.depth)))?;
    let fb = case.focal_baseline.unwrap_or(1.0);
    let rmse = c.inverse_depth_rmse.unwrap_or(0.0) * fb;
    let in_mask = mask.iter().filter(|&&m| m).count().max(1) as f64;
    Ok((c.psnr, rmse * rmse, c.valid_fraction * mask.len() as f64 / in_mask))
}

/// Every mesher at every rate on `case`, after the full-resolution row.
pub fn compare_case(case: &Case, meshers: &[Box<dyn Mesher>], options: &Options) -> anyhow::Result<Vec<Row>> {
    anyhow::ensure!(
        case.references.len() == 1 && case.novels.len() == 1,
        "{}: the comparison needs one reference and one novel view",
        case.name
    );
    let (depth, camera) = (&case.references[0].depth, &case.references[0].camera);
    let repeats = options.repeats.max(1);
    // Up to `repeats` timings in all, `first` among them.
    let time = |first: Option<(TriMesh, f64)>,
                f: &mut dyn FnMut() -> anyhow::Result<TriMesh>|
     -> anyhow::Result<(TriMesh, f64)> {
        let (mut last, mut times) = match first {
            Some((mesh, ms)) => (Some(mesh), vec![ms]),
            None => (None, Vec::new()),
        };
        while times.len() < repeats && times.iter().sum::<f64>() < TIME_BUDGET_MS {
            let t = Instant::now();
            last = Some(f()?);
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Ok((last.ok_or_else(|| anyhow::anyhow!("no mesh"))?, median(times)))
    };
    let (full, full_ms) = time(None, &mut || Ok(full_mesh(depth)))?;
    let full_n = full.triangles.len();
    anyhow::ensure!(full_n > 0, "{}: the depth map has no valid cell", case.name);
    let warped = warp(case, &full);
    let truth = &case.novels[0].depth;
    let mask: Vec<bool> = warped
        .depth
        .iter()
        .zip(truth)
        .map(|(&a, &b)| a > 0.0 && b > 0.0)
        .collect();
    let (psnr, disparity_mse, coverage) = score(case, &warped, &mask)?;
    let mut rows = vec![Row {
        scene: case.name.clone(),
        mesher: FULL.into(),
        rate: 1.0,
        triangles: full_n,
        achieved_rate: 1.0,
        knob: 0.0,
        knob_name: "none".into(),
        ms: full_ms,
        per_level_ms: None,
        psnr,
        disparity_mse,
        coverage,
        psnr_common: psnr,
        disparity_mse_common: disparity_mse,
        common_mask: 1.0,
        bad_pixels_common: bad_pixels(case, &warped, &mask),
    }];
    for &rate in &options.rates {
        let mut at_rate: Vec<(Row, Blended)> = Vec::new();
        for mesher in meshers {
            let want = ((full_n as f64 / rate).round() as usize).max(1);
            let baselines::Driven { mesh, knob, ms, runner } = baselines::drive(mesher.as_ref(), depth, camera, want)?;
            let runner: &dyn Mesher = runner.as_deref().unwrap_or(mesher.as_ref());
            let (mesh, ms) = time(Some((mesh, ms)), &mut || Ok(runner.mesh(depth, camera, knob)?))?;
            mesh.validate(depth.width, depth.height)?;
            let mut per_level = Vec::new();
            for _ in 0..repeats {
                match runner.per_level_ms(depth, camera, knob)? {
                    Some(ms) => per_level.push(ms),
                    None => break,
                }
            }
            let per_level_ms = (!per_level.is_empty()).then(|| median(per_level));
            let warped = warp(case, &mesh);
            let (psnr, disparity_mse, coverage) = score(case, &warped, &mask)?;
            let row = Row {
                scene: case.name.clone(),
                mesher: mesher.name().into(),
                rate,
                triangles: mesh.triangles.len(),
                achieved_rate: full_n as f64 / mesh.triangles.len().max(1) as f64,
                knob,
                knob_name: runner.knob_name(),
                ms,
                per_level_ms,
                psnr,
                disparity_mse,
                coverage,
                psnr_common: f64::NAN,
                disparity_mse_common: f64::NAN,
                common_mask: f64::NAN,
                bad_pixels_common: f64::NAN,
            };
            at_rate.push((row, warped));
        }
        let common: Vec<bool> = (0..mask.len())
            .map(|i| mask[i] && at_rate.iter().all(|(_, w)| w.depth[i] > 0.0))
            .collect();
        let common_mask =
            common.iter().filter(|&&c| c).count() as f64 / mask.iter().filter(|&&m| m).count().max(1) as f64;
        for (mut row, warped) in at_rate {
            (row.psnr_common, row.disparity_mse_common, _) = score(case, &warped, &common)?;
            row.common_mask = common_mask;
            row.bad_pixels_common = bad_pixels(case, &warped, &common);
            eprintln!(
                "{} {} rate {rate}: {} triangles (rate {:.1}), {:.1} ms, PSNR {:.2} dB on {:.3} of the mask, {:.2} dB on the common {:.3}, disparity MSE {:.3}",
                row.scene,
                row.mesher,
                row.triangles,
                row.achieved_rate,
                row.ms,
                row.psnr,
                row.coverage,
                row.psnr_common,
                row.common_mask,
                row.disparity_mse_common
            );
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The comparison over `options.scenes` under `data`.
pub fn run(data: &Path, options: &Options) -> anyhow::Result<Vec<Row>> {
    let meshers = baselines::all();
    let mut rows = Vec::new();
    for scene in &options.scenes {
        let case = cases::middlebury(data, scene)?;
        rows.extend(compare_case(&case, &meshers, options)?);
    }
    Ok(rows)
}

fn scenes(rows: &[Row]) -> Vec<&str> {
    let mut out: Vec<&str> = Vec::new();
    for r in rows {
        if !out.contains(&r.scene.as_str()) {
            out.push(&r.scene);
        }
    }
    out
}

fn meshers(rows: &[Row]) -> Vec<&str> {
    let mut out: Vec<&str> = Vec::new();
    for r in rows.iter().filter(|r| r.mesher != FULL) {
        if !out.contains(&r.mesher.as_str()) {
            out.push(&r.mesher);
        }
    }
    out
}

/// The Markdown tables: one per scene, then the goals (the RQT against the
/// plane-fit quadtree's PSNR and against QEM's time).
pub fn markdown(rows: &[Row]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    for scene in scenes(rows) {
        let _ = writeln!(out, "### {scene}\n");
        let _ = writeln!(
            out,
            "| rate asked | mesher | knob | triangles | rate met | ms | ms per further rate | PSNR dB, own mask | coverage | PSNR dB, common mask | disparity MSE px^2, common mask | bad pixels, common mask |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|");
        let of_scene: Vec<&Row> = rows.iter().filter(|r| r.scene == scene).collect();
        let mut rates: Vec<f64> = of_scene.iter().map(|r| r.rate).collect();
        rates.sort_by(f64::total_cmp);
        rates.dedup();
        for rate in rates {
            for r in of_scene.iter().filter(|r| r.rate == rate) {
                let again = r.per_level_ms.unwrap_or(r.ms);
                let _ = writeln!(
                    out,
                    "| {} | {} | {} {:.3e} | {} | {:.1} | {:.1} | {:.1} | {:.2} | {:.3} | {:.2} | {:.3} | {:.4} |",
                    r.rate,
                    r.mesher,
                    r.knob_name,
                    r.knob,
                    r.triangles,
                    r.achieved_rate,
                    r.ms,
                    again,
                    r.psnr,
                    r.coverage,
                    r.psnr_common,
                    r.disparity_mse_common,
                    r.bad_pixels_common
                );
            }
        }
        let _ = writeln!(out);
    }
    let find = |scene: &str, mesher: &str, rate: f64| {
        rows.iter()
            .find(|r| r.scene == scene && r.mesher == mesher && r.rate == rate)
    };
    let _ = writeln!(out, "### The RQT against the plane-fit quadtree and QEM\n");
    let _ = writeln!(
        out,
        "| scene | rate | RQT | common mask | RQT PSNR - quadtree_plane PSNR, common mask, dB | the same, own masks | RQT coverage - quadtree_plane coverage | QEM ms / RQT ms | QEM ms / RQT extraction ms | QEM triangles / RQT triangles |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|");
    for scene in scenes(rows) {
        let mut rates: Vec<f64> = rows
            .iter()
            .filter(|r| r.scene == scene && r.mesher != FULL)
            .map(|r| r.rate)
            .collect();
        rates.sort_by(f64::total_cmp);
        rates.dedup();
        for rate in rates {
            for variant in ["rqt", "rqt_refined"] {
                let Some(rqt) = find(scene, variant, rate) else {
                    continue;
                };
                let (plane, own, cover) =
                    find(scene, "quadtree_plane", rate).map_or((f64::NAN, f64::NAN, f64::NAN), |p| {
                        (
                            rqt.psnr_common - p.psnr_common,
                            rqt.psnr - p.psnr,
                            rqt.coverage - p.coverage,
                        )
                    });
                let extract = rqt.per_level_ms.unwrap_or(rqt.ms).max(1e-9);
                let (speed, speed_again, tris) = find(scene, "qem", rate).map_or((f64::NAN, f64::NAN, f64::NAN), |q| {
                    (
                        q.ms / rqt.ms.max(1e-9),
                        q.ms / extract,
                        q.triangles as f64 / rqt.triangles.max(1) as f64,
                    )
                });
                let _ = writeln!(
                    out,
                    "| {scene} | {rate} | {variant} | {:.3} | {plane:+.2} | {own:+.2} | {cover:+.3} | {speed:.1} | {speed_again:.0} | {tris:.2} |",
                    rqt.common_mask
                );
            }
        }
    }
    out
}

/// The rows of a comparison written by [`write`] (`baselines.json` in `out`).
pub fn read(out: &Path) -> anyhow::Result<Vec<Row>> {
    let path = out.join("baselines.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}: run report --baselines first", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{} is not a comparison's rows", path.display()))
}

/// Writes `baselines.md`, `baselines.json` and per scene the thesis's two
/// plots, `psnr-<scene>` (PSNR against reduction rate) and `time-<scene>`
/// (meshing time against reduction rate), SVG and PNG, into `out`. The
/// plots show the rows that met their rate within [`MET`].
pub fn write(rows: &[Row], out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("baselines.md"), markdown(rows))?;
    std::fs::write(out.join("baselines.json"), serde_json::to_string_pretty(rows)?)?;
    for scene in scenes(rows) {
        let series = |y: fn(&Row) -> f64| -> Vec<(String, Vec<(f64, f64)>)> {
            meshers(rows)
                .into_iter()
                .map(|m| {
                    // A rate the mesher could not reach (its row says
                    // where it stopped) is not a point of its curve.
                    let pts = rows
                        .iter()
                        .filter(|r| r.scene == scene && r.mesher == m)
                        .filter(|r| (r.achieved_rate / r.rate - 1.0).abs() <= MET)
                        .map(|r| (r.achieved_rate, y(r)))
                        .collect();
                    (m.to_string(), pts)
                })
                .collect()
        };
        plot::Chart {
            title: &format!("{scene}: PSNR of the warped view against reduction rate"),
            x_label: "reduction rate (full-resolution triangles / triangles)",
            y_label: "PSNR dB (pixels every mesher covers)",
            linear_x: true,
            log_y: false,
            legend: plotters::prelude::SeriesLabelPosition::LowerLeft,
            series: series(|r| r.psnr_common),
        }
        .write(&out.join(format!("psnr-{scene}")))?;
        plot::Chart {
            title: &format!("{scene}: meshing time against reduction rate"),
            x_label: "reduction rate (full-resolution triangles / triangles)",
            y_label: "ms, one thread (log)",
            linear_x: true,
            log_y: true,
            legend: plotters::prelude::SeriesLabelPosition::MiddleRight,
            series: series(|r| r.ms),
        }
        .write(&out.join(format!("time-{scene}")))?;
    }
    Ok(())
}
