//! End to end: simulate the box scene, start the real server on port 0,
//! ingest through the client, render novel views by blending, and measure
//! them against the simulator's ground truth.

mod common;

use common::{ingest, start};
use dmesh_client::blend::{BlendOptions, Blended};
use dmesh_client::compare::compare;
use dmesh_client::http::Server;
use dmesh_client::loadtest::Detail;
use dmesh_client::novel::render_novel;
use dmesh_engine::camera::Camera;
use dmesh_engine::sim::rig::camera;
use dmesh_engine::sim::SceneSpec;
use glam::DVec3;

async fn render(server: &Server, novel: &Camera, tau: f64, max_views: u32) -> Blended {
    let request = Detail {
        lod: dmesh_proto::Lod::Tau(tau),
        max_views: Some(max_views),
        ..Default::default()
    }
    .request(novel.into());
    render_novel(server, "box", &request, &BlendOptions::default())
        .await
        .unwrap()
}

fn novel(scene: &SceneSpec, angle: f64, height: f64) -> Camera {
    let target = DVec3::new(0.0, 0.4, 0.0);
    let eye = DVec3::new(4.0 * angle.sin(), height, 4.0 * angle.cos());
    camera(scene.width, scene.height, scene.fov_deg, eye, target).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_view_at_its_own_camera_reproduces_its_colour() {
    let running = start().await;
    let server = Server::new(&running.base, None);
    let scene = SceneSpec::demo();
    ingest(&server, "box", &scene).await;
    let refs = scene.reference_views().unwrap();
    for k in [0usize, 3, 9] {
        let cam = refs[k].camera;
        let blended = render(&server, &cam, 0.5, 1).await;
        let c = compare(
            &blended.rgb,
            &refs[k].color.rgb,
            Some((&blended.depth, &refs[k].depth.z)),
        )
        .unwrap();
        println!("view {k}: PSNR {:.2} dB over {:.1} %", c.psnr, 100.0 * c.valid_fraction);
        if let Ok(dir) = std::env::var("DMESH_E2E_DUMP") {
            image::RgbImage::from_raw(cam.width, cam.height, blended.rgb.clone())
                .unwrap()
                .save(format!("{dir}/self-{k}.png"))
                .unwrap();
        }
        assert!(c.psnr >= 40.0, "view {k}: {:.2} dB", c.psnr);
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn blended_novel_views_match_ground_truth() {
    let running = start().await;
    let server = Server::new(&running.base, None);
    let scene = SceneSpec::demo();
    ingest(&server, "box", &scene).await;
    let step = std::f64::consts::TAU / 8.0;
    for (angle, height) in [(0.5 * step, 1.2), (2.3 * step, 1.9), (5.5 * step, 2.6)] {
        let cam = novel(&scene, angle, height);
        let truth = scene.ground_truth(&cam).unwrap();
        let blended = render(&server, &cam, 1.0, 5).await;
        let c = compare(&blended.rgb, &truth.color.rgb, Some((&blended.depth, &truth.depth.z))).unwrap();
        println!(
            "angle {angle:.2} height {height}: PSNR {:.2} dB over {:.1} %",
            c.psnr,
            100.0 * c.valid_fraction
        );
        if let Ok(dir) = std::env::var("DMESH_E2E_DUMP") {
            let save = |name: &str, rgb: &[u8]| {
                image::RgbImage::from_raw(cam.width, cam.height, rgb.to_vec())
                    .unwrap()
                    .save(format!("{dir}/{name}-{angle:.2}.png"))
                    .unwrap()
            };
            save("blend", &blended.rgb);
            save("truth", &truth.color.rgb);
        }
        assert!(c.psnr >= 30.0, "PSNR {:.2} dB at angle {angle}", c.psnr);
        assert!(
            c.valid_fraction > 0.5,
            "only {:.2} of the view covered",
            c.valid_fraction
        );
    }
    // Between two references, blending the selected views beats the best single one.
    let cam = novel(&scene, 0.5 * step, 1.9);
    let truth = scene.ground_truth(&cam).unwrap();
    let psnr = |b: &Blended| compare(&b.rgb, &truth.color.rgb, Some((&b.depth, &truth.depth.z))).unwrap();
    let blended = psnr(&render(&server, &cam, 1.0, 5).await);
    let single = psnr(&render(&server, &cam, 1.0, 1).await);
    println!(
        "blend {:.2} dB ({:.3}), single {:.2} dB ({:.3})",
        blended.psnr, blended.valid_fraction, single.psnr, single.valid_fraction
    );
    assert!(blended.psnr > single.psnr, "blending did not beat the best single view");
    assert!(blended.valid_fraction >= single.valid_fraction);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn no_rubber_sheet_between_the_pole_and_the_wall() {
    let running = start().await;
    let server = Server::new(&running.base, None);
    let scene = SceneSpec::demo();
    ingest(&server, "box", &scene).await;
    // From the -z side the pole (z = 1) stands in front of the wall (z = 1.5).
    let cam = novel(&scene, std::f64::consts::PI + 0.2, 1.0);
    let truth = scene.ground_truth(&cam).unwrap();
    let blended = render(&server, &cam, 1.0, 5).await;
    // Pixels whose depth lies between the pole's and the wall's, where the
    // truth is either: a rubber sheet spans the gap. Silhouette pixels may
    // flip between the two surfaces, never land in between.
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut gap = 0;
    let mut examples = Vec::new();
    let mut pole_pixels = 0;
    for y in 0..h {
        for x in 1..w - 1 {
            let i = y * w + x;
            let (zr, zt) = (blended.depth[i], truth.depth.z[i]);
            if zr <= 0.0 || zt <= 0.0 {
                continue;
            }
            // Near a depth jump of the truth (the pole's silhouette against the wall).
            let (l, r) = (truth.depth.z[i - 1], truth.depth.z[i + 1]);
            let (near, far) = (l.min(r).min(zt), l.max(r).max(zt));
            if far - near > 0.3 {
                pole_pixels += 1;
                // The middle half of the gap: silhouettes may shift by a pixel
                // onto the neighbouring surface (a little off its depth), a
                // rubber sheet crosses the middle.
                let in_gap = |z: f32| z > near + 0.25 * (far - near) && z < far - 0.25 * (far - near);
                // Only where the truth is on one of the two surfaces, and
                // off every surface around the pixel: a silhouette drawn
                // to its reference pixels' edges (a cut's part ends half a
                // sample past its last one) may land on a third surface
                // beside it, a little off its depth, which is no sheet.
                let around = (y.saturating_sub(1)..(y + 2).min(h))
                    .flat_map(|yy| (x - 1..x + 2).map(move |xx| yy * w + xx))
                    .any(|j| (truth.depth.z[j] - zr).abs() <= 0.05 * zr);
                if in_gap(zr) && !in_gap(zt) && !around {
                    gap += 1;
                    examples.push((x, y, zr, zt));
                }
            }
        }
    }
    println!("{pole_pixels} pixels at depth jumps, {gap} in the gap");
    assert!(pole_pixels > 20, "the view does not show the pole against the wall");
    assert_eq!(gap, 0, "{gap} rubber-sheet pixels (x, y, drawn, true): {examples:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_load_test_stops_by_itself_and_counts_everything() {
    let running = start().await;
    let server = Server::new(&running.base, None);
    let scene = SceneSpec::demo();
    ingest(&server, "box", &scene).await;
    let cameras = dmesh_client::loadtest::orbit(&server.cameras("box").await.unwrap(), 6).unwrap();
    let stop = dmesh_client::loadtest::Stop::Requests(24);
    let report = dmesh_client::loadtest::run(&server, "box", &cameras, Detail::default(), 4, stop)
        .await
        .unwrap();
    assert_eq!(report.requests, 24);
    assert_eq!(report.errors, 0, "{:?}", report.errors_by_status);
    assert!(report.p50_ms > 0.0 && report.p99_ms >= report.p50_ms && report.max_ms >= report.p99_ms);
    assert!(report.bytes > 0 && report.throughput_rps > 0.0);
    // Asking for a scene that does not exist counts 404s instead of failing.
    let missing = dmesh_client::loadtest::run(
        &server,
        "nope",
        &cameras,
        Detail::default(),
        2,
        dmesh_client::loadtest::Stop::Requests(4),
    )
    .await
    .unwrap();
    assert_eq!(
        (missing.errors, missing.errors_by_status.get(&404).copied()),
        (4, Some(4))
    );
}

fn seam_pixels(b: &Blended, truth: &[f32]) -> usize {
    seams(b, truth).len()
}

/// Uncovered pixels of `b` on a surface the truth shows, with covered pixels
/// of that surface on both sides at most two pixels apart along a row, a
/// column or a diagonal: the seams the blend must not leave.
fn seams(b: &Blended, truth: &[f32]) -> Vec<usize> {
    let (w, h) = (i64::from(b.width), i64::from(b.height));
    // On the truth's surface: within 5 % per pixel away (oblique surfaces).
    let near = |j: usize, z: f32, t: i64| b.depth[j] > 0.0 && (b.depth[j] - z).abs() <= 0.05 * t as f32 * z;
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let i = (y * w + x) as usize;
            let z = truth[i];
            b.depth[i] == 0.0
                && z > 0.0
                && [(1, 0), (0, 1), (1, 1), (1, -1)].iter().any(|&(dx, dy)| {
                    let side = |s: i64| {
                        (1..=2).find(|&t| {
                            let (px, py) = (x + s * t * dx, y + s * t * dy);
                            px >= 0 && py >= 0 && px < w && py < h && near((py * w + px) as usize, z, t)
                        })
                    };
                    matches!((side(1), side(-1)), (Some(a), Some(b)) if a + b - 1 <= 2)
                })
        })
        .map(|(x, y)| (y * w + x) as usize)
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn seams_between_references_are_filled_and_disocclusions_kept() {
    let running = start().await;
    let server = Server::new(&running.base, None);
    let scene = SceneSpec::demo();
    ingest(&server, "box", &scene).await;
    let step = std::f64::consts::TAU / 8.0;
    let (mut before, mut filled_total, mut holes_kept, mut wrong, mut beside) = (0, 0, 0, 0, 0);
    // Halfway between neighbouring references, at 320 x 240.
    for k in 0..8 {
        let angle = (k as f64 + 0.5) * step;
        let eye = DVec3::new(4.0 * angle.sin(), 1.2, 4.0 * angle.cos());
        let cam = camera(320, 240, scene.fov_deg, eye, DVec3::new(0.0, 0.4, 0.0)).unwrap();
        let truth = scene.ground_truth(&cam).unwrap();
        let request = Detail {
            lod: dmesh_proto::Lod::Tau(1.0),
            ..Default::default()
        }
        .request((&cam).into());
        let raw = render_novel(
            &server,
            "box",
            &request,
            &BlendOptions {
                fill_gaps: 0,
                ..Default::default()
            },
        )
        .await
        .unwrap();
        let filled = render_novel(&server, "box", &request, &BlendOptions::default())
            .await
            .unwrap();
        let raw_seams = seam_pixels(&raw, &truth.depth.z);
        before += raw_seams;
        // Every seam of the blend is filled.
        let left: Vec<usize> = seams(&raw, &truth.depth.z)
            .into_iter()
            .filter(|&i| filled.depth[i] == 0.0)
            .collect();
        assert!(
            left.is_empty(),
            "angle {angle:.2}: {} of {raw_seams} seam pixels left, e.g. {:?}",
            left.len(),
            &left[..left.len().min(5)]
        );
        for i in 0..raw.depth.len() {
            if raw.depth[i] == 0.0 && filled.depth[i] > 0.0 {
                filled_total += 1;
                // Filled from the surface that is really there, unless a
                // disocclusion as thin as a seam hides behind it; a pixel
                // of background beside a silhouette (drawn to its reference
                // pixels' edges) may be filled too.
                let z = truth.depth.z[i];
                if z == 0.0 {
                    beside += 1;
                } else if (filled.depth[i] - z).abs() > 0.1 * z {
                    wrong += 1;
                }
            }
            if raw.depth[i] == 0.0 && filled.depth[i] == 0.0 {
                holes_kept += 1;
            }
        }
    }
    println!(
        "{before} seam pixels without filling, {filled_total} filled ({wrong} off the true surface, {beside} background beside a silhouette), {holes_kept} uncovered kept"
    );
    assert!(
        wrong * 20 <= filled_total,
        "{wrong} of {filled_total} filled pixels are off the true surface"
    );
    assert!(
        beside * 5 <= filled_total,
        "{beside} of {filled_total} filled pixels are background beside a silhouette"
    );
    assert!(before > 0, "the views between references show seams to fill");
    assert!(holes_kept > 0, "disocclusions and the background stay uncovered");
}
