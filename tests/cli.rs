//! The `dmesh` binary: figures as JSON, PLY output, one-line errors.

use std::path::Path;
use std::process::Command;

use dmesh_engine::image::{encode_exr, encode_pfm};

fn dmesh(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dmesh")).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn scene(dir: &Path) -> (String, String, String) {
    let (w, h) = (40u32, 30u32);
    let z: Vec<f32> = (0..w * h)
        .map(|i| if i % w < 20 { 2.0 } else { 3.0 + (i / w) as f32 * 0.01 })
        .collect();
    let depth = dir.join("depth.exr");
    std::fs::write(&depth, encode_exr(w, h, &z).unwrap()).unwrap();
    let pfm = dir.join("depth.pfm");
    std::fs::write(&pfm, encode_pfm(w, h, &z)).unwrap();
    let cam = dir.join("cam.json");
    std::fs::write(
        &cam,
        r#"{"width": 40, "height": 30, "projection": {"perspective": {"fx": 40, "fy": 40, "cx": 19.5, "cy": 14.5}}}"#,
    )
    .unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    (s(&depth), s(&pfm), s(&cam))
}

#[test]
fn json_figures_describe_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let (depth, pfm, cam) = scene(dir.path());
    for file in [&depth, &pfm] {
        let (code, out, err) = dmesh(&["mesh", "--depth", file, "--camera", &cam, "--epsilon", "0", "--json"]);
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        for key in [
            "width",
            "height",
            "grid_vertices",
            "vertices",
            "triangles",
            "strips",
            "indices",
            "segmented_triangles",
            "build_ms",
            "extract_ms",
            "peak_bytes",
        ] {
            assert!(v.get(key).is_some(), "missing {key} in {out}");
        }
        assert_eq!(v["width"], 40);
        // Full resolution minus the column of cells across the step.
        let segmented = v["segmented_triangles"].as_u64().unwrap();
        assert_eq!(segmented, 2 * 29);
        assert_eq!(v["triangles"].as_u64().unwrap(), 2 * 39 * 29 - segmented);
    }
}

