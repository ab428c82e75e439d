//! The `dmesh-client` binary: compare's JSON, one-line errors, and `stream` against a real server.

mod common;

use std::process::Command;

fn client(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dmesh-client"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

#[test]
fn compare_prints_the_documented_json() {
    let dir = tempfile::tempdir().unwrap();
    let a = image::RgbImage::from_fn(8, 8, |x, _| image::Rgb([x as u8 * 10 + 5, 50, 50]));
    let mut b = a.clone();
    b.put_pixel(3, 3, image::Rgb([100, 100, 100]));
    let (pa, pb) = (dir.path().join("a.png"), dir.path().join("b.png"));
    a.save(&pa).unwrap();
    b.save(&pb).unwrap();
    let (code, out, err) = client(&["compare", pa.to_str().unwrap(), pb.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert!(
        v["psnr"].as_f64().unwrap() > 20.0 && v["psnr"].as_f64().unwrap() < 60.0,
        "{out}"
    );
    assert_eq!(v["valid_fraction"], 1.0);
    assert!(v.get("inverse_depth_rmse").is_some());
}

#[test]
fn failures_are_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let cam = dir.path().join("cam.json");
    std::fs::write(
        &cam,
        r#"{"width": 8, "height": 8, "projection": {"perspective": {"fx": 8, "fy": 8, "cx": 3.5, "cy": 3.5}}}"#,
    )
    .unwrap();
    let cases: [(Vec<&str>, &str); 3] = [
        (
            vec!["compare", "/nonexistent/a.png", "/nonexistent/b.png"],
            "cannot read",
        ),
        (
            vec![
                "render",
                "--server",
                "http://127.0.0.1:9",
                "--scene",
                "s",
                "--camera",
                cam.to_str().unwrap(),
                "--out",
                "/tmp/x.png",
            ],
            "error",
        ),
        (vec!["ingest", "--scene", "s"], "--simulate"),
    ];
    for (args, needle) in cases {
        let (code, _, err) = client(&args);
        assert_ne!(code, 0, "{args:?}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn walkthrough_refuses_bad_input_in_one_line_before_any_request() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        r#"{"width": 64, "height": 48, "fov_deg": 60, "frames": 10, "keys": []}"#,
    )
    .unwrap();
    let good = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/paths/demo-orbit.json");
    // A port nothing listens on: every case must fail before connecting.
    let server = "http://127.0.0.1:9";
    let cases: [(Vec<&str>, &str); 5] = [
        (vec!["--path", "/nonexistent/path.json"], "cannot read"),
        (vec!["--path", bad.to_str().unwrap()], "two keys"),
        (vec!["--path", good, "--strategy", "fast"], "unknown strategy"),
        (vec!["--path", good, "--tau=-1"], "--tau"),
        (vec!["--path", good, "--budget-triangles=-5"], "budget"),
    ];
    for (args, want) in cases {
        let mut all = vec!["walkthrough", "--server", server, "--scene", "demo"];
        all.extend(args.iter());
        let (code, _, err) = client(&all);
        assert_ne!(code, 0, "{args:?} succeeded");
        assert!(err.contains(want), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
}

/// `stream` replaces one view frame by frame at the offered rate, the
/// simulated objects moving: every frame stored, the view's mesh changed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stream_replaces_a_view_at_the_offered_rate() {
    let running = common::start().await;
    let stream = |frames: &str, format: &str| {
        let base = running.base.clone();
        let (frames, format) = (frames.to_string(), format.to_string());
        tokio::task::spawn_blocking(move || {
            client(&[
                "stream",
                "--server",
                &base,
                "--scene",
                "live",
                "--simulate",
                "demo",
                "--fps",
                "8",
                "--frames",
                &frames,
                "--format",
                &format,
                "--json",
            ])
        })
    };
    let server = dmesh_client::http::Server::new(&running.base, None);
    let request = dmesh_proto::StripRequest {
        lod: dmesh_proto::Lod::Epsilon(0.01),
        camera: None,
        bits: None,
        held: None,
        held_camera: None,
    };
    let (code, _, err) = stream("1", "pfm").await.unwrap();
    assert_eq!(code, 0, "{err}");
    let (first, _) = server.strips("live", "live", &request).await.unwrap();
    for format in ["pfm", "pgm"] {
        let (code, out, err) = stream("6", format).await.unwrap();
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(
            (v["frames"].as_u64(), v["failed"].as_u64()),
            (Some(6), Some(0)),
            "{out}"
        );
        let fps = v["achieved_fps"].as_f64().unwrap();
        assert!(
            fps > 4.0 && fps < 12.0,
            "achieved {fps} frames per second at 8 offered: {out}"
        );
        assert!(v["upload_p50_ms"].as_f64().unwrap() > 0.0);
    }
    // The last frame (the objects swayed) is another mesh than the first.
    let (last, _) = server.strips("live", "live", &request).await.unwrap();
    assert_ne!(first.vertices, last.vertices);
    // Neither a scene nor a folder: a one-line error before any request.
    let (code, _, err) = client(&["stream", "--scene", "s", "--server", "http://127.0.0.1:9"]);
    assert_ne!(code, 0);
    assert!(err.contains("--simulate") && err.lines().count() == 1, "{err}");
}
