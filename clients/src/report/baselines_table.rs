//! The baselines comparison written out: its Markdown tables, its rows as
//! JSON and the thesis's two plots per scene (Naik Sec. 6.2, Figs. 6.x:
//! PSNR and meshing time against reduction rate). The comparison itself is
//! [`super::baselines`].

use std::path::Path;

use anyhow::Context;

use super::baselines::{Row, DIBR, FULL, MET};
use super::plot;

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
    // The full mesh and per-pixel DIBR have no rate: they are the tables'
    // references, not curves.
    for r in rows.iter().filter(|r| r.mesher != FULL && r.mesher != DIBR) {
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
            "| rate asked | mesher | knob | triangles | rate met | ms | ms per further rate | PSNR dB, own mask | coverage | PSNR dB, common mask | disparity MSE px^2, common mask | the same against the full mesh | bad pixels, common mask | edge band, common mask | colour error on it |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        let of_scene: Vec<&Row> = rows.iter().filter(|r| r.scene == scene).collect();
        let mut rates: Vec<f64> = of_scene.iter().map(|r| r.rate).collect();
        rates.sort_by(f64::total_cmp);
        rates.dedup();
        for rate in rates {
            for r in of_scene.iter().filter(|r| r.rate == rate) {
                let again = r.per_level_ms.unwrap_or(r.ms);
                let _ = writeln!(
                    out,
                    "| {} | {} | {} {:.3e} | {} | {:.1} | {:.1} | {:.1} | {:.2} | {:.3} | {:.2} | {:.3} | {:.3} | {:.4} | {:.3} | {:.3} |",
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
                    r.disparity_mse_full_common,
                    r.bad_pixels_common,
                    r.edge_band_common,
                    r.edge_error_common
                );
            }
        }
        let _ = writeln!(out);
    }
    let find = |scene: &str, mesher: &str, rate: f64| row(rows, scene, mesher, rate);
    let _ = writeln!(
        out,
        "### Summary\n\nPSNR (dB, common mask) at rates 5 / 20 / 70, and meshing time at rate 20:\n"
    );
    out.push_str(&summary(rows));
    let _ = writeln!(out);
    let _ = writeln!(out, "### The RQT against the plane-fit quadtree and QEM\n");
    let _ = writeln!(
        out,
        "| scene | rate | RQT | common mask | RQT PSNR - quadtree_plane PSNR, common mask, dB | the same, own masks | RQT coverage - quadtree_plane coverage | QEM ms / RQT ms | QEM ms / RQT extraction ms | QEM triangles / RQT triangles | RQT colour error on the edge band | QEM's |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    for scene in scenes(rows) {
        let mut rates: Vec<f64> = rows
            .iter()
            .filter(|r| r.scene == scene && r.mesher != FULL)
            .map(|r| r.rate)
            .collect();
        rates.sort_by(f64::total_cmp);
        rates.dedup();
        for rate in rates {
            for variant in ["rqt", "rqt_dropping", "rqt_cut", "rqt_shared_cut"] {
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
                let (speed, speed_again, tris, qem_edge) =
                    find(scene, "qem", rate).map_or((f64::NAN, f64::NAN, f64::NAN, f64::NAN), |q| {
                        (
                            q.ms / rqt.ms.max(1e-9),
                            q.ms / extract,
                            q.triangles as f64 / rqt.triangles.max(1) as f64,
                            q.edge_error_common,
                        )
                    });
                let _ = writeln!(
                    out,
                    "| {scene} | {rate} | {variant} | {:.3} | {plane:+.2} | {own:+.2} | {cover:+.3} | {speed:.1} | {speed_again:.0} | {tris:.2} | {:.2} | {qem_edge:.2} |",
                    rqt.common_mask, rqt.edge_error_common
                );
            }
        }
    }
    let _ = writeln!(out);
    out.push_str(&cut_verdicts(rows));
    let _ = writeln!(
        out,
        "\n### The thesis's conclusions and the goals, judged\n\nEach computed from the rows above by the criterion stated (`clients/src/report/baselines_verdicts.rs`); a row counts where its mesher met the rate within {:.0} %, and PSNR is on the common mask unless the criterion says otherwise.\n",
        MET * 100.0
    );
    for v in super::baselines_verdicts::verdicts(rows) {
        let _ = writeln!(out, "{v}");
    }
    out
}

/// The meshers of the summary table, in its column order.
const SUMMARY: [&str; 8] = [
    "rqt",
    "rqt_dropping",
    "rqt_shared_cut",
    "quadtree_plane",
    "qem",
    "remesh",
    "decimate",
    "quadtree_constant",
];

/// The summary table docs/baselines.md quotes: per scene, each mesher's
/// PSNR on the common mask at rates 5, 20 and 70 (with the rate it
/// reached when it missed one), and the meshing times at rate 20.
pub fn summary(rows: &[Row]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| scene | {} | ms at rate 20: rqt / plane / qem / remesh |",
        SUMMARY.join(" | ")
    );
    let _ = writeln!(out, "|---|{}---|", "---|".repeat(SUMMARY.len()));
    for scene in scenes(rows) {
        let cells: Vec<String> = SUMMARY
            .iter()
            .map(|m| {
                [5.0, 20.0, 70.0]
                    .iter()
                    .map(|&rate| match row(rows, scene, m, rate) {
                        None => "-".to_string(),
                        Some(r) if (r.achieved_rate / r.rate - 1.0).abs() <= MET => format!("{:.2}", r.psnr_common),
                        Some(r) => format!("{:.2} (rate {:.0})", r.psnr_common, r.achieved_rate),
                    })
                    .collect::<Vec<_>>()
                    .join(" / ")
            })
            .collect();
        let ms: Vec<String> = ["rqt", "quadtree_plane", "qem", "remesh"]
            .iter()
            .map(|m| row(rows, scene, m, 20.0).map_or("-".to_string(), |r| format!("{:.0}", r.ms)))
            .collect();
        let _ = writeln!(out, "| {scene} | {} | {} |", cells.join(" | "), ms.join(" / "));
    }
    out
}

