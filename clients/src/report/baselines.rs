//! `dmesh-client report --baselines`: the thesis's comparison of depth-map
//! meshers (Naik Ch. 6) with the restricted quadtree among them.
//!
//! Per scene the left view is meshed by every mesher of
//! `dmesh_engine::baselines`, each driven to the reduction rates of
//! [`RATES`] (the full-resolution mesh's triangles over the triangles kept),
//! warped to the right view through the same blend as the strips of the
//! report, with no gap filling (a filled crack would flatter a mesher that
//! leaves cracks), and compared with the right image, on the thesis's terms
//! (Naik Sec. 6.1):
//!
//! - PSNR of colour (Eq. 6.2-6.3): the mean of the three channels' squared
//!   errors over the valid mask, against the thesis's peak of **256**
//!   (Eq. 6.3; 0.034 dB above the usual 255);
//! - MSE of disparity, the inverse depth `f B / z` in pixels (Eq. 6.4),
//!   against the ground truth and, as Sec. 6.1.2 states it, against the
//!   full-resolution mesh's rasterised disparity.
//!
//! The valid mask is the thesis's left-right correspondence check: the
//! pixels where the warped full-resolution mesh and the right view's ground
//! truth agree within [`BAD_DISPARITY_PX`] of disparity, which leaves out
//! occlusions, disocclusions and the truth's own holes; a mesher's pixels
//! left uncovered are excluded too, as the thesis does, and `coverage` says
//! how much of the mask a mesher covers. Beside the meshers, the per-pixel
//! DIBR the thesis compares everything against ([`DIBR`]): every left pixel
//! forward-warped as a splat. A mesher that
//! drops the hard pixels at depth edges would gain PSNR on its own mask, so
//! the scores that compare meshers (`psnr_common`, `disparity_mse_common`)
//! are taken on the *common* mask of a rate: the pixels every mesher covers
//! at that rate. Times are one meshing
//! at the knob setting that meets the rate (the median of up to `repeats`
//! runs, fewer once a mesher has taken [`TIME_BUDGET_MS`]), from depth
//! image to triangles, on one thread; the search for the setting is not
//! timed.

use std::path::Path;

use std::time::Instant;

use dmesh_engine::baselines::{self, full_mesh, Mesher, TriMesh};
use glam::DVec3;
use serde::{Deserialize, Serialize};

pub use super::baselines_table::{markdown, read, summary, write};
use super::cases::{self, Case};
use crate::blend::{blend_surfaces, BlendOptions, Blended, Surface, SurfacePoint};
use crate::compare::compare;

/// The reduction rates of the comparison (Naik Figs. 6.2 and 6.3 span 5 to 70).
pub const RATES: [f64; 6] = [5.0, 10.0, 20.0, 30.0, 45.0, 70.0];
/// The thesis's scenes that are in the data folder.
pub const SCENES: [&str; 4] = ["art", "aloe", "reindeer", "cones"];
/// The row name of the full-resolution mesh, every scene's reference.
pub const FULL: &str = "full";
/// The row name of per-pixel DIBR: every left pixel forward-warped as a
/// splat, no mesh.
pub const DIBR: &str = "dibr";
/// The thesis's PSNR peak (Eq. 6.3).
pub const PSNR_PEAK: f64 = 256.0;
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
    /// MSE on the same pixels of disparity against the full-resolution
    /// mesh's rasterised disparity (Naik Sec. 6.1.2), pixels squared.
    #[serde(default)]
    pub disparity_mse_full_common: f64,
    /// Fraction of the full mesh's valid mask that every mesher covers at this rate.
    pub common_mask: f64,
    /// Fraction of the common mask whose disparity is off by more than
    /// [`BAD_DISPARITY_PX`] (Middlebury's "bad pixels"): the pixels where a
    /// foreground and a background swapped at a depth edge, which carry
    /// nearly all of the MSE.
    pub bad_pixels_common: f64,
    /// Fraction of the common mask in the depth-edge band ([`edge_band`]).
    #[serde(default)]
    pub edge_band_common: f64,
    /// Fraction of the common mask's colour squared error on those pixels:
    /// where a mesher loses, at its outlines or on its surfaces.
    #[serde(default)]
    pub edge_error_common: f64,
}

/// Disparity error, pixels, past which a pixel is "bad".
pub const BAD_DISPARITY_PX: f64 = 1.0;

/// Disparity step, pixels, between neighbouring pixels of the right view's
/// ground truth that makes a depth edge for [`edge_band`].
pub const EDGE_STEP_PX: f64 = 2.0;

