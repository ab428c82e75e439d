//! Live ingest: can the server take a depth video on one view while clients
//! render it? (issue 16). Per frame size, a scene of one view whose depth
//! frames (synthetic terrain and boxes, each frame moved by a little) are
//! replaced through `PUT` at a fixed rate while 8 clients ask `/render` of
//! it at tau = 1, for a duration, against the server's stack in process
//! (two worker threads and the default admission, as `dmesh serve` on this
//! machine). Each size runs twice: frames as PFM (f32, what a depth
//! camera's driver hands over without compression) stored durably per
//! frame, and as 16-bit PGM in millimetres (a depth camera's native
//! format) sent as live frames (`?live=true`: visible at once, made
//! durable within `--live-persist-secs`); one PNG colour image, all encoded
//! before the run. A frame is visible to readers when its `PUT` is
//! answered, so the upload times are the send-to-visible latencies.
//!
//! The uploader sends the next frame at its due time, or at once when the
//! previous upload ended after it (a late frame is never skipped): the
//! server keeps up when every frame is stored by the time the next one is
//! due, that is when uploads take less than the frame interval and the
//! achieved rate equals the offered one.
//!
//! A fifth row is issue 27's 1920 x 1080 target as it is stated: live
//! frames at 20 per second on the server's two threads, with nobody
//! rendering (the four rows before show what eight renderers cost it).
//!
//! Usage: `cargo bench -p dmesh-client --bench ingest [-- SECONDS [FPS [CLIENTS]]]`
//! (defaults 10 s, 30 frames per second, 8 clients; the fifth row keeps
//! its 20 frames per second and no clients).

mod support;

use std::time::{Duration, Instant};

use dmesh::http::Pipeline;
use dmesh_client::http::Server;
use dmesh_client::loadtest::{orbit, run, Detail, Report, Stop};

/// Distinct frames cycled through (each is a fresh depth image to the server).
const FRAMES: usize = 8;

fn png(width: u32, height: u32) -> anyhow::Result<Vec<u8>> {
    let rgb: Vec<u8> = (0..width * height)
        .flat_map(|i| {
            let (x, y) = (i % width, i / width);
            [(x % 256) as u8, (y % 256) as u8, 128]
        })
        .collect();
    let img = image::RgbImage::from_raw(width, height, rgb).ok_or_else(|| anyhow::anyhow!("colour size"))?;
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)?;
    Ok(out)
}

/// Percentile `q` (0..1) of `v`, sorted here.
fn percentile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// How frames travel.
#[derive(Clone, Copy)]
enum Mode {
    /// PFM, each frame durable before it is answered.
    Durable,
    /// 16-bit PGM (millimetres), `?live=true`.
    Live,
}

struct Row {
    size: (u32, u32),
    mode: Mode,
    fps: f64,
    clients: usize,
    offered: usize,
    stored: usize,
    failed: usize,
    late: usize,
    achieved_fps: f64,
    upload_p50: f64,
    upload_p99: f64,
    upload_max: f64,
    build_ms: f64,
    /// `None` when nobody rendered.
    render: Option<Report>,
}

