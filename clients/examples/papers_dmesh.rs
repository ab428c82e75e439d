//! DMesh's own experiments on its own terms (issue 29, part 2): Table 4
//! (triangles of static against view-dependent meshes for far, medium and
//! near cameras), Table 1's stages (build time per stage), the strip
//! lengths Sec. 7.2-7.3 report (20-40 triangles per strip static, 15-30
//! view-dependent) and Sec. 7.1's comparison of the segmentation methods
//! (Fig. 18: cost and quality). Prints Markdown for `docs/papers.md`.
//!
//! Usage: `cargo run --release -p dmesh-client --example papers_dmesh [-- [--quick] DATA_DIR]`
//! (default `../shared/data`; Art is left out when it is missing).
//! `--quick` runs every table once on small inputs, for the test that
//! keeps this example from rotting; its figures mean nothing.
//!
//! Everything runs in process on the engine: the demo scene's 16
//! references, the five the DMesh rule selects for a camera looking at the
//! scene's centre from 0.5, 1 and 3 times the rig's distance; static meshes
//! at DMesh's tolerance (epsilon = 1/1000 of the bounding box diagonal,
//! Table 2), view-dependent ones at tau = 1 px. Times are extraction only,
//! median of 5, one thread; the paper's rendering times need a GPU, which
//! this machine does not have.

use std::time::Instant;

use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Lod, Mesh, Method, Segmentation, Threads};
use dmesh_engine::scene::{select_views, SelectionRule};
use dmesh_engine::sim::rig::Rig;
use dmesh_engine::sim::{render_view, SceneSpec};

/// `--quick`: one run of everything, on small inputs.
static QUICK: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn quick() -> bool {
    QUICK.load(std::sync::atomic::Ordering::Relaxed)
}

