//! Weights that do not pop (issue 28; DMesh Fig. 22): along an orbit of the
//! demo scene in 0.1 degree steps, how much of the total weight each step
//! moves between views, and how many pixels of the blended picture change
//! (by more than 8 of 255) from one frame to the next beside how many of
//! the simulator's ground truth do,
//! for the selection before this issue (positional mean over the views
//! within the limit, a hard cut at five views) and after (ULR: scores
//! against the first view left out, `engine/src/scene/selection.rs`).
//!
//! Every reference view is meshed once at a static tolerance in process
//! (no server), so the pictures differ by their weights alone.
//!
//! Usage: `cargo run --release -p dmesh-client --example orbit_weights [-- OUT_DIR]`
//! (default `docs/weights`): writes `steps.csv`, `weights.svg`/`.png` and
//! `frames.svg`/`.png`, and prints a table.

use anyhow::Context;
use dmesh_client::blend::{blend, BlendOptions, Blended, Texture, ViewInput};
use dmesh_client::report::plot::Chart;
use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::Hierarchy;
use dmesh_engine::render_plan::{self, Ask};
use dmesh_engine::scene::{select_views, SelectionRule};
use dmesh_engine::sim::rig::Rig;
use dmesh_engine::sim::{render_view, SceneSpec};
use plotters::prelude::SeriesLabelPosition;

/// The orbit of the issue, in steps of 0.1 degree.
const STEPS: u32 = 3600;
/// The arc drawn: the part of the orbit where the old rule popped most.
const ARC: std::ops::Range<u32> = 2950..3250;
/// The novel pictures' size.
const SIZE: (u32, u32) = (160, 120);

/// The rule before issue 28, kept here to compare against.
fn old_weights(novel: &Camera, views: &[Camera], max_views: usize) -> Vec<(usize, f64)> {
    let dir = |c: &Camera| (c.rotation * glam::DVec3::Z).normalize_or(glam::DVec3::Z);
    let n = dir(novel);
    let c: Vec<(usize, f64, f64)> = views
        .iter()
        .enumerate()
        .filter_map(|(i, v)| {
            let beta = dir(v).dot(n).clamp(-1.0, 1.0).acos().to_degrees();
            (beta < 135.0).then(|| (i, beta, (v.translation - novel.translation).length()))
        })
        .collect();
    let mean = c.iter().map(|c| c.2).sum::<f64>() / c.len().max(1) as f64;
    let mut w: Vec<(usize, f64)> = c
        .iter()
        .map(|&(i, beta, d)| {
            let a = if beta < 45.0 {
                1.0
            } else {
                (beta - 45.0).to_radians().cos().max(0.0)
            };
            (i, a / (1.0 + d / mean))
        })
        .filter(|w| w.1 > 0.0)
        .collect();
    w.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    w.truncate(max_views);
    let total: f64 = w.iter().map(|w| w.1).sum();
    w.iter().map(|&(i, x)| (i, x / total)).collect()
}

fn new_weights(novel: &Camera, views: &[Camera], max_views: usize) -> anyhow::Result<Vec<(usize, f64)>> {
    Ok(
        select_views(novel, views, SelectionRule::Dmesh { max_angle_deg: 135.0 }, max_views)?
            .iter()
            .map(|w| (w.index, w.weight))
            .collect(),
    )
}

fn dense(w: &[(usize, f64)], n: usize) -> Vec<f64> {
    let mut d = vec![0.0; n];
    for &(i, x) in w {
        d[i] = x;
    }
    d
}

/// The share (per cent) of the pixels both pictures cover whose colour
/// changes by more than 8 of 255 in some channel: a pop shows as a spike.
fn change(a: &Blended, b: &Blended) -> f64 {
    let (mut changed, mut n) = (0usize, 0usize);
    for k in 0..a.depth.len() {
        if a.depth[k] > 0.0 && b.depth[k] > 0.0 {
            n += 1;
            if (0..3).any(|c| a.rgb[3 * k + c].abs_diff(b.rgb[3 * k + c]) > 8) {
                changed += 1;
            }
        }
    }
    100.0 * changed as f64 / n.max(1) as f64
}