/// Half-width, pixels, of the band around depth edges ([`edge_band`]).
pub const EDGE_BAND_PX: usize = 3;

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
    let options = BlendOptions {
        fill_gaps: 0,
        ..BlendOptions::default()
    };
    blend_surfaces(&case.novels[0].camera, &[surface], &options)
}

/// Per-pixel DIBR: every valid left pixel forward-warped into the right
/// view as a splat covering its footprint there (its corners projected at
/// its depth, at least the nearest pixel), nearest first.
fn dibr(case: &Case) -> Blended {
    let (r, novel) = (&case.references[0], &case.novels[0].camera);
    let (w, h) = (novel.width as usize, novel.height as usize);
    let mut out = Blended {
        width: novel.width,
        height: novel.height,
        rgb: vec![0; 3 * w * h],
        depth: vec![0.0; w * h],
        coverage: vec![0; w * h],
    };
    let (rw, rh) = (r.depth.width as usize, r.depth.height as usize);
    let to_novel = |u: f64, v: f64, z: f64| {
        let world = r.camera.to_world(r.camera.back_project(u, v, z));
        novel.project(novel.to_camera(world))
    };
    for y in 0..rh {
        for x in 0..rw {
            let z = f64::from(r.depth.z[y * rw + x]);
            if !(z.is_finite() && z > 0.0) {
                continue;
            }
            let (u, v) = (x as f64, y as f64);
            let Some((cu, cv, cz)) = to_novel(u, v, z) else {
                continue;
            };
            // The footprint: the pixel's corners at its depth.
            let (mut lo, mut hi) = ((cu, cv), (cu, cv));
            for (du, dv) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
                if let Some((pu, pv, _)) = to_novel(u + du, v + dv, z) {
                    (lo, hi) = ((lo.0.min(pu), lo.1.min(pv)), (hi.0.max(pu), hi.1.max(pv)));
                }
            }
            // The pixels whose centres it covers, or the nearest; at most
            // 4 x 4 (a wider footprint is a surface seen edge-on).
            let span = |lo: f64, hi: f64, c: f64| {
                let (a, b) = (lo.ceil(), hi.floor());
                if a > b {
                    (c.round(), c.round())
                } else {
                    (a, b.min(a + 3.0))
                }
            };
            let ((x0, x1), (y0, y1)) = (span(lo.0, hi.0, cu), span(lo.1, hi.1, cv));
            let colour = &r.texture.rgb[3 * (y * rw + x)..3 * (y * rw + x) + 3];
            let mut py = y0;
            while py <= y1 {
                let mut px = x0;
                while px <= x1 {
                    if px >= 0.0 && py >= 0.0 && (px as usize) < w && (py as usize) < h {
                        let i = py as usize * w + px as usize;
                        if out.depth[i] == 0.0 || (cz as f32) < out.depth[i] {
                            out.depth[i] = cz as f32;
                            out.rgb[3 * i..3 * i + 3].copy_from_slice(colour);
                            out.coverage[i] = 1;
                        }
                    }
                    px += 1.0;
                }
                py += 1.0;
            }
        }
    }
    out
}

/// The thesis's PSNR (peak 256) from one against the usual peak of 255.
fn thesis_psnr(psnr_255: f64) -> f64 {
    psnr_255 + 20.0 * (PSNR_PEAK / 255.0).log10()
}

/// MSE of disparity, pixels squared, between two warped views on `mask`.
fn disparity_mse_between(case: &Case, a: &Blended, b: &Blended, mask: &[bool]) -> f64 {
    let fb = case.focal_baseline.unwrap_or(1.0);
    let (mut se, mut n) = (0f64, 0usize);
    for i in (0..mask.len()).filter(|&i| mask[i] && a.depth[i] > 0.0 && b.depth[i] > 0.0) {
        let d = fb * (1.0 / f64::from(a.depth[i]) - 1.0 / f64::from(b.depth[i]));
        se += d * d;
        n += 1;
    }
    se / n.max(1) as f64
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

/// The pixels of the right view within [`EDGE_BAND_PX`] (in x and y) of a
/// depth edge of its ground truth: neighbours whose disparities differ by
/// more than [`EDGE_STEP_PX`], or a valid pixel beside an invalid one.
fn edge_band(case: &Case) -> Vec<bool> {
    let novel = &case.novels[0];
    let (w, h) = (novel.camera.width as usize, novel.camera.height as usize);
    let fb = case.focal_baseline.unwrap_or(1.0);
    let disparity = |i: usize| {
        let z = f64::from(novel.depth[i]);
        (z > 0.0).then(|| fb / z)
    };
    let step = |i: usize, j: usize| match (disparity(i), disparity(j)) {
        (Some(a), Some(b)) => (a - b).abs() > EDGE_STEP_PX,
        (None, None) => false,
        _ => true,
    };
    let mut edge = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !(x + 1 < w && step(i, i + 1) || y + 1 < h && step(i, i + w)) {
                continue;
            }
            for yy in y.saturating_sub(EDGE_BAND_PX)..(y + EDGE_BAND_PX + 2).min(h) {
                for xx in x.saturating_sub(EDGE_BAND_PX)..(x + EDGE_BAND_PX + 2).min(w) {
                    edge[yy * w + xx] = true;
                }
            }
        }
    }
    edge
}