#[test]
fn strip_orders_give_the_same_triangles_in_fewer_indices() {
    let dir = tempfile::tempdir().unwrap();
    let (depth, _, cam) = scene(dir.path());
    let run = |order: &str| {
        let (code, out, err) = dmesh(&[
            "mesh",
            "--depth",
            &depth,
            "--camera",
            &cam,
            "--epsilon",
            "0",
            "--strips",
            order,
            "--json",
        ]);
        assert_eq!(code, 0, "{order}: {err}");
        let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        (v["triangles"].as_u64().unwrap(), v["indices"].as_u64().unwrap())
    };
    let (traversal, greedy, tunnelled) = (run("traversal"), run("greedy"), run("tunnelled"));
    assert_eq!(traversal.0, greedy.0);
    assert_eq!(traversal.0, tunnelled.0);
    assert!(
        tunnelled.1 < greedy.1 && greedy.1 < traversal.1,
        "indices: traversal {traversal:?}, greedy {greedy:?}, tunnelled {tunnelled:?}"
    );
    let (code, _, err) = dmesh(&[
        "mesh",
        "--depth",
        &depth,
        "--camera",
        &cam,
        "--epsilon",
        "0",
        "--strips",
        "best",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("best"), "{err}");
}

#[test]
fn a_triangle_budget_is_met_and_its_tolerance_printed() {
    let dir = tempfile::tempdir().unwrap();
    let (depth, _, cam) = scene(dir.path());
    let view = dir.path().join("view.json");
    std::fs::write(&view, r#"{"width": 64, "height": 48, "projection": {"perspective": {"fx": 60, "fy": 60, "cx": 31.5, "cy": 23.5}}, "pose": {"rotation": [0, 0, 0, 1], "translation": [0.1, 0, -2]}}"#).unwrap();
    let view = view.to_str().unwrap().to_string();
    for (extra, key) in [(vec![], "epsilon"), (vec!["--view", view.as_str()], "tau")] {
        let mut args = vec![
            "mesh",
            "--depth",
            &depth,
            "--camera",
            &cam,
            "--max-triangles",
            "2000",
            "--json",
        ];
        args.extend(extra);
        let (code, out, err) = dmesh(&args);
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        assert!(v["triangles"].as_u64().unwrap() <= 2000, "{out}");
        assert!(v[key].as_f64().is_some_and(|t| t.is_finite() && t >= 0.0), "{out}");
    }
    let (code, _, err) = dmesh(&["mesh", "--depth", &depth, "--camera", &cam, "--max-triangles", "1"]);
    assert_ne!(code, 0);
    assert!(err.contains("max_triangles is 1") && err.lines().count() == 1, "{err}");
}

#[test]
fn outlines_are_kept_unless_dropped_or_cut_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let (depth, _, cam) = scene(dir.path());
    let base = ["mesh", "--depth", &depth, "--camera", &cam, "--epsilon", "0.5"];
    let figures = |extra: &[&str]| {
        let args = [&base[..], &["--json"], extra].concat();
        let (code, out, err) = dmesh(&args);
        assert_eq!(code, 0, "{err}");
        serde_json::from_str::<serde_json::Value>(out.trim()).unwrap()
    };
    let triangles = |extra: &[&str]| figures(extra)["drawn_triangles"].as_u64().unwrap();
    // At a coarse tolerance the step's outline is refined down to its
    // cells; dropping whole the coarse triangles across it keeps fewer.
    let (kept, dropped) = (triangles(&[]), triangles(&["--drop-outlines"]));
    assert!(dropped < kept, "dropped {dropped}, kept {kept}");
    // Cutting them draws what the refinement's dropped cells leave out:
    // this grid's roots are 2 samples across (40 x 30 pads least so), so
    // every cut is a cell's, and it draws parts the others leave out.
    let v = figures(&["--cut-outlines"]);
    let (whole, cut) = (v["triangles"].as_u64().unwrap(), v["cut_triangles"].as_u64().unwrap());
    let drawn = v["drawn_triangles"].as_u64().unwrap();
    assert!(cut > 0 && drawn > whole && drawn <= whole + 3 * cut, "{v}");
    // Both at once is refused, in one line.
    let (code, _, err) = dmesh(&[&base[..], &["--drop-outlines", "--cut-outlines"]].concat());
    assert_ne!(code, 0);
    assert!(err.contains("--cut-outlines"), "{err}");
}

#[test]
fn ply_has_a_header_that_matches_the_figures() {
    let dir = tempfile::tempdir().unwrap();
    let (depth, _, cam) = scene(dir.path());
    let ply = dir.path().join("out.ply");
    let view = dir.path().join("view.json");
    std::fs::write(&view, r#"{"width": 64, "height": 48, "projection": {"perspective": {"fx": 60, "fy": 60, "cx": 31.5, "cy": 23.5}}, "pose": {"rotation": [0, 0.05, 0, 0.99875], "translation": [0.2, 0, -1]}}"#).unwrap();
    let (code, out, err) = dmesh(&[
        "mesh",
        "--depth",
        &depth,
        "--camera",
        &cam,
        "--tau",
        "0.5",
        "--view",
        view.to_str().unwrap(),
        "--ply",
        ply.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let bytes = std::fs::read(&ply).unwrap();
    let text = String::from_utf8_lossy(&bytes[..400]);
    assert!(text.starts_with("ply\nformat binary_little_endian 1.0\n"));
    assert!(text.contains(&format!("element vertex {}", v["vertices"])));
    assert!(text.contains(&format!("element face {}", v["triangles"])));
    assert!(text.contains("property float quality"));
}

#[test]
fn bad_input_fails_with_one_line_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let (depth, _, cam) = scene(dir.path());
    let truncated = dir.path().join("cut.exr");
    std::fs::write(&truncated, &std::fs::read(&depth).unwrap()[..100]).unwrap();
    let bad_cam = dir.path().join("bad.json");
    std::fs::write(
        &bad_cam,
        r#"{"width": 40, "height": 30, "projection": {"perspective": {"fx": 0, "fy": 40, "cx": 19.5, "cy": 14.5}}}"#,
    )
    .unwrap();
    let small_cam = dir.path().join("small.json");
    std::fs::write(
        &small_cam,
        r#"{"width": 4, "height": 3, "projection": {"perspective": {"fx": 4, "fy": 4, "cx": 2, "cy": 1}}}"#,
    )
    .unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "mesh",
                "--depth",
                "/nonexistent.exr",
                "--camera",
                &cam,
                "--epsilon",
                "1",
            ],
            "cannot read depth file",
        ),
        (
            vec![
                "mesh",
                "--depth",
                truncated.to_str().unwrap(),
                "--camera",
                &cam,
                "--epsilon",
                "1",
            ],
            "depth EXR",
        ),
        (
            vec![
                "mesh",
                "--depth",
                &depth,
                "--camera",
                bad_cam.to_str().unwrap(),
                "--epsilon",
                "1",
            ],
            "fx",
        ),
        (
            vec![
                "mesh",
                "--depth",
                &depth,
                "--camera",
                small_cam.to_str().unwrap(),
                "--epsilon",
                "1",
            ],
            "must match",
        ),
        (
            vec!["mesh", "--depth", &depth, "--camera", &cam, "--epsilon", "-1"],
            "epsilon",
        ),
        (
            vec![
                "mesh",
                "--depth",
                &depth,
                "--camera",
                &cam,
                "--epsilon",
                "1",
                "--omega",
                "120",
            ],
            "omega",
        ),
        (
            vec!["mesh", "--depth", &depth, "--camera", &cam, "--tau", "1"],
            "--view",
        ),
        (vec!["mesh", "--depth", &depth, "--camera", &cam], "--epsilon"),
        (
            vec![
                "mesh",
                "--depth",
                &depth,
                "--camera",
                &cam,
                "--epsilon",
                "1",
                "--depth-kind",
                "disparity",
            ],
            "focal_baseline",
        ),
        (
            vec![
                "mesh",
                "--depth",
                &depth,
                "--camera",
                &cam,
                "--epsilon",
                "1",
                "--max-pixels",
                "100",
            ],
            "limit",
        ),
    ];
    for (args, needle) in cases {
        let (code, _, err) = dmesh(&args);
        assert_ne!(code, 0, "{args:?} succeeded");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err:?} does not mention {needle}");
    }
}

