//! The thesis's comparison (`report --baselines`): the scenes load with
//! their published geometry, every mesher meets its rate and scores, the
//! files are written, the committed results are whole, and bad options are
//! refused clearly.

use std::path::{Path, PathBuf};
use std::process::Command;

use dmesh_client::report::baselines::{compare_case, markdown, write, Options, DIBR, FULL, RATES, SCENES};
use dmesh_client::report::cases;
use dmesh_engine::baselines;

fn data() -> PathBuf {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    assert!(data.is_dir(), "the Middlebury data must be at {}", data.display());
    data
}

/// Art (2005, half size) warped at full resolution: with `dmin` and the
/// published focal length the right view is matched (a wrong offset or
/// disparity scale shifts every pixel and the PSNR falls below 15 dB).
#[test]
fn a_2005_scene_warps_onto_its_right_view() {
    let case = cases::middlebury(&data(), "art").unwrap();
    let r = &case.references[0];
    assert_eq!((r.camera.width, r.camera.height), (695, 555));
    let fb = case.focal_baseline.unwrap();
    assert!((fb - 1870.0 * 0.16).abs() < 1e-9, "{fb}");
    // The nearest valid disparity is at least dmin / 2 = 100 half-size pixels.
    let far = r.depth.z.iter().fold(0f32, |a, &z| a.max(z));
    assert!(f64::from(far) <= fb / 100.0 + 1e-6, "{far}");
    let options = Options {
        scenes: vec![],
        rates: vec![],
        repeats: 1,
    };
    let rows = compare_case(&case, &[], &options).unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0].mesher, FULL);
    assert!(rows[0].psnr > 24.0, "{:?}", rows[0]);
    assert!((rows[0].coverage - 1.0).abs() < 1e-12);
    // The valid mask is the left-right check: no pixel of the full mesh's
    // own warp in it is off by more than a pixel of disparity.
    assert_eq!(rows[0].bad_pixels_common, 0.0, "{:?}", rows[0]);
    // Per-pixel DIBR: splats cover nearly all of the mask, and score near
    // the full mesh (it is the same depth, without the triangles between).
    let dibr = &rows[1];
    assert_eq!(dibr.mesher, DIBR);
    assert!(dibr.coverage > 0.95 && dibr.coverage <= 1.0 + 1e-12, "{dibr:?}");
    assert!((dibr.psnr - rows[0].psnr).abs() < 3.0, "{dibr:?} against {:?}", rows[0]);
    // Its errors are the classic ones: a background splat in a crack of
    // the foreground, a fraction of a per cent of the pixels.
    assert!(dibr.disparity_mse_full_common.is_finite(), "{dibr:?}");
    assert!(dibr.bad_pixels_common < 0.02, "{dibr:?}");
    // The scene has depth edges: a band around them, part of the mask,
    // holding its share of the error or more.
    for r in &rows {
        assert!(r.edge_band_common > 0.01 && r.edge_band_common < 0.9, "{r:?}");
        assert!((0.0..=1.0).contains(&r.edge_error_common), "{r:?}");
    }
}

/// Every mesher on cones at rate 10: the rate met within 10 %, scores that
/// make sense, and the tables and plots written.
#[test]
fn every_mesher_meets_the_rate_on_cones_and_the_files_are_written() {
    let case = cases::middlebury(&data(), "cones").unwrap();
    let meshers = baselines::all();
    let options = Options {
        scenes: vec![],
        rates: vec![10.0],
        repeats: 1,
    };
    let rows = compare_case(&case, &meshers, &options).unwrap();
    assert_eq!(rows.len(), 2 + meshers.len());
    let full = &rows[0];
    for m in &meshers {
        let r = rows.iter().find(|r| r.mesher == m.name()).unwrap();
        assert!((r.achieved_rate / 10.0 - 1.0).abs() <= 0.1, "{r:?}");
        assert!(r.psnr.is_finite() && r.psnr > 20.0, "{r:?}");
        assert!(r.disparity_mse.is_finite() && r.disparity_mse >= 0.0, "{r:?}");
        assert!(r.coverage > 0.5 && r.coverage <= 1.0 + 1e-12, "{r:?}");
        // The common mask is inside every mesher's own.
        assert!(r.common_mask > 0.3 && r.common_mask <= r.coverage + 1e-12, "{r:?}");
        assert!(r.psnr_common.is_finite() && r.disparity_mse_common.is_finite(), "{r:?}");
        assert!(
            r.disparity_mse_full_common.is_finite() && r.disparity_mse_full_common >= 0.0,
            "{r:?}"
        );
        assert!((0.0..0.5).contains(&r.bad_pixels_common), "{r:?}");
        assert!(r.edge_band_common > 0.0 && r.edge_band_common < 1.0, "{r:?}");
        assert!((0.0..=1.0).contains(&r.edge_error_common), "{r:?}");
        assert!(r.ms > 0.0, "{r:?}");
        // A tenth of the triangles cannot be much better than all of them
        // (each on its own mask; the common mask leaves out the hard pixels).
        assert!(r.psnr < full.psnr + 1.0, "{r:?} against {full:?}");
        assert!(r.psnr_common >= r.psnr - 1.0, "{r:?}");
    }
    let rqt = rows.iter().find(|r| r.mesher == "rqt").unwrap();
    let per_level = rqt.per_level_ms.unwrap();
    assert!(per_level > 0.0 && per_level < rqt.ms, "{rqt:?}");
    let dir = tempfile::tempdir().unwrap();
    write(&rows, dir.path()).unwrap();
    for name in ["psnr-cones", "time-cones"] {
        let png = image::open(dir.path().join(format!("{name}.png"))).unwrap();
        assert_eq!((png.width(), png.height()), (800, 520));
        let svg = std::fs::read_to_string(dir.path().join(format!("{name}.svg"))).unwrap();
        assert!(svg.contains("<svg") && svg.contains("quadtree_plane"), "{name}.svg");
    }
    let md = std::fs::read_to_string(dir.path().join("baselines.md")).unwrap();
    assert_eq!(md, markdown(&rows));
    assert!(md.contains("### cones") && md.contains("| 10 | qem |"));
    // The cut outlines' verdicts are counted from these rows.
    let cut = rows.iter().find(|r| r.mesher == "rqt_cut").unwrap();
    let plane = rows.iter().find(|r| r.mesher == "quadtree_plane").unwrap();
    let above = usize::from(cut.psnr_common >= plane.psnr_common);
    assert!(
        md.contains(&format!(
            "`rqt_cut` is at or above `quadtree_plane` on {above} of 1 rows"
        )),
        "{md}"
    );
}

