//! Durability under SIGKILL: a loop of uploads against the real `dmesh serve`
//! is killed at random moments; after each restart every acknowledged view is
//! there, readable and the version last acknowledged (or the one in flight
//! when the process died), and every listed view is whole.

#[path = "support/raw_http.rs"]
mod raw_http;

use std::time::{Duration, Instant};

use dmesh_engine::image::encode_pfm;
use raw_http::{http, multipart, start_with};

const W: u32 = 24;
const H: u32 = 16;

fn upload_body(seed: u32) -> Vec<u8> {
    let z: Vec<f32> = (0..W * H).map(|i| 1.0 + ((i + seed) % 7) as f32 * 0.01).collect();
    let color = {
        let img = image::RgbImage::from_fn(W, H, |x, y| image::Rgb([x as u8, y as u8, seed as u8]));
        let mut out = Vec::new();
        image::DynamicImage::ImageRgb8(img)
            .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
            .unwrap();
        out
    };
    let camera = format!(
        r#"{{"width": {W}, "height": {H}, "projection": {{"perspective": {{"fx": 20, "fy": 20, "cx": 11.5, "cy": 7.5}}}}}}"#
    );
    multipart(&[
        ("camera", camera.as_bytes()),
        ("depth", &encode_pfm(W, H, &z)),
        ("color", &color),
    ])
}

fn start(data: &std::path::Path) -> (std::process::Child, std::net::SocketAddr) {
    start_with(data, &[])
}

#[test]
fn acknowledged_uploads_survive_sigkill() {
    let dir = tempfile::tempdir().unwrap();
    let mut acknowledged: Vec<String> = Vec::new();
    // Per view, the seed of its last acknowledged upload (the colour's blue
    // channel); and the upload in flight when the server died.
    let mut versions = std::collections::HashMap::<String, u32>::new();
    let mut next = 0u32;
    // A small deterministic generator: the kill moments vary, the test does not flake on a seed.
    let mut seed = 0x9e37_79b9u32;
    for round in 0..6 {
        let (mut child, addr) = start(dir.path());
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        let kill_after = Duration::from_millis(20 + u64::from(seed % 180));
        let killer = std::thread::spawn(move || {
            std::thread::sleep(kill_after);
            let _ = child.kill(); // SIGKILL
            let _ = child.wait();
        });
        // Upload (and overwrite) until the server dies.
        let began = Instant::now();
        let mut in_flight = None;
        while began.elapsed() < Duration::from_secs(10) {
            let view = format!("v{}", next % 40);
            let seed = next;
            let body = upload_body(seed);
            next += 1;
            match http(
                addr,
                "PUT",
                &format!("/v1/scenes/crash/views/{view}"),
                Some("multipart/form-data; boundary=B"),
                &body,
            ) {
                Ok((201, _)) => {
                    versions.insert(view.clone(), seed);
                    if !acknowledged.contains(&view) {
                        acknowledged.push(view);
                    }
                }
                Ok((status, body)) => panic!(
                    "round {round}: upload answered {status}: {}",
                    String::from_utf8_lossy(&body)
                ),
                Err(_) => {
                    // Killed mid-request: this version may or may not have landed.
                    in_flight = Some((view, seed));
                    break;
                }
            }
        }
        killer.join().unwrap();
        // Restart: every acknowledged view is there; every listed view is whole.
        let (mut child, addr) = start(dir.path());
        let (status, body) = http(addr, "GET", "/v1/scenes/crash/views", None, b"").unwrap();
        if !acknowledged.is_empty() {
            assert_eq!(status, 200, "round {round}");
            let listed: serde_json::Value = serde_json::from_slice(&body).unwrap();
            let listed: Vec<String> = listed["views"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_str().unwrap().to_string())
                .collect();
            for v in &acknowledged {
                assert!(listed.contains(v), "round {round}: acknowledged view {v} is missing");
                let (status, body) =
                    http(addr, "GET", &format!("/v1/scenes/crash/views/{v}/color"), None, b"").unwrap();
                assert_eq!(status, 200, "round {round}: {v}'s colour");
                let blue = image::load_from_memory(&body).unwrap().to_rgb8().get_pixel(0, 0)[2];
                let last = versions[v];
                let flying = in_flight.as_ref().filter(|(w, _)| w == v).map(|(_, s)| *s);
                assert!(
                    blue == last as u8 || flying.is_some_and(|s| blue == s as u8),
                    "round {round}: view {v} is version {blue}, not the last acknowledged {} (in flight: {flying:?})",
                    last as u8
                );
                // A version in flight that landed is now the one to expect.
                if let Some(s) = flying.filter(|s| blue == *s as u8 && blue != last as u8) {
                    versions.insert(v.clone(), s);
                }
            }
            for v in &listed {
                let (status, body) = http(
                    addr,
                    "GET",
                    &format!("/v1/scenes/crash/views/{v}/strips?epsilon=0"),
                    None,
                    b"",
                )
                .unwrap();
                assert_eq!(
                    status,
                    200,
                    "round {round}: view {v} unreadable: {}",
                    String::from_utf8_lossy(&body)
                );
            }
        }
        let _ = child.kill();
        let _ = child.wait();
    }
    assert!(
        acknowledged.len() >= 5,
        "too few uploads were acknowledged to test anything: {}",
        acknowledged.len()
    );
}

/// Live frames (`?live=true`, not made durable per frame) survive a killed
/// process: the kernel holds what was renamed into place. With
/// `--live-persist-secs 3600` nothing is made durable before the kill, so
/// the view found after the restart is the latest acknowledged frame (or
/// one the server stored as the connection died), whole.
#[test]
fn acknowledged_live_frames_survive_a_killed_process() {
    let dir = tempfile::tempdir().unwrap();
    let (mut child, addr) = start_with(dir.path(), &["--live-persist-secs", "3600"]);
    let mut acknowledged = None;
    for seed in 0..60u32 {
        match http(
            addr,
            "PUT",
            "/v1/scenes/live/views/cam?live=true",
            Some("multipart/form-data; boundary=B"),
            &upload_body(seed),
        ) {
            Ok((201, _)) => acknowledged = Some(seed),
            Ok((status, body)) => panic!("frame {seed}: {status}: {}", String::from_utf8_lossy(&body)),
            Err(e) => panic!("frame {seed}: {e}"),
        }
    }
    let last = acknowledged.expect("frames acknowledged");
    let _ = child.kill(); // SIGKILL, no shutdown
    let _ = child.wait();
    let (mut child, addr) = start(dir.path());
    let (status, body) = http(addr, "GET", "/v1/scenes/live/views/cam/color", None, b"").unwrap();
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let color = image::load_from_memory(&body).unwrap().to_rgb8();
    // The colour's blue channel is the frame's seed.
    assert_eq!(
        u32::from(color.get_pixel(0, 0)[2]),
        last,
        "the latest acknowledged frame is kept"
    );
    let (status, _) = http(addr, "GET", "/v1/scenes/live/views/cam/strips?epsilon=0", None, b"").unwrap();
    assert_eq!(status, 200);
    // Bad queries are refused.
    for query in ["live=maybe", "fast=1"] {
        let path = format!("/v1/scenes/live/views/cam?{query}");
        let (status, _) = http(
            addr,
            "PUT",
            &path,
            Some("multipart/form-data; boundary=B"),
            &upload_body(1),
        )
        .unwrap();
        assert_eq!(status, 400, "{query}");
    }
    let _ = child.kill();
    let _ = child.wait();
}