fn measure(width: u32, height: u32, mode: Mode, seconds: f64, fps: f64, clients: usize) -> anyhow::Result<Row> {
    let (depth, camera) = dmesh_engine::synthetic::terrain_with_boxes(width, height);
    let frames: Vec<Vec<u8>> = (0..FRAMES)
        .map(|k| {
            // Each frame moves the surface by a little: a new image each time.
            let scale = 1.0 + 0.002 * k as f32;
            let z: Vec<f32> = depth.z.iter().map(|&z| z * scale).collect();
            match mode {
                Mode::Durable => dmesh_engine::image::encode_pfm(width, height, &z),
                Mode::Live => {
                    let mm: Vec<u16> = z
                        .iter()
                        .map(|&z| (z * 1000.0).round().clamp(0.0, 65535.0) as u16)
                        .collect();
                    dmesh_engine::image::pgm::encode16(width, height, &mm)
                }
            }
        })
        .collect();
    let (fields, live) = match mode {
        Mode::Durable => (Vec::new(), false),
        Mode::Live => (vec![("scale", "0.001".to_string())], true),
    };
    let color = png(width, height)?;
    let cam = serde_json::to_string(&dmesh_proto::Camera::from(&camera))?;
    // One hierarchy build of this size in this process, for the table.
    let build_ms = {
        let mut t: Vec<f64> = (0..5)
            .map(|_| {
                let s = Instant::now();
                let _ = std::hint::black_box(dmesh_engine::mesh::Hierarchy::build(
                    &depth,
                    &camera,
                    &Default::default(),
                ));
                s.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        percentile(&mut t, 0.5)
    };

    let app = support::serve(Pipeline::default())?;
    let base = app.base.clone();
    let client_rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()?;
    let row = client_rt.block_on(async {
        let server = Server::new(&base, None);
        server
            .put_frame("live", "cam", &cam, &frames[0], &color, &fields, live)
            .await?;
        let novel = orbit(std::slice::from_ref(&camera), 16)?;
        let detail = Detail::default();
        // Warm up: the first renders build the hierarchy.
        run(&server, "live", &novel, detail, 2, Stop::Requests(20)).await?;

        let duration = Duration::from_secs_f64(seconds);
        let uploader = {
            let server = Server::new(&base, None);
            let (frames, color, cam, fields) = (frames.clone(), color.clone(), cam.clone(), fields.clone());
            tokio::spawn(async move {
                let interval = Duration::from_secs_f64(1.0 / fps);
                let start = tokio::time::Instant::now();
                let (mut times, mut failed, mut late, mut k) = (Vec::new(), 0usize, 0usize, 0usize);
                while start.elapsed() < duration {
                    let due = start + interval * k as u32;
                    if tokio::time::Instant::now() < due {
                        tokio::time::sleep_until(due).await;
                    } else if k > 0 {
                        late += 1;
                    }
                    let t = Instant::now();
                    match server
                        .put_frame("live", "cam", &cam, &frames[k % FRAMES], &color, &fields, live)
                        .await
                    {
                        Ok(_) => times.push(t.elapsed().as_secs_f64() * 1e3),
                        Err(_) => failed += 1,
                    }
                    k += 1;
                }
                (times, failed, late, k, start.elapsed().as_secs_f64())
            })
        };
        let render = if clients > 0 {
            Some(run(&server, "live", &novel, detail, clients, Stop::Duration(duration)).await?)
        } else {
            None
        };
        let (mut times, failed, late, offered, elapsed) = uploader.await?;
        let stored = times.len();
        anyhow::Ok(Row {
            size: (width, height),
            mode,
            fps,
            clients,
            offered,
            stored,
            failed,
            late,
            achieved_fps: stored as f64 / elapsed,
            upload_p50: percentile(&mut times, 0.5),
            upload_p99: percentile(&mut times, 0.99),
            upload_max: percentile(&mut times, 1.0),
            build_ms,
            render,
        })
    })?;
    app.runtime.shutdown_timeout(Duration::from_secs(1));
    Ok(row)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let seconds: f64 = args.first().map_or(Ok(10.0), |s| s.parse())?;
    let fps: f64 = args.get(1).map_or(Ok(30.0), |s| s.parse())?;
    let clients: usize = args.get(2).map_or(Ok(8), |s| s.parse())?;
    anyhow::ensure!(
        seconds > 0.0 && fps > 0.0 && clients > 0,
        "SECONDS, FPS and CLIENTS must be positive"
    );
    let mut rows = Vec::new();
    let scenarios = [
        (640, 480, Mode::Durable, fps, clients),
        (640, 480, Mode::Live, fps, clients),
        (1920, 1080, Mode::Durable, fps, clients),
        (1920, 1080, Mode::Live, fps, clients),
        (1920, 1080, Mode::Live, 20.0, 0),
    ];
    for (w, h, mode, fps, clients) in scenarios {
        eprintln!("{w} x {h}: {fps} frames/s for {seconds} s, {clients} clients rendering");
        rows.push(measure(w, h, mode, seconds, fps, clients)?);
    }
    println!(
        "\n{} cores ({}); one view replaced by PUT for {seconds} s while the clients /render it at tau = 1 px\n",
        dmesh::http::cores(),
        std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|c| c.lines().find(|l| l.starts_with("model name")).map(|l| l
                .split(':')
                .nth(1)
                .unwrap_or("")
                .trim()
                .to_string()))
            .unwrap_or_else(|| "unknown CPU".into())
    );
    println!("| frame | sent as | build ms (in process) | offered/s | clients | frames offered | stored | failed | late | stored/s | send to visible p50 ms | p99 ms | max ms | renders/s | render p50 ms | render p99 ms | render shed (503) | keeps up |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let keeps_up = r.failed == 0 && r.upload_p99 < 1e3 / r.fps && r.achieved_fps >= 0.98 * r.fps;
        let renders = match &r.render {
            Some(render) => format!(
                "{:.0} | {:.1} | {:.1} | {}",
                render.throughput_rps,
                render.p50_ms,
                render.p99_ms,
                render.errors_by_status.get(&503).copied().unwrap_or(0)
            ),
            None => "- | - | - | -".into(),
        };
        println!(
            "| {} x {} | {} | {:.1} | {:.0} | {} | {} | {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {} |",
            r.size.0,
            r.size.1,
            match r.mode {
                Mode::Durable => "PFM, durable",
                Mode::Live => "PGM, live",
            },
            r.build_ms,
            r.fps,
            r.clients,
            r.offered,
            r.stored,
            r.failed,
            r.late,
            r.achieved_fps,
            r.upload_p50,
            r.upload_p99,
            r.upload_max,
            renders,
            if keeps_up { "yes" } else { "no" }
        );
    }
    Ok(())
}