#[test]
fn a_mask_invalidates_samples() {
    let dir = tempfile::tempdir().unwrap();
    let (depth, _, cam) = scene(dir.path());
    // Left half valid, right half masked out.
    let mask = image::GrayImage::from_fn(40, 30, |x, _| image::Luma([if x < 20 { 255 } else { 0 }]));
    let mask_path = dir.path().join("mask.png");
    mask.save(&mask_path).unwrap();
    let (code, out, err) = dmesh(&[
        "mesh",
        "--depth",
        &depth,
        "--camera",
        &cam,
        "--epsilon",
        "0",
        "--mask",
        mask_path.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    // Only the 19 x 29 cells of the left half remain.
    assert_eq!(v["triangles"].as_u64().unwrap(), 2 * 19 * 29);
    let small = image::GrayImage::new(4, 4);
    small.save(&mask_path).unwrap();
    let (code, _, err) = dmesh(&[
        "mesh",
        "--depth",
        &depth,
        "--camera",
        &cam,
        "--epsilon",
        "0",
        "--mask",
        mask_path.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("mask is 4x4"), "{err}");
}

#[test]
fn demo_runs_without_files() {
    let (code, out, err) = dmesh(&["demo", "--size", "65"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("epsilon 1 cm") && out.contains("tau 1 px"), "{out}");
}

#[test]
fn serving_on_a_port_in_use_fails_before_touching_the_store() {
    // Held for the whole test: the server cannot bind it.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let listen = taken.local_addr().unwrap().to_string();
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let (code, _, err) = dmesh(&["serve", "--demo", "--listen", &listen, "--data", data.to_str().unwrap()]);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains(&format!("listening on {listen}")), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    assert!(!data.exists(), "the demo scene was written to {}", data.display());
}
