//! Naik's conclusions (thesis Ch. 6-7) and the project's goals against
//! them, judged from a comparison's rows ([`super::verdict`]): each claim
//! quoted, its criterion, the run's figures and the outcome.
//!
//! A row counts where its mesher met the rate within [`MET`]; the thesis's
//! meshers are [`THESIS`]; PSNR is on the common mask unless a criterion
//! says otherwise.

use super::baselines::{Row, MET};
use super::verdict::{range, Verdict};

/// The thesis's meshers.
pub const THESIS: [&str; 6] = [
    "decimate",
    "median_decimate",
    "remesh",
    "qem",
    "quadtree_constant",
    "quadtree_plane",
];

/// The rows a comparison's verdicts read.
struct Rows<'a>(&'a [Row]);

impl<'a> Rows<'a> {
    fn met(r: &Row) -> bool {
        (r.achieved_rate / r.rate - 1.0).abs() <= MET
    }

    /// `mesher`'s row on `scene` at `rate`, when it met the rate.
    fn at(&self, scene: &str, mesher: &str, rate: f64) -> Option<&'a Row> {
        self.0
            .iter()
            .find(|r| r.scene == scene && r.mesher == mesher && r.rate == rate)
            .filter(|r| Self::met(r))
    }

    /// Any row of `mesher` on `scene` at `rate`, met or not.
    fn any(&self, scene: &str, mesher: &str, rate: f64) -> Option<&'a Row> {
        self.0
            .iter()
            .find(|r| r.scene == scene && r.mesher == mesher && r.rate == rate)
    }

    fn scenes(&self) -> Vec<&'a str> {
        let mut s: Vec<&str> = Vec::new();
        for r in self.0 {
            if !s.contains(&r.scene.as_str()) {
                s.push(&r.scene);
            }
        }
        s
    }

    /// The reduction rates of `scene` (not the full mesh's), ascending.
    fn rates(&self, scene: &str) -> Vec<f64> {
        let mut v: Vec<f64> = self
            .0
            .iter()
            .filter(|r| r.scene == scene && r.rate > 1.0)
            .map(|r| r.rate)
            .collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    }

    /// Every scene and rate where both `a` and `b` met the rate, with their rows.
    fn both(&self, a: &str, b: &str) -> Vec<(&'a str, f64, &'a Row, &'a Row)> {
        self.scenes()
            .into_iter()
            .flat_map(|s| {
                self.rates(s)
                    .into_iter()
                    .filter_map(move |rate| Some((s, rate, self.at(s, a, rate)?, self.at(s, b, rate)?)))
            })
            .collect()
    }

    /// `mesher`'s PSNR at its highest met rate on `scene` less at its lowest.
    fn span(&self, scene: &str, mesher: &str) -> Option<f64> {
        let c = self.curve(scene, mesher);
        Some(c.last()?.psnr_common - c.first()?.psnr_common)
    }

    /// `mesher`'s met rows on `scene`, by rate.
    fn curve(&self, scene: &str, mesher: &str) -> Vec<&'a Row> {
        self.rates(scene)
            .into_iter()
            .filter_map(|rate| self.at(scene, mesher, rate))
            .collect()
    }
}

