//! Walkthroughs against the real server (in process): the balanced refresh
//! never plans past its budget, holes are counted apart, ages grow by one
//! per frame and reset on refresh, a still camera draws the same image with
//! every strategy after the first frame, and a cut becomes holes.

mod common;

use common::{ingest, start};
use dmesh_client::http::Server;
use dmesh_client::walkthrough::path::{Key, Path};
use dmesh_client::walkthrough::policy::{Budget, Policy, Strategy};
use dmesh_client::walkthrough::{run, Frame, Options, Scene};
use dmesh_engine::sim::SceneSpec;

/// Six keys on a circle of radius 3.3 around the demo scene, over `arc` radians.
fn orbit(frames: u32, arc: f64, cut: bool) -> Path {
    let keys = (0..6)
        .map(|k| {
            let a = f64::from(k) * arc / 6.0;
            Key {
                eye: [3.3 * a.cos(), 1.8, 3.3 * a.sin()],
                target: [0.0, 0.4, 0.0],
                cut: cut && k == 3,
            }
        })
        .collect();
    Path {
        width: 128,
        height: 96,
        fov_deg: 60.0,
        frames,
        closed: false,
        keys,
    }
}

fn still(frames: u32) -> Path {
    let key = Key {
        eye: [3.0, 1.6, 1.0],
        target: [0.0, 0.4, 0.0],
        cut: false,
    };
    Path {
        width: 128,
        height: 96,
        fov_deg: 60.0,
        frames,
        closed: false,
        keys: vec![key.clone(), key],
    }
}

/// Walks `path` balanced under `budget`, with the default options.
async fn walk_balanced(server: &Server, scene: &Scene, path: &Path, budget: Budget) -> Vec<Frame> {
    let policy = Policy::new(Strategy::Balanced, budget);
    run(server, scene, path, &policy, &Options::default(), |_| {})
        .await
        .unwrap()
}

async fn setup() -> (common::Running, Server, Scene) {
    let running = start().await;
    let server = Server::new(&running.base, None);
    ingest(&server, "box", &SceneSpec::demo()).await;
    let scene = Scene::load(&server, "box").await.unwrap();
    (running, server, scene)
}