/// On `mask`: the fraction of its pixels in `edge`, and the fraction of its
/// colour squared error on them (0 where it has none).
fn edge_shares(case: &Case, warped: &Blended, mask: &[bool], edge: &[bool]) -> (f64, f64) {
    let truth = &case.novels[0].rgb;
    let (mut pixels, mut on_edge) = (0usize, 0usize);
    let (mut error, mut edge_error) = (0f64, 0f64);
    for i in (0..mask.len()).filter(|&i| mask[i]) {
        let e: f64 = (3 * i..3 * i + 3)
            .map(|k| (f64::from(warped.rgb[k]) - f64::from(truth[k])).powi(2))
            .sum();
        pixels += 1;
        error += e;
        if edge[i] {
            on_edge += 1;
            edge_error += e;
        }
    }
    let share = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
    (share(on_edge as f64, pixels as f64), share(edge_error, error))
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
    Ok((
        thesis_psnr(c.psnr),
        rmse * rmse,
        c.valid_fraction * mask.len() as f64 / in_mask,
    ))
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
    // The left-right check: the full mesh's warp and the truth agree.
    let fb = case.focal_baseline.unwrap_or(1.0);
    let mask: Vec<bool> = warped
        .depth
        .iter()
        .zip(truth)
        .map(|(&a, &b)| {
            a > 0.0 && b > 0.0 && (fb * (1.0 / f64::from(a) - 1.0 / f64::from(b))).abs() <= BAD_DISPARITY_PX
        })
        .collect();
    let full_warp = warped.clone();
    let edge = edge_band(case);
    let (psnr, disparity_mse, coverage) = score(case, &warped, &mask)?;
    let (edge_band_common, edge_error_common) = edge_shares(case, &warped, &mask, &edge);
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
        disparity_mse_full_common: 0.0,
        common_mask: 1.0,
        bad_pixels_common: bad_pixels(case, &warped, &mask),
        edge_band_common,
        edge_error_common,
    }];
    // Per-pixel DIBR, scored on the mask like the full mesh.
    let t = Instant::now();
    let splatted = dibr(case);
    let dibr_ms = t.elapsed().as_secs_f64() * 1e3;
    let (psnr, disparity_mse, coverage) = score(case, &splatted, &mask)?;
    let covered: Vec<bool> = (0..mask.len()).map(|i| mask[i] && splatted.depth[i] > 0.0).collect();
    let (edge_band_common, edge_error_common) = edge_shares(case, &splatted, &covered, &edge);
    rows.push(Row {
        scene: case.name.clone(),
        mesher: DIBR.into(),
        rate: 1.0,
        triangles: 0,
        achieved_rate: 1.0,
        knob: 0.0,
        knob_name: "per pixel".into(),
        ms: dibr_ms,
        per_level_ms: None,
        psnr,
        disparity_mse,
        coverage,
        psnr_common: psnr,
        disparity_mse_common: disparity_mse,
        disparity_mse_full_common: disparity_mse_between(case, &splatted, &full_warp, &covered),
        common_mask: covered.iter().filter(|&&c| c).count() as f64 / mask.iter().filter(|&&m| m).count().max(1) as f64,
        bad_pixels_common: bad_pixels(case, &splatted, &covered),
        edge_band_common,
        edge_error_common,
    });
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
                disparity_mse_full_common: f64::NAN,
                common_mask: f64::NAN,
                bad_pixels_common: f64::NAN,
                edge_band_common: f64::NAN,
                edge_error_common: f64::NAN,
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
            row.disparity_mse_full_common = disparity_mse_between(case, &warped, &full_warp, &common);
            row.common_mask = common_mask;
            row.bad_pixels_common = bad_pixels(case, &warped, &common);
            (row.edge_band_common, row.edge_error_common) = edge_shares(case, &warped, &common, &edge);
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