/// `scene a-b` for each scene, of `f`'s values on its rows.
fn per_scene(rows: &Rows<'_>, f: impl Fn(&str) -> String) -> String {
    rows.scenes()
        .iter()
        .map(|s| format!("{s} {}", f(s)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// How far below QEM "slightly less" may be, in dB.
const SLIGHTLY_DB: f64 = 1.0;
/// The most a "slight" growth or a "minimal" gain may be, in dB.
const SLIGHT_GAIN_DB: f64 = 1.0;
/// "Considerably smaller": at most this share of the other's error.
const CONSIDERABLY: f64 = 0.8;
/// "No degradation": at most this loss from the lowest rate to the highest, dB.
const NO_DEGRADATION_DB: f64 = 1.0;

/// Every verdict on `rows`: the thesis's conclusions, then the project's goals.
pub fn verdicts(rows: &[Row]) -> Vec<Verdict> {
    let r = Rows(rows);
    let scenes = r.scenes();
    let mut out = Vec::new();

    // "Quadtree with plane fit has the best PSNR" (Sec. 6.3, Ch. 7).
    let (mut best, mut counted, mut lost) = (0, 0, Vec::new());
    for s in &scenes {
        for rate in r.rates(s) {
            let Some(plane) = r.at(s, "quadtree_plane", rate) else {
                continue;
            };
            let others: Vec<&Row> = THESIS[..5].iter().filter_map(|m| r.at(s, m, rate)).collect();
            counted += 1;
            if others.iter().all(|o| plane.psnr_common >= o.psnr_common) {
                best += 1;
            } else {
                lost.push(format!("{s} {rate}"));
            }
        }
    }
    out.push(
        Verdict::judge(
            "The quadtree with plane fit has the best PSNR (Sec. 6.3, Ch. 7)",
            "at every scene and rate it met, its PSNR is at least each other thesis mesher's",
            counted > 0 && best == counted,
            format!("best on {best} of {counted} rows; behind on {}", if lost.is_empty() { "none".into() } else { lost.join(", ") }),
        )
        .because(
            "",
            "Its kept blocks that a discontinuity crosses lose their faces, so at high rates it leaves depth edges uncovered, and foreground and background mix there.",
        ),
    );

    // "PSNR grows slightly while increasing the reduction rate."
    let growth: Vec<(&str, f64)> = scenes
        .iter()
        .filter_map(|s| Some((*s, r.span(s, "quadtree_plane")?)))
        .collect();
    out.push(
        Verdict::judge(
            "The plane fit's PSNR grows slightly with the reduction rate (Sec. 6.3)",
            format!("on every scene its PSNR at its highest met rate is 0-{SLIGHT_GAIN_DB} dB above its PSNR at its lowest"),
            !growth.is_empty() && growth.iter().all(|g| (0.0..=SLIGHT_GAIN_DB).contains(&g.1)),
            growth
                .iter()
                .map(|(s, g)| format!("{s} {g:+.2} dB"))
                .collect::<Vec<_>>()
                .join(", "),
        )
        .because(
            "",
            "Larger blocks are planes through their corner samples only (Alg. 2), so their error grows with the threshold.",
        ),
    );

    // "At the lower side the maximum achievable reduction factor is 30."
    let reach = |m: &str| -> Vec<(&str, f64)> {
        scenes
            .iter()
            .map(|s| (*s, r.curve(s, m).last().map_or(0.0, |row| row.rate)))
            .collect()
    };
    let plane_reach = reach("quadtree_plane");
    out.push(Verdict::judge(
        "The plane fit cannot go past a reduction rate of about 30 (Sec. 6.3)",
        "on every scene, the highest rate it meets is below 45",
        plane_reach.iter().all(|p| p.1 < 45.0),
        plane_reach
            .iter()
            .map(|(s, x)| format!("{s} {x}"))
            .collect::<Vec<_>>()
            .join(", "),
    ));

    // "Surface simplification takes significant time for no apparent gain in PSNR."
    let qem_plane = r.both("qem", "quadtree_plane");
    let qem_rows = qem_plane.len();
    let qem_gain: Vec<f64> = qem_plane
        .iter()
        .map(|(_, _, q, p)| q.psnr_common - p.psnr_common)
        .collect();
    let slow: Vec<f64> = qem_plane.iter().map(|(_, _, q, p)| q.ms / p.ms.max(1e-9)).collect();
    out.push(Verdict::judge(
        "QEM takes much longer than the plane fit (Sec. 6.3-6.4)",
        "QEM's meshing time is at least 10 times the plane fit's on every row both met",
        qem_rows > 0 && slow.iter().all(|&x| x >= 10.0),
        format!("{} times, over {qem_rows} rows", range(slow.iter().copied(), 0)),
    ));
    out.push(
        Verdict::judge(
            "QEM brings no gain in PSNR (Sec. 6.3)",
            format!("QEM's PSNR is at most {SLIGHT_GAIN_DB} dB above the plane fit's on every row both met"),
            qem_rows > 0 && qem_gain.iter().all(|&g| g <= SLIGHT_GAIN_DB),
            format!("QEM minus plane fit {} dB", range(qem_gain.iter().copied(), 2)),
        )
        .because(
            "",
            "meshoptimizer is not the thesis's QEM: its border-aware quadrics keep depth edges, and its collapses keep the topology.",
        ),
    );

    // "There is no degradation in the quality [of adaptive remeshing] even
    // when the simplification rate is high."
    let remesh_change: Vec<(&str, f64)> = scenes.iter().filter_map(|s| Some((*s, r.span(s, "remesh")?))).collect();
    out.push(Verdict::judge(
        "Adaptive remeshing does not degrade at high rates (Sec. 6.3)",
        format!(
            "on every scene its PSNR falls by at most {NO_DEGRADATION_DB} dB from its lowest met rate to its highest"
        ),
        !remesh_change.is_empty() && remesh_change.iter().all(|l| l.1 >= -NO_DEGRADATION_DB),
        remesh_change
            .iter()
            .map(|(s, l)| format!("{s} {l:+.2} dB"))
            .collect::<Vec<_>>()
            .join(", "),
    ));

    // "Filtered depth map shows considerably smaller MSE as opposed to
    // unfiltered one even though there is no much significant improvement in PSNR."
    let filtered = r.both("median_decimate", "decimate");
    let pairs = filtered.len();
    let mse_ratio: Vec<f64> = filtered
        .iter()
        .map(|(_, _, m, d)| m.disparity_mse_common / d.disparity_mse_common.max(1e-12))
        .collect();
    let psnr_gain: Vec<f64> = filtered
        .iter()
        .map(|(_, _, m, d)| m.psnr_common - d.psnr_common)
        .collect();
    out.push(
        Verdict::judge(
            "The median filter gives a considerably smaller disparity MSE than plain decimation (Sec. 6.3)",
            format!("median-filtered decimation's disparity MSE is at most {CONSIDERABLY} of plain decimation's on every row both met"),
            pairs > 0 && mse_ratio.iter().all(|&x| x <= CONSIDERABLY),
            format!(
                "MSE ratio {} over {pairs} rows; PSNR gain {} dB",
                range(mse_ratio.iter().copied(), 2),
                range(psnr_gain.iter().copied(), 2)
            ),
        )
        .because("", "These disparities are quantised, not noisy: a median filter has little to remove."),
    );

    // "PSNR of the Quadtree with constant block is slightly less compared
    // to surface simplification ... can go up to the reduction factor of 70."
    let gaps: Vec<f64> = r
        .both("quadtree_constant", "qem")
        .iter()
        .map(|(_, _, c, q)| q.psnr_common - c.psnr_common)
        .collect();
    let gap_rows = gaps.len();
    out.push(
        Verdict::judge(
            "The constant quadtree is slightly below QEM (Sec. 6.3)",
            format!("on every row both met, its PSNR is 0-{SLIGHTLY_DB} dB below QEM's"),
            gap_rows > 0 && gaps.iter().all(|&g| (0.0..=SLIGHTLY_DB).contains(&g)),
            format!(
                "QEM minus constant {} dB over {gap_rows} rows",
                range(gaps.iter().copied(), 2)
            ),
        )
        .because(
            "",
            "Flat blocks shift the warped texture by their whole depth error, which grows with the block.",
        ),
    );
    let constant_reach = reach("quadtree_constant");
    out.push(Verdict::judge(
        "The constant quadtree reaches a reduction rate of 70 (Sec. 6.3)",
        "on every scene it meets rate 70",
        constant_reach.iter().all(|c| c.1 >= 70.0),
        constant_reach
            .iter()
            .map(|(s, x)| format!("{s} {x}"))
            .collect::<Vec<_>>()
            .join(", "),
    ));

    // "DIBR shows slightly higher PSNR compared to Quadtree with plane fit."
    let lowest = |s: &str| r.rates(s).first().copied().unwrap_or(5.0);
    let dibr: Vec<(&str, f64)> = scenes
        .iter()
        .filter_map(|s| {
            let d = r.any(s, "dibr", 1.0)?;
            let p = r.at(s, "quadtree_plane", lowest(s))?;
            Some((*s, d.psnr - p.psnr))
        })
        .collect();
    out.push(
        Verdict::judge(
            "DIBR's PSNR is slightly higher than the plane fit's (Sec. 6.3)",
            format!("on every scene, per-pixel DIBR's PSNR (its own mask) is 0-{SLIGHT_GAIN_DB} dB above the plane fit's at its lowest rate (its own mask)"),
            !dibr.is_empty() && dibr.iter().all(|d| (0.0..=SLIGHT_GAIN_DB).contains(&d.1)),
            dibr.iter()
                .map(|(s, d)| format!("{s} {d:+.2} dB"))
                .collect::<Vec<_>>()
                .join(", "),
        )
        .because(
            "",
            "DIBR's splats let the background through cracks in the foreground at depth edges; a mesh's triangles close them.",
        ),
    );

    // The project's goals against the thesis's meshers.
    let rqt_plane = r.both("rqt", "quadtree_plane");
    let both = rqt_plane.len();
    let above = rqt_plane
        .iter()
        .filter(|(_, _, q, p)| q.psnr_common >= p.psnr_common)
        .count();
    let short: Vec<String> = rqt_plane
        .iter()
        .filter(|(_, _, q, p)| q.psnr_common < p.psnr_common)
        .map(|(s, rate, q, p)| format!("{s} {rate} ({:+.2})", q.psnr_common - p.psnr_common))
        .collect();
    out.push(
        Verdict::judge(
            "Goal: the served RQT at or above the plane fit at every rate on all four scenes",
            "the `rqt` row's PSNR is at least `quadtree_plane`'s on every row both met",
            both > 0 && above == both,
            format!(
                "at or above on {above} of {both} rows; short on {}",
                if short.is_empty() { "none".into() } else { short.join(", ") }
            ),
        )
        .because(
            "",
            "Off a 3 px band round the depth edges the RQT is within a few per cent of the plane fit's error; on the band it is worse (the tables' last columns).",
        ),
    );
    if let (Some(q), Some(e)) = (r.at("art", "rqt", 70.0), r.at("art", "qem", 70.0)) {
        out.push(
            Verdict::judge(
                "Goal: the served RQT at or above QEM on art at rate 70",
                "`rqt`'s PSNR is at least `qem`'s on art at rate 70",
                q.psnr_common >= e.psnr_common,
                format!("{:.2} dB against {:.2}", q.psnr_common, e.psnr_common),
            )
            .because(
                "",
                "QEM spends its triangles along the border as long thin triangles that follow it, which the lattice cannot make.",
            ),
        );
    }
    let speed: Vec<f64> = r
        .both("qem", "rqt")
        .iter()
        .map(|(_, _, q, t)| q.ms / t.ms.max(1e-9))
        .collect();
    out.push(Verdict::judge(
        "Goal: the RQT at least 20 times faster than QEM at equal triangles",
        "QEM's time over `rqt`'s (build and extraction) is at least 20 on every row both met",
        !speed.is_empty() && speed.iter().all(|&x| x >= 20.0),
        format!("{} times", range(speed.iter().copied(), 1)),
    ));
    let full = per_scene(&r, |s| {
        r.any(s, "full", 1.0)
            .map_or("-".into(), |f| format!("{:.2} dB", f.psnr))
    });
    out.push(Verdict::judge(
        "The full-resolution mesh at or above per-pixel DIBR (this project's reading of Sec. 6.3's reference)",
        "on every scene the full-resolution mesh's PSNR is at least DIBR's (each on its own mask)",
        scenes
            .iter()
            .all(|s| match (r.any(s, "full", 1.0), r.any(s, "dibr", 1.0)) {
                (Some(f), Some(d)) => f.psnr >= d.psnr,
                _ => false,
            }),
        format!(
            "full mesh {full}; DIBR {}",
            per_scene(&r, |s| r
                .any(s, "dibr", 1.0)
                .map_or("-".into(), |d| format!("{:.2} dB", d.psnr)))
        ),
    ));
    out
}
