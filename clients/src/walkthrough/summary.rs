//! A walkthrough's figures: frame-time statistics per strategy (median, p95,
//! p99, coefficient of variation, as Qu et al. Figs. 7-10 show them per
//! frame), the cost per frame, the image quality, and the files: a Markdown
//! table, per-frame CSV, JSON, and the frame-time and PSNR plots.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;
use serde::Serialize;

use super::Frame;
use crate::report::plot::Chart;

/// One strategy's walk, summed up.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Strategy name.
    pub strategy: String,
    /// Frames walked.
    pub frames: usize,
    /// Frame time, milliseconds: median.
    pub median_ms: f64,
    /// 95th percentile.
    pub p95_ms: f64,
    /// 99th percentile.
    pub p99_ms: f64,
    /// Largest.
    pub max_ms: f64,
    /// Standard deviation over mean.
    pub cv: f64,
    /// The requests' part of the frame time (what the strategy controls): median.
    pub fetch_median_ms: f64,
    /// Its 99th percentile.
    pub fetch_p99_ms: f64,
    /// p99 over median.
    pub p99_over_median: f64,
    /// Mean response bytes per frame.
    pub bytes_per_frame: f64,
    /// Mean server extraction milliseconds per frame.
    pub server_ms_per_frame: f64,
    /// Mean triangles fetched per frame.
    pub fetched_triangles_per_frame: f64,
    /// Mean holes per frame.
    pub holes_per_frame: f64,
    /// Frames whose planned refresh passed what the budget left after the holes.
    pub budget_overruns: usize,
    /// Mean PSNR, dB (with ground truth).
    pub psnr_mean: Option<f64>,
    /// Worst PSNR, dB.
    pub psnr_worst: Option<f64>,
    /// Mean coverage of the ground truth's pixels.
    pub coverage_mean: Option<f64>,
    /// Oldest mesh drawn.
    pub max_age: u32,
    /// Requests shed by the server and sent again, in all.
    pub retries: u32,
}

/// The `q` quantile (nearest rank) of `v`.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let rank = ((q * s.len() as f64).ceil() as usize).clamp(1, s.len());
    s[rank - 1]
}

fn mean(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| sum / n as f64)
}

impl Summary {
    /// Sums up `frames` walked by `strategy`, leaving out the first frame's
    /// times (every strategy fetches everything there) from the statistics.
    pub fn of(strategy: &str, frames: &[Frame]) -> Self {
        let steady: &[Frame] = if frames.len() > 1 { &frames[1..] } else { frames };
        let ms: Vec<f64> = steady.iter().map(|f| f.frame_ms).collect();
        let m = mean(ms.iter().copied()).unwrap_or(f64::NAN);
        let sd = mean(ms.iter().map(|x| (x - m) * (x - m))).unwrap_or(f64::NAN).sqrt();
        let median = quantile(&ms, 0.5);
        let p99 = quantile(&ms, 0.99);
        let fetch: Vec<f64> = steady.iter().map(|f| f.fetch_ms).collect();
        let per = |f: fn(&Frame) -> f64| mean(frames.iter().map(f)).unwrap_or(0.0);
        let psnr: Vec<f64> = frames.iter().filter_map(|f| f.psnr).filter(|p| p.is_finite()).collect();
        Self {
            strategy: strategy.to_string(),
            frames: frames.len(),
            median_ms: median,
            p95_ms: quantile(&ms, 0.95),
            p99_ms: p99,
            max_ms: ms.iter().copied().fold(0.0, f64::max),
            cv: sd / m,
            fetch_median_ms: quantile(&fetch, 0.5),
            fetch_p99_ms: quantile(&fetch, 0.99),
            p99_over_median: p99 / median,
            bytes_per_frame: per(|f| f.bytes as f64),
            server_ms_per_frame: per(|f| f.server_ms),
            fetched_triangles_per_frame: per(|f| f.fetched_triangles as f64),
            holes_per_frame: per(|f| f64::from(f.holes)),
            budget_overruns: frames
                .iter()
                .filter(|f| {
                    f.budget
                        .is_some_and(|b| f.planned_refresh > 0.0 && f.planned_holes + f.planned_refresh > b)
                })
                .count(),
            psnr_mean: mean(psnr.iter().copied()),
            psnr_worst: psnr.iter().copied().reduce(f64::min),
            coverage_mean: mean(frames.iter().filter_map(|f| f.coverage)),
            max_age: frames
                .iter()
                .flat_map(|f| f.ages.iter().map(|a| a.1))
                .max()
                .unwrap_or(0),
            retries: frames.iter().map(|f| f.retries).sum(),
        }
    }
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.digits$}"))
}