/// The row of `mesher` on `scene` at `rate`, if the comparison has one.
fn row<'a>(rows: &'a [Row], scene: &str, mesher: &str, rate: f64) -> Option<&'a Row> {
    rows.iter()
        .find(|r| r.scene == scene && r.mesher == mesher && r.rate == rate)
}

/// The outlines cut (`rqt_cut`) against the plane-fit quadtree and QEM, with
/// the verdicts computed from the rows: "at or above" when `rqt_cut`'s
/// PSNR on the common mask is at least the other's at the same scene and
/// rate, counted over the rows where both met the rate within [`MET`]; and
/// on art at rate 70, whether `rqt_cut` closes at least half the gap from
/// `rqt` to `qem` in the same run.
pub fn cut_verdicts(rows: &[Row]) -> String {
    use std::fmt::Write;
    let met = |r: &&Row| (r.achieved_rate / r.rate - 1.0).abs() <= MET;
    let find = |scene: &str, mesher: &str, rate: f64| row(rows, scene, mesher, rate).filter(met);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "### Outlines cut
"
    );
    let _ = writeln!(
        out,
        "PSNR in dB on the common mask; a row counts where both met the rate within {:.0} %.\n",
        MET * 100.0
    );
    let _ = writeln!(out, "| scene | rate | rqt_cut | rqt | quadtree_plane | qem |");
    let _ = writeln!(out, "|---|---|---|---|---|---|");
    let (mut rows_plane, mut above_plane, mut rows_qem, mut above_qem) = (0, 0, 0, 0);
    let cell = |r: Option<&Row>| r.map_or("-".to_string(), |r| format!("{:.2}", r.psnr_common));
    for scene in scenes(rows) {
        let mut rates: Vec<f64> = rows
            .iter()
            .filter(|r| r.scene == scene && r.mesher == "rqt_cut")
            .map(|r| r.rate)
            .collect();
        rates.sort_by(f64::total_cmp);
        for rate in rates {
            let cut = find(scene, "rqt_cut", rate);
            let plane = find(scene, "quadtree_plane", rate);
            let qem = find(scene, "qem", rate);
            if let (Some(c), Some(p)) = (cut, plane) {
                rows_plane += 1;
                above_plane += usize::from(c.psnr_common >= p.psnr_common);
            }
            if let (Some(c), Some(q)) = (cut, qem) {
                rows_qem += 1;
                above_qem += usize::from(c.psnr_common >= q.psnr_common);
            }
            let _ = writeln!(
                out,
                "| {scene} | {rate} | {} | {} | {} | {} |",
                cell(cut),
                cell(find(scene, "rqt", rate)),
                cell(plane),
                cell(qem)
            );
        }
    }
    let _ = writeln!(
        out,
        "\n`rqt_cut` is at or above `quadtree_plane` on {above_plane} of {rows_plane} rows, and at or above `qem` on {above_qem} of {rows_qem}."
    );
    if let (Some(c), Some(r), Some(q)) = (
        find("art", "rqt_cut", 70.0),
        find("art", "rqt", 70.0),
        find("art", "qem", 70.0),
    ) {
        let goal = r.psnr_common + 0.5 * (q.psnr_common - r.psnr_common);
        let verdict = if c.psnr_common >= goal {
            "closes"
        } else {
            "does not close"
        };
        let _ = writeln!(
            out,
            "On art at rate 70 `rqt_cut` scores {:.2} dB: it {verdict} half the gap from `rqt`'s {:.2} to `qem`'s {:.2} ({goal:.2}).",
            c.psnr_common, r.psnr_common, q.psnr_common
        );
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
        // The full-resolution mesh and per-pixel DIBR as reference lines
        // across the rates (each on its own mask: neither has a rate).
        let (lo, hi) = rows
            .iter()
            .filter(|r| r.scene == scene && r.rate > 1.0)
            .fold((f64::INFINITY, 0f64), |(a, b), r| {
                (a.min(r.achieved_rate), b.max(r.achieved_rate))
            });
        let references = |y: fn(&Row) -> f64| -> Vec<(String, Vec<(f64, f64)>)> {
            [(FULL, "full mesh"), (DIBR, "per-pixel DIBR")]
                .iter()
                .filter_map(|(m, label)| {
                    let r = rows.iter().find(|r| r.scene == scene && r.mesher == *m)?;
                    Some((label.to_string(), vec![(lo, y(r)), (hi, y(r))]))
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
            series: [series(|r| r.psnr_common), references(|r| r.psnr)].concat(),
        }
        .write(&out.join(format!("psnr-{scene}")))?;
        // The thesis pairs each PSNR plot with the MSE of the rasterised
        // disparity (Sec. 6.1.2).
        plot::Chart {
            title: &format!("{scene}: disparity MSE against reduction rate"),
            x_label: "reduction rate (full-resolution triangles / triangles)",
            y_label: "disparity MSE, px^2 (pixels every mesher covers, log)",
            linear_x: true,
            log_y: true,
            legend: plotters::prelude::SeriesLabelPosition::UpperLeft,
            series: [series(|r| r.disparity_mse_common), references(|r| r.disparity_mse)].concat(),
        }
        .write(&out.join(format!("mse-{scene}")))?;
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