/// The committed comparison (`docs/baselines`, regenerated with the
/// README's command) holds every scene, mesher and rate, with finite scores.
#[test]
fn the_committed_comparison_is_whole() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/baselines/baselines.json");
    let rows: Vec<serde_json::Value> = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let meshers: Vec<&str> = baselines::all().iter().map(|m| m.name()).collect();
    for scene in SCENES {
        let of_scene: Vec<&serde_json::Value> = rows.iter().filter(|r| r["scene"] == scene).collect();
        assert!(of_scene.iter().any(|r| r["mesher"] == FULL), "{scene}");
        assert!(of_scene.iter().any(|r| r["mesher"] == DIBR), "{scene}");
        for mesher in &meshers {
            for rate in RATES {
                let r = of_scene
                    .iter()
                    .find(|r| r["mesher"] == *mesher && r["rate"].as_f64() == Some(rate))
                    .unwrap_or_else(|| panic!("{scene} {mesher} {rate} is missing"));
                for key in [
                    "psnr",
                    "disparity_mse",
                    "coverage",
                    "psnr_common",
                    "disparity_mse_common",
                    "disparity_mse_full_common",
                    "common_mask",
                    "bad_pixels_common",
                    "edge_band_common",
                    "edge_error_common",
                    "ms",
                    "achieved_rate",
                ] {
                    assert!(
                        r[key].as_f64().is_some_and(f64::is_finite),
                        "{scene} {mesher} {rate}: {key}"
                    );
                }
            }
        }
        for name in ["psnr", "time"] {
            for ext in ["png", "svg"] {
                let file =
                    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../docs/baselines/{name}-{scene}.{ext}"));
                assert!(file.is_file(), "{} is missing", file.display());
            }
        }
    }
}

#[test]
fn bad_options_are_refused_clearly() {
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_dmesh-client"))
            .args(args)
            .output()
            .unwrap();
        (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (ok, err) = run(&["report", "--baselines"]);
    assert!(!ok && err.contains("--baselines needs --data"), "{err}");
    let data = data();
    let data = data.to_str().unwrap();
    let (ok, err) = run(&["report", "--baselines", "--data", data, "--rates", "0.5"]);
    assert!(!ok && err.contains("--rates"), "{err}");
    let (ok, err) = run(&["report", "--baselines", "--data", data, "--scenes", "nowhere"]);
    assert!(!ok && err.contains("nowhere"), "{err}");
}

/// A file of the repository, as text.
fn repo_file(path: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The pages that quote the comparison quote the committed rows: the
/// generated page is what `markdown` makes of them, and docs/baselines.md's
/// summary table and verdicts, and the README's headline row, are lines of
/// it (a rerun that changes the rows fails here until the pages follow).
#[test]
fn the_pages_quote_the_committed_rows() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/baselines");
    let rows = dmesh_client::report::baselines::read(&dir).unwrap();
    assert_eq!(
        repo_file("docs/baselines/baselines.md"),
        markdown(&rows),
        "docs/baselines/baselines.md is not what its rows give: run report --baselines --replot"
    );
    let doc = repo_file("docs/baselines.md");
    let summary = dmesh_client::report::baselines::summary(&rows);
    for line in summary.lines() {
        assert!(doc.contains(line), "docs/baselines.md lacks the summary line\n{line}");
    }
    let verdicts = dmesh_client::report::baselines_verdicts::verdicts(&rows);
    assert!(verdicts.len() >= 12, "{verdicts:?}");
    for v in &verdicts {
        assert!(v.judged(), "{v}");
        let line = v.to_string();
        assert!(doc.contains(&line), "docs/baselines.md lacks the verdict\n{line}");
    }
    let at = |mesher: &str| {
        rows.iter()
            .find(|r| r.scene == "art" && r.mesher == mesher && r.rate == 20.0)
            .unwrap_or_else(|| panic!("art {mesher} 20"))
    };
    let (rqt, qem, plane) = (at("rqt"), at("qem"), at("quadtree_plane"));
    let headline = format!(
        "RQT {:.2} dB in {:.0} ms, QEM {:.2} dB in {:.0} ms, plane-fit quadtree {:.2} dB",
        rqt.psnr_common, rqt.ms, qem.psnr_common, qem.ms, plane.psnr_common
    );
    assert!(
        repo_file("README.md").contains(&headline),
        "the README's row on Naik's comparison should read\n{headline}"
    );
}