/// The comparison table (Markdown).
pub fn markdown(title: &str, rows: &[Summary]) -> String {
    let mut s = format!(
        "### {title}\n\n| strategy | frames | median ms | p95 ms | p99 ms | p99 / median | CV | fetch median ms | fetch p99 ms | KB / frame | server ms / frame | triangles / frame | holes / frame | PSNR mean | PSNR worst | coverage | oldest | retries |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {:.2} | {:.0} | {:.2} | {} | {} | {} | {} | {} |",
            r.strategy,
            r.frames,
            r.median_ms,
            r.p95_ms,
            r.p99_ms,
            r.p99_over_median,
            r.cv,
            r.fetch_median_ms,
            r.fetch_p99_ms,
            r.bytes_per_frame / 1024.0,
            r.server_ms_per_frame,
            r.fetched_triangles_per_frame,
            r.holes_per_frame,
            opt(r.psnr_mean, 2),
            opt(r.psnr_worst, 2),
            opt(r.coverage_mean, 3),
            r.max_age,
            r.retries
        );
    }
    s
}

/// Per-frame CSV of one or more strategies.
pub fn csv(walks: &[(String, Vec<Frame>)]) -> String {
    let mut s = String::from("strategy,frame,frame_ms,fetch_ms,blend_ms,server_ms,bytes,fetched_triangles,drawn_triangles,views,holes,missing,stale,uncovered,retries,refreshed,refreshed_triangles,budget,planned_holes,planned_refresh,max_age,psnr,inverse_depth_rmse,coverage\n");
    for (name, frames) in walks {
        for f in frames {
            let o = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x}"));
            let _ = writeln!(
                s,
                "{name},{},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                f.frame,
                f.frame_ms,
                f.fetch_ms,
                f.blend_ms,
                f.server_ms,
                f.bytes,
                f.fetched_triangles,
                f.drawn_triangles,
                f.views,
                f.holes,
                f.missing,
                f.stale,
                f.uncovered,
                f.retries,
                f.refreshed,
                f.refreshed_triangles,
                o(f.budget),
                f.planned_holes,
                f.planned_refresh,
                f.ages.iter().map(|a| a.1).max().unwrap_or(0),
                o(f.psnr),
                o(f.inverse_depth_rmse),
                o(f.coverage)
            );
        }
    }
    s
}

/// Writes `NAME.csv` (per frame), `NAME.json` (the summaries) and the plots
/// `NAME-frame-ms`, `NAME-fetch-ms` and, with ground truth, `NAME-psnr` (SVG
/// and PNG) into `dir`.
pub fn write(dir: &Path, name: &str, title: &str, walks: &[(String, Vec<Frame>)]) -> anyhow::Result<Vec<Summary>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let summaries: Vec<Summary> = walks.iter().map(|(s, f)| Summary::of(s, f)).collect();
    std::fs::write(dir.join(format!("{name}.csv")), csv(walks))?;
    // The per-frame rows are in the CSV; the JSON holds the summaries.
    #[derive(Serialize)]
    struct Out<'a> {
        title: &'a str,
        summaries: &'a [Summary],
    }
    let out = Out {
        title,
        summaries: &summaries,
    };
    std::fs::write(dir.join(format!("{name}.json")), serde_json::to_vec_pretty(&out)?)?;
    let series: Vec<(String, Vec<Plotted>)> = walks
        .iter()
        .map(|(name, frames)| {
            let pts = frames
                .iter()
                .map(|f| Plotted {
                    frame: f64::from(f.frame),
                    frame_ms: f.frame_ms,
                    fetch_ms: f.fetch_ms,
                    psnr: f.psnr,
                })
                .collect();
            (name.clone(), pts)
        })
        .collect();
    charts(dir, name, title, &series)?;
    Ok(summaries)
}

/// What the plots show of a frame.
struct Plotted {
    frame: f64,
    frame_ms: f64,
    fetch_ms: f64,
    psnr: Option<f64>,
}

/// The plots `NAME-frame-ms`, `NAME-fetch-ms` and, when any frame has a
/// PSNR, `NAME-psnr`: one chart per per-frame figure, a line per strategy.
/// Frames in a time plot's running median: single frames' times jump by
/// the machine's noise, and three strategies' raw lines tangle.
const SMOOTH_FRAMES: usize = 15;

/// The running median of `points` over `window` points, centred (shorter
/// at the ends).
fn running_median(points: &[(f64, f64)], window: usize) -> Vec<(f64, f64)> {
    let half = window / 2;
    (0..points.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(half), (k + half + 1).min(points.len()));
            let mut ys: Vec<f64> = points[a..b].iter().map(|p| p.1).collect();
            ys.sort_by(f64::total_cmp);
            (points[k].0, ys[ys.len() / 2])
        })
        .collect()
}