/// Runs per timing: 5, or 1 when quick.
fn runs() -> usize {
    if quick() {
        1
    } else {
        5
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The mesh of `h` at `lod` and its median extraction time over 5 runs.
fn timed(h: &Hierarchy, lod: Lod<'_>) -> anyhow::Result<(Mesh, f64)> {
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..runs() {
        let t = Instant::now();
        let m = h.extract(lod)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
        last = Some(m);
    }
    Ok((last.expect("at least one run"), median(times)))
}

fn per_strip(m: &Mesh) -> f64 {
    m.triangles.len() as f64 / m.strip_count().max(1) as f64
}

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(k) = args.iter().position(|a| a == "--quick") {
        args.remove(k);
        QUICK.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    let data = std::path::PathBuf::from(args.first().cloned().unwrap_or_else(|| "../shared/data".into()));
    let spec = SceneSpec::demo();
    let views = spec.rig.cameras(spec.width, spec.height, spec.fov_deg)?;
    let mut meshes = Vec::new();
    let (mut lo, mut hi) = (glam::DVec3::splat(f64::INFINITY), glam::DVec3::splat(f64::NEG_INFINITY));
    for (k, cam) in views.iter().enumerate() {
        let v = render_view(&spec, cam, true, k as u64)?;
        let depth = DepthImage::from_z(cam.width, cam.height, v.depth.z)?;
        let h = Hierarchy::build(&depth, cam, &Default::default())?;
        for y in (0..cam.height).step_by(4) {
            for x in (0..cam.width).step_by(4) {
                if h.depth((x, y)) > 0.0 {
                    let p = cam.to_world(h.position((x, y)));
                    (lo, hi) = (lo.min(p), hi.max(p));
                }
            }
        }
        meshes.push(h);
    }
    let epsilon = (hi - lo).length() / 1000.0;
    println!("### Table 4: static against view-dependent meshes\n");
    println!(
        "The demo scene's 16 references (256 x 192); the five the DMesh rule selects; static at epsilon = {:.1} mm (1/1000 of the bounding box diagonal, as in Table 2), view-dependent at tau = 1 px. Extraction only, one thread, median of 5.\n",
        epsilon * 1e3
    );
    println!("| range | distance | triangles static | triangles view-dependent | extraction ms static | extraction ms view-dependent | triangles per strip static | view-dependent |");
    println!("|---|---|---|---|---|---|---|---|");
    let (radius, height, target) = (3.3, 1.8, [0.0, 0.4, 0.0]);
    for (name, scale) in [("far", 3.0), ("medium", 1.0), ("near", 0.5)] {
        let cam: Camera = Rig::Ring {
            count: 8,
            radius: radius * scale,
            heights: vec![target[1] + (height - target[1]) * scale],
            target,
        }
        .cameras(256, 192, spec.fov_deg)?[3];
        let selected = select_views(&cam, &views, SelectionRule::Dmesh { max_angle_deg: 135.0 }, 5)?;
        let (mut ts, mut td, mut ms, mut md, mut ss, mut sd) = (0, 0, 0.0, 0.0, 0usize, 0usize);
        for w in &selected {
            let h = &meshes[w.index];
            let (s, t_s) = timed(h, Lod::Epsilon(epsilon))?;
            let (d, t_d) = timed(h, Lod::Tau { tau: 1.0, view: &cam })?;
            (ts, td, ms, md) = (ts + s.triangles.len(), td + d.triangles.len(), ms + t_s, md + t_d);
            (ss, sd) = (ss + s.strip_count(), sd + d.strip_count());
        }
        println!(
            "| {name} | {:.1} m | {ts} | {td} | {ms:.2} | {md:.2} | {:.1} | {:.1} |",
            radius * scale,
            ts as f64 / ss.max(1) as f64,
            td as f64 / sd.max(1) as f64
        );
    }
    println!("\n### Table 1's stages: build time per stage\n");
    println!("One thread, median of 5 builds per scene; strips: a static extraction at 0.5 % of a typical depth, with its strips. DMesh's Table 1 splits its initialisation the same way (back-projection, error metric, normals and rho, segmentation flags, strips).\n");
    println!("| scene | size | depths onto the grid | normals and rho | segmentation | finest level | coarse levels (exact deviations) | border | whole build | strips (extraction) |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut cases: Vec<(String, DepthImage, Camera, f64)> = Vec::new();
    let size = if quick() { 65 } else { 513 };
    let (d, c) = dmesh_engine::synthetic::terrain_with_boxes(size, size);
    cases.push(("synthetic".into(), d, c, 10.0));
    let middlebury: &[&str] = if quick() { &[] } else { &["cones", "art", "reindeer"] };
    for &name in middlebury {
        if let Ok(case) = dmesh_client::report::cases::middlebury(&data, name) {
            let r = &case.references[0];
            cases.push((name.into(), r.depth.clone(), r.camera, case.depth_scale));
        }
    }
    let mut shares: Vec<(String, f64, [f64; 3])> = Vec::new();
    for (name, depth, cam, scale) in &cases {
        let mut runs: Vec<(f64, dmesh_engine::mesh::Stages, f64)> = (0..runs())
            .map(|_| {
                let h = Hierarchy::build_with(depth, cam, &Default::default(), dmesh_engine::mesh::Threads::Single)?;
                let s = h.stats();
                let m = h.extract(Lod::Epsilon(0.005 * scale))?;
                anyhow::Ok((s.build_ms, s.stages, m.extract_ms))
            })
            .collect::<anyhow::Result<_>>()?;
        runs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (ms, st, ex) = runs[runs.len() / 2];
        let pixels = f64::from(depth.width) * f64::from(depth.height);
        shares.push((
            name.clone(),
            ms / pixels,
            [st.coarse_ms / ms, st.finest_ms / ms, st.normals_ms / ms],
        ));
        println!(
            "| {name} | {} x {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {ms:.2} | {ex:.2} |",
            depth.width,
            depth.height,
            st.depths_ms,
            st.normals_ms,
            st.flags_ms,
            st.finest_ms,
            st.coarse_ms,
            st.border_ms
        );
    }
    let range = |k: usize| {
        let v = shares.iter().map(|s| 100.0 * s.2[k]);
        let (lo, hi) = v.fold((f64::INFINITY, 0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
        format!("{lo:.0}-{hi:.0} %")
    };
    println!(
        "\nShares of the whole build: coarse levels {}, finest level {}, normals and rho {}. Build time per pixel (ns): {}.",
        range(0),
        range(1),
        range(2),
        shares
            .iter()
            .map(|(n, per_pixel, _)| format!("{n} {:.0}", per_pixel * 1e6))
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!("\n### Strip lengths by tolerance\n");
    println!("Triangles per strip of one reference's mesh, static (epsilon as a fraction of a typical depth: 4 m for the demo, the report's depth scale for Art) and view-dependent (tau, the reference's own camera).\n");
    println!("| scene | tolerance | triangles | strips | triangles per strip |");
    println!("|---|---|---|---|---|");
    let mut scenes: Vec<(String, Hierarchy, f64)> = Vec::new();
    let demo_view = &meshes[4];
    scenes.push(("demo v04".into(), demo_view.clone(), 4.0));
    match dmesh_client::report::cases::middlebury(&data, "art") {
        Ok(_) if quick() => {}
        Ok(case) => {
            let r = &case.references[0];
            let h = Hierarchy::build(&r.depth, &r.camera, &Default::default())?;
            scenes.push(("art (left view)".into(), h, case.depth_scale));
        }
        Err(e) => println!("<!-- art left out: {e} -->"),
    }
    for (name, h, scale) in &scenes {
        for rel in [0.001, 0.005, 0.02] {
            let m = h.extract(Lod::Epsilon(rel * scale))?;
            println!(
                "| {name} | epsilon {:.1} % of {scale:.1} m | {} | {} | {:.1} |",
                rel * 100.0,
                m.triangles.len(),
                m.strip_count(),
                per_strip(&m)
            );
        }
        let cam = *h.camera();
        for tau in [0.5, 1.0, 4.0] {
            let m = h.extract(Lod::Tau { tau, view: &cam })?;
            println!(
                "| {name} | tau {tau} px | {} | {} | {:.1} |",
                m.triangles.len(),
                m.strip_count(),
                per_strip(&m)
            );
        }
    }
    segmentation_methods(&data)?;
    Ok(())
}

/// Sec. 7.1 and Fig. 18: the three segmentation methods and none, in build
/// time and in the quality of the blend of the references each builds.
fn segmentation_methods(data: &std::path::Path) -> anyhow::Result<()> {
    use dmesh_client::blend::{blend, BlendOptions, ViewInput};
    use dmesh_client::report::cases::{self, Case};
    use dmesh_engine::mesh::segmentation::{KAPPA, LAMBDA, OMEGA_DEG, SIGMA};
    use dmesh_engine::render_plan::{self, Ask};
    println!("\n### Sec. 7.1 and Fig. 18: segmentation methods\n");
    println!(
        "Each method at the server's default threshold (orthogonality omega = {OMEGA_DEG} degrees, disparity sigma = {SIGMA}, connectedness kappa = {KAPPA}; the depth-range gate lambda = {LAMBDA} for all). \
         Build: one thread, median of 5 builds of each reference, summed; the segmentation stage (the leaf tests, which is all that differs) beside it; connectedness also needs the normals first, which every build computes anyway. \
         Blend: each novel view from the references the DMesh rule selects, view-dependent at tau = 1 px, blended by the CPU client without gap filling, scored against the ground truth. \
         PSNR over the pixels every method covers (the common mask) and over each method's own; coverage is the share of the image each covers. \
         The demo scene: 16 references of 256 x 192, 8 novel views around it. Art: the left view warped to the right one.\n"
    );
    println!("| scene | method | build ms | of which segmentation ms | segmented triangles | PSNR dB, common mask | PSNR dB, own mask | coverage |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut scenes: Vec<Case> = vec![cases::simulated("demo", false, if quick() { 2 } else { 8 })?];
    match cases::middlebury(data, "art") {
        Ok(_) if quick() => {}
        Ok(case) => scenes.push(case),
        Err(e) => println!("<!-- art left out: {e} -->"),
    }
    let methods = [
        ("orthogonality", Method::Orthogonality { omega_deg: OMEGA_DEG }),
        ("disparity", Method::Disparity { sigma: SIGMA }),
        ("connectedness", Method::Connectedness { kappa: KAPPA }),
        ("none", Method::None),
    ];
    for case in &scenes {
        let cameras: Vec<Camera> = case.references.iter().map(|r| r.camera).collect();
        // Per method: build ms, segmented triangles, and per novel view the
        // blended image and its coverage.
        let mut results = Vec::new();
        for (name, method) in methods {
            let seg = Segmentation {
                method,
                ..Default::default()
            };
            let (mut build_ms, mut flags_ms, mut segmented) = (0.0, 0.0, 0);
            let mut hierarchies = Vec::new();
            for r in &case.references {
                let (mut times, mut flag_times) = (Vec::new(), Vec::new());
                let mut last = None;
                for _ in 0..runs() {
                    let h = Hierarchy::build_with(&r.depth, &r.camera, &seg, Threads::Single)?;
                    times.push(h.stats().build_ms);
                    flag_times.push(h.stats().stages.flags_ms);
                    last = Some(h);
                }
                let h = last.ok_or_else(|| anyhow::anyhow!("no build"))?;
                build_ms += median(times);
                flags_ms += median(flag_times);
                segmented += h.stats().segmented_triangles;
                hierarchies.push(h);
            }
            let mut blends = Vec::new();
            for novel in &case.novels {
                let selected = render_plan::select(&novel.camera, &cameras, dmesh_proto::Selection::Dmesh, None, None)?;
                let mut responses = Vec::new();
                for w in &selected {
                    let ask = Ask::new(dmesh_proto::Lod::Tau(1.0), Some(novel.camera), None)?.share(w.weight);
                    let r = &case.references[w.index];
                    let out = render_plan::extract(&hierarchies[w.index], r.raw_grid, &case.name, "v", &ask, |ms| ms)?;
                    responses.push((w.weight, out.response, &r.texture));
                }
                let inputs = ViewInput::of_responses(&responses);
                let options = BlendOptions {
                    fill_gaps: 0,
                    ..BlendOptions::default()
                };
                blends.push(blend(&novel.camera, &inputs, &options)?);
            }
            results.push((name, build_ms, flags_ms, segmented, blends));
        }
        // The common mask: covered by every method and valid in the truth.
        for (name, build_ms, flags_ms, segmented, blends) in &results {
            let (mut common, mut own, mut cover) = ((0.0, 0usize), (0.0, 0usize), 0.0);
            for (k, (b, novel)) in blends.iter().zip(&case.novels).enumerate() {
                let n = novel.depth.len();
                let mut covered = 0usize;
                for i in 0..n {
                    if novel.depth[i] <= 0.0 || b.depth[i] <= 0.0 {
                        continue;
                    }
                    covered += 1;
                    let se: f64 = (0..3)
                        .map(|c| (f64::from(b.rgb[3 * i + c]) - f64::from(novel.rgb[3 * i + c])).powi(2))
                        .sum::<f64>()
                        / 3.0;
                    own = (own.0 + se, own.1 + 1);
                    if results.iter().all(|(_, _, _, _, other)| other[k].depth[i] > 0.0) {
                        common = (common.0 + se, common.1 + 1);
                    }
                }
                cover += covered as f64 / n as f64;
            }
            let psnr = |(se, count): (f64, usize)| 10.0 * (255.0f64 * 255.0 / (se / count.max(1) as f64)).log10();
            println!(
                "| {} | {name} | {build_ms:.1} | {flags_ms:.2} | {segmented} | {:.2} | {:.2} | {:.1} % |",
                case.name,
                psnr(common),
                psnr(own),
                100.0 * cover / case.novels.len().max(1) as f64
            );
        }
    }
    Ok(())
}