/// Every round that refreshed kept to its budget. Returns how many rounds
/// refreshed, so a caller can require that the check was not vacuous.
fn assert_within_budget(frames: &[Frame]) -> usize {
    let refreshing = frames.iter().filter(|f| f.refreshed > 0).count();
    for f in frames {
        let budget = f.budget.expect("balanced frames have a budget");
        if f.refreshed > 0 {
            assert!(
                f.planned_holes + f.planned_refresh <= budget,
                "frame {}: holes {} + refresh {} > budget {budget}",
                f.frame,
                f.planned_holes,
                f.planned_refresh
            );
        }
    }
    refreshing
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn balanced_refresh_keeps_to_its_budget_and_ages_count_frames() {
    let (_running, server, scene) = setup().await;
    // About 9 cm a frame: held meshes serve several frames.
    let path = orbit(40, std::f64::consts::FRAC_PI_3, false);
    let budget = Budget::OneView;
    let frames = walk_balanced(&server, &scene, &path, budget).await;
    // The budget is put to the test: some round refreshed.
    assert!(assert_within_budget(&frames) > 0, "the orbit refreshes something");
    assert!(
        frames[0].holes > 0 && frames[0].missing == frames[0].holes,
        "the first frame is all holes"
    );
    for pair in frames.windows(2) {
        let before: std::collections::HashMap<usize, u32> = pair[0].ages.iter().copied().collect();
        let fetched = pair[1].holes + pair[1].refreshed;
        let mut zeros = 0;
        for &(v, age) in &pair[1].ages {
            if age == 0 {
                zeros += 1;
            } else if let Some(&was) = before.get(&v) {
                assert_eq!(
                    age,
                    was + 1,
                    "frame {}: view {v} aged from {was} to {age}",
                    pair[1].frame
                );
            }
        }
        assert_eq!(
            zeros, fetched,
            "frame {}: every drawn mesh of age 0 was fetched",
            pair[1].frame
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_still_camera_draws_the_same_image_with_every_strategy() {
    let (_running, server, scene) = setup().await;
    let dir = tempfile::tempdir().unwrap();
    let path = still(6);
    for strategy in [Strategy::Full, Strategy::Keyframe { every: 3 }, Strategy::Balanced] {
        let options = Options {
            frames_out: Some(dir.path().join(strategy.name())),
            truth: Some(SceneSpec::demo()),
            ..Options::default()
        };
        let frames = run(
            &server,
            &scene,
            &path,
            &Policy::new(strategy, Budget::OneView),
            &options,
            |_| {},
        )
        .await
        .unwrap();
        for f in &frames {
            // Against the simulator's truth for the same camera. Cut
            // outlines draw silhouettes to their reference pixels' edges,
            // whose colour is half the neighbouring surface's: more pixels
            // are compared, at about 30 dB.
            let (psnr, coverage) = (f.psnr.unwrap(), f.coverage.unwrap());
            assert!(
                psnr > 29.5 && coverage > 0.95,
                "frame {}: {psnr} dB, coverage {coverage}",
                f.frame
            );
        }
        if strategy == Strategy::Balanced {
            // Nothing moves, so nothing goes stale: after the first frame only refreshes.
            assert!(frames.iter().skip(1).all(|f| f.holes == 0));
            assert!(
                frames.iter().skip(1).all(|f| f.refreshed == 1),
                "one view's worth refreshes the oldest"
            );
        }
    }
    let image = |s: &str, t: u32| {
        image::open(dir.path().join(s).join(format!("frame-{t:04}.png")))
            .unwrap()
            .to_rgb8()
    };
    for t in 1..6 {
        let full = image("full", t);
        assert!(full.pixels().any(|p| p.0 != [0, 0, 0]), "frame {t} draws something");
        assert_eq!(full, image("keyframe", t), "frame {t}: keyframe differs from full");
        assert_eq!(full, image("balanced", t), "frame {t}: balanced differs from full");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cut_turns_into_holes_not_budget_overruns() {
    let (_running, server, scene) = setup().await;
    let path = orbit(40, std::f64::consts::TAU, true);
    let budget = Budget::Triangles(2000.0);
    let frames = walk_balanced(&server, &scene, &path, budget).await;
    assert_within_budget(&frames);
    // Where the holes alone take the budget, nothing is refreshed: the
    // budget is spent on holes, not overrun (and the walk has such rounds).
    let full: Vec<&Frame> = frames
        .iter()
        .filter(|f| f.budget.is_some_and(|b| f.planned_holes >= b))
        .collect();
    assert!(!full.is_empty(), "no round's holes took the whole budget");
    for f in full {
        assert_eq!(
            f.refreshed, 0,
            "frame {} refreshed past a budget its holes took",
            f.frame
        );
    }
    // The jump: the frame after it fetches holes (stale or uncovered), and far more than its neighbours.
    let eyes: Vec<glam::DVec3> = (0..40).map(|t| path.camera(t).unwrap().translation).collect();
    let jump = (1..40)
        .max_by(|&a, &b| {
            let d = |t: usize| (eyes[t] - eyes[t - 1]).length();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let at = &frames[jump];
    assert!(at.holes >= 2, "the cut at frame {jump} made {} holes", at.holes);
    assert!(at.stale + at.uncovered + at.missing == at.holes);
}

/// The committed walkthroughs' plots redraw from their CSV and JSON alone.
#[test]
fn saved_walkthroughs_replot_from_their_csv() {
    let dir = tempfile::tempdir().unwrap();
    let docs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/walkthrough");
    for ext in ["csv", "json"] {
        std::fs::copy(
            docs.join(format!("demo-orbit.{ext}")),
            dir.path().join(format!("demo-orbit.{ext}")),
        )
        .unwrap();
    }
    dmesh_client::walkthrough::summary::replot(dir.path(), "demo-orbit").unwrap();
    for chart in ["frame-ms", "fetch-ms", "psnr"] {
        let png = image::open(dir.path().join(format!("demo-orbit-{chart}.png"))).unwrap();
        assert_eq!((png.width(), png.height()), (800, 520), "{chart}");
        let svg = std::fs::read_to_string(dir.path().join(format!("demo-orbit-{chart}.svg"))).unwrap();
        assert!(svg.contains("balanced") && svg.contains("keyframe"), "{chart}");
    }
    assert!(dmesh_client::walkthrough::summary::replot(dir.path(), "nowhere").is_err());
}