fn charts(dir: &Path, name: &str, title: &str, walks: &[(String, Vec<Plotted>)]) -> anyhow::Result<()> {
    let plot = |suffix: &str, what: &str, y_label: &str, f: fn(&Plotted) -> Option<f64>| {
        let smooth = suffix.ends_with("-ms");
        let series = walks
            .iter()
            .map(|(s, frames)| {
                let pts: Vec<(f64, f64)> = frames.iter().filter_map(|fr| f(fr).map(|y| (fr.frame, y))).collect();
                (
                    s.clone(),
                    if smooth {
                        running_median(&pts, SMOOTH_FRAMES)
                    } else {
                        pts
                    },
                )
            })
            .collect();
        let what = if smooth {
            format!("{what} (median of {SMOOTH_FRAMES} frames)")
        } else {
            what.to_string()
        };
        Chart {
            title: &format!("{title}: {what}"),
            x_label: "frame",
            y_label,
            series,
            linear_x: true,
            log_y: false,
            legend: plotters::prelude::SeriesLabelPosition::LowerRight,
        }
        .write(&dir.join(format!("{name}-{suffix}")))
    };
    plot(
        "frame-ms",
        "time per frame",
        "frame ms (requests waited on + blend)",
        |f| Some(f.frame_ms),
    )?;
    plot(
        "fetch-ms",
        "requests waited on per frame",
        "fetch ms (the part the strategy controls)",
        |f| Some(f.fetch_ms),
    )?;
    if walks.iter().any(|(_, f)| f.iter().any(|fr| fr.psnr.is_some())) {
        plot("psnr", "PSNR per frame", "PSNR dB (each frame's covered pixels)", |f| {
            f.psnr.filter(|p| p.is_finite())
        })?;
    }
    Ok(())
}

/// Redraws the plots of a walk written by [`write`] from its `NAME.csv`
/// and `NAME.json` in `dir`, without walking again.
pub fn replot(dir: &Path, name: &str) -> anyhow::Result<()> {
    let read = |ext: &str| {
        let path = dir.join(format!("{name}.{ext}"));
        std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))
    };
    let json: serde_json::Value = serde_json::from_str(&read("json")?)?;
    let title = json["title"].as_str().unwrap_or(name).to_string();
    let csv = read("csv")?;
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let col = |n: &str| {
        head.iter()
            .position(|h| *h == n)
            .ok_or_else(|| anyhow::anyhow!("{name}.csv has no {n} column"))
    };
    let (strategy, frame, frame_ms, fetch_ms, psnr) = (
        col("strategy")?,
        col("frame")?,
        col("frame_ms")?,
        col("fetch_ms")?,
        col("psnr")?,
    );
    let mut walks: Vec<(String, Vec<Plotted>)> = Vec::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let num = |k: usize| f.get(k).and_then(|v| v.parse::<f64>().ok());
        let row = Plotted {
            frame: num(frame).ok_or_else(|| anyhow::anyhow!("{name}.csv: a row without a frame"))?,
            frame_ms: num(frame_ms).unwrap_or(f64::NAN),
            fetch_ms: num(fetch_ms).unwrap_or(f64::NAN),
            psnr: num(psnr),
        };
        let s = f.get(strategy).copied().unwrap_or_default();
        match walks.iter_mut().find(|(n, _)| n == s) {
            Some((_, rows)) => rows.push(row),
            None => walks.push((s.to_string(), vec![row])),
        }
    }
    charts(dir, name, &title, &walks)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_running_median_ignores_a_lone_spike_and_keeps_the_frames() {
        let pts: Vec<(f64, f64)> = (0..9)
            .map(|k| (f64::from(k), if k == 4 { 100.0 } else { 1.0 }))
            .collect();
        let m = super::running_median(&pts, 3);
        assert_eq!(m.len(), 9);
        assert!(m.iter().all(|p| p.1 == 1.0), "{m:?}");
        assert_eq!(m[4].0, 4.0);
    }

    #[test]
    fn quantiles_are_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(quantile(&v, 0.5), 50.0);
        assert_eq!(quantile(&v, 0.99), 99.0);
        assert_eq!(quantile(&v, 1.0), 100.0);
        assert!(quantile(&[], 0.5).is_nan());
    }

    #[test]
    fn a_summary_leaves_the_first_frame_out_of_the_times_and_counts_overruns() {
        let frame = |t: u32, ms: f64, planned: f64| Frame {
            frame: t,
            frame_ms: ms,
            budget: Some(10.0),
            planned_refresh: planned,
            ..Frame::default()
        };
        let frames = vec![frame(0, 100.0, 0.0), frame(1, 2.0, 5.0), frame(2, 2.0, 11.0)];
        let s = Summary::of("balanced", &frames);
        assert_eq!(s.median_ms, 2.0);
        assert_eq!(s.cv, 0.0);
        assert_eq!(s.budget_overruns, 1);
    }
}