fn main() -> anyhow::Result<()> {
    let out = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "docs/weights".into()));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let spec = SceneSpec::demo();
    let views = spec.rig.cameras(spec.width, spec.height, spec.fov_deg)?;
    let mut responses = Vec::new();
    let mut textures = Vec::new();
    for (k, cam) in views.iter().enumerate() {
        let v = render_view(&spec, cam, true, k as u64)?;
        let depth = DepthImage::from_z(cam.width, cam.height, v.depth.z.clone())?;
        let h = Hierarchy::build(&depth, cam, &Default::default())?;
        let ask = Ask::new(dmesh_proto::Lod::Epsilon(0.002), None, None)?;
        responses.push(render_plan::extract(&h, None, "demo", "v", &ask, |ms| ms)?.response);
        textures.push(Texture {
            width: v.color.width,
            height: v.color.height,
            rgb: v.color.rgb,
        });
    }
    let orbit = Rig::Ring {
        count: STEPS,
        radius: 3.3,
        heights: vec![1.8],
        target: [0.0, 0.4, 0.0],
    }
    .cameras(SIZE.0, SIZE.1, spec.fov_deg)?;
    let options = BlendOptions::default();
    let picture = |cam: &Camera, w: &[(usize, f64)]| {
        let inputs: Vec<ViewInput<'_>> = w
            .iter()
            .map(|&(i, weight)| ViewInput {
                weight,
                strips: &responses[i],
                texture: &textures[i],
            })
            .collect();
        blend(cam, &inputs, &options)
    };
    let mut csv =
        String::from("degrees,old_weight_moved,new_weight_moved,old_picture_change,new_picture_change,truth_change\n");
    let (mut wo, mut wn, mut po, mut pn, mut pt) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // Weight steps over the whole orbit.
    let (mut worst_old, mut worst_new, mut at_old) = (0f64, 0f64, 0usize);
    let n = views.len();
    let mut prev = None;
    for (k, cam) in orbit.iter().chain(std::iter::once(&orbit[0])).enumerate() {
        let w = (
            dense(&old_weights(cam, &views, 5), n),
            dense(&new_weights(cam, &views, 5)?, n),
        );
        if let Some((a, b)) = &prev {
            let moved = |x: &Vec<f64>, y: &Vec<f64>| 0.5 * x.iter().zip(y).map(|(p, q)| (p - q).abs()).sum::<f64>();
            if moved(a, &w.0) > worst_old {
                (worst_old, at_old) = (moved(a, &w.0), k);
            }
            worst_new = worst_new.max(moved(b, &w.1));
        }
        prev = Some(w);
    }
    // Pictures over the arc.
    let mut last: Option<(Blended, Blended, Blended)> = None;
    for k in ARC {
        let cam = &orbit[k as usize];
        let (ow, nw) = (old_weights(cam, &views, 5), new_weights(cam, &views, 5)?);
        let (old, new) = (picture(cam, &ow)?, picture(cam, &nw)?);
        let t = render_view(&spec, cam, true, 0)?;
        let truth = Blended {
            width: SIZE.0,
            height: SIZE.1,
            rgb: t.color.rgb,
            depth: t.depth.z,
            coverage: Vec::new(),
        };
        let deg = f64::from(k) / 10.0;
        if let Some((lo, ln, lt)) = &last {
            let prev_cam = &orbit[k as usize - 1];
            let moved = |a: &[(usize, f64)], b: &[(usize, f64)]| {
                0.5 * dense(a, n)
                    .iter()
                    .zip(dense(b, n))
                    .map(|(p, q)| (p - q).abs())
                    .sum::<f64>()
            };
            let (mo, mn) = (
                moved(&old_weights(prev_cam, &views, 5), &ow),
                moved(&new_weights(prev_cam, &views, 5)?, &nw),
            );
            let (co, cn, ct) = (change(lo, &old), change(ln, &new), change(lt, &truth));
            csv += &format!("{deg:.1},{mo:.6},{mn:.6},{co:.4},{cn:.4},{ct:.4}\n");
            wo.push((deg, mo));
            wn.push((deg, mn));
            po.push((deg, co));
            pn.push((deg, cn));
            pt.push((deg, ct));
        }
        last = Some((old, new, truth));
    }
    std::fs::write(out.join("steps.csv"), csv)?;
    Chart {
        title: "Weight moved between views per 0.1 degree step (demo orbit, 5 views)",
        x_label: "orbit angle (degrees)",
        y_label: "share of the total weight",
        series: vec![("before (hard cut)".into(), wo), ("after (ULR)".into(), wn)],
        linear_x: true,
        log_y: false,
        legend: SeriesLabelPosition::UpperRight,
    }
    .write(&out.join("weights"))?;
    Chart {
        title: "Pixels changing by more than 8/255 per 0.1 degree step",
        x_label: "orbit angle (degrees)",
        y_label: "per cent of the covered pixels",
        series: vec![
            ("blend before".into(), po.clone()),
            ("blend after".into(), pn.clone()),
            ("ground truth".into(), pt.clone()),
        ],
        linear_x: true,
        log_y: false,
        legend: SeriesLabelPosition::UpperRight,
    }
    .write(&out.join("frames"))?;
    let max = |v: &[(f64, f64)]| v.iter().map(|p| p.1).fold(0.0, f64::max);
    let median = |v: &[(f64, f64)]| {
        let mut s: Vec<f64> = v.iter().map(|p| p.1).collect();
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    };
    println!("the old rule's largest step: at {:.1} degrees", at_old as f64 / 10.0);
    println!("| rule | largest weight step, whole orbit | pixels changing > 8/255 per step on the arc: largest % | median % |");
    println!("|---|---|---|---|");
    println!(
        "| before (hard cut) | {worst_old:.4} | {:.2} | {:.2} |",
        max(&po),
        median(&po)
    );
    println!(
        "| after (ULR) | {worst_new:.4} | {:.2} | {:.2} |",
        max(&pn),
        median(&pn)
    );
    println!("| ground truth | | {:.2} | {:.2} |", max(&pt), median(&pt));
    Ok(())
}
