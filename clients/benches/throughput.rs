//! Throughput and tail latency of `/render` against the engine's own
//! extraction rate, on this machine, in one run (issue 5's benchmark).
//!
//! One 513 x 513 synthetic view (terrain and boxes), novel cameras on an
//! orbit around it, tau = 1 pixel. Phases:
//! 1. engine: two threads extract the same requests back to back for the
//!    phase's duration (two cores' worth of raw extraction, no HTTP);
//! 2. server: `dmesh serve`'s stack in process (2 worker threads, shedding
//!    above `--max-concurrency`), loaded over loopback HTTP by the load
//!    generator (one thread, as `dmesh-client loadtest`) with 64 clients, then
//!    256 (four times the load), at tau = 1 and then with a 0.5 ms extraction
//!    budget.
//!
//! Usage: `cargo bench -p dmesh-client --bench throughput [-- SECONDS [MAX_CONCURRENCY [CLIENTS...]]]`
//! (defaults 10 s per phase, 2 requests served at once after a wait of at most
//! `QUEUE_WAIT_US` = 1000 us, 64 then 256 clients).

mod support;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use dmesh_client::http::Server;
use dmesh_client::loadtest::{run, Detail, Report, Stop};
use dmesh_engine::camera::Camera;
use dmesh_engine::mesh::{Hierarchy, Lod, Segmentation};

fn engine_rate(h: &Arc<Hierarchy>, cams: &Arc<Vec<Camera>>, seconds: f64) -> (f64, f64) {
    let stop = Arc::new(AtomicBool::new(false));
    let done = Arc::new(AtomicU64::new(0));
    let triangles = Arc::new(AtomicU64::new(0));
    let threads: Vec<_> = (0..2)
        .map(|t| {
            let (h, cams, stop, done, triangles) =
                (h.clone(), cams.clone(), stop.clone(), done.clone(), triangles.clone());
            std::thread::spawn(move || {
                let mut k = t;
                while !stop.load(Ordering::Relaxed) {
                    let view = &cams[k % cams.len()];
                    if let Ok(m) = h.extract(Lod::Tau { tau: 1.0, view }) {
                        triangles.fetch_add(m.triangles.len() as u64, Ordering::Relaxed);
                    }
                    done.fetch_add(1, Ordering::Relaxed);
                    k += 2;
                }
            })
        })
        .collect();
    let start = Instant::now();
    std::thread::sleep(Duration::from_secs_f64(seconds));
    stop.store(true, Ordering::Relaxed);
    for t in threads {
        let _ = t.join();
    }
    let n = done.load(Ordering::Relaxed) as f64;
    (
        n / start.elapsed().as_secs_f64(),
        triangles.load(Ordering::Relaxed) as f64 / n.max(1.0),
    )
}

fn row(name: &str, clients: usize, r: &Report) {
    let served = r.requests - r.errors;
    let shed = r.errors_by_status.get(&503).copied().unwrap_or(0);
    println!(
        "| {name} | {clients} | {:.0} | {:.2} | {:.2} | {:.2} | {:.2} | {served} | {shed} | {} |",
        r.throughput_rps,
        r.p50_ms,
        r.p99_ms,
        r.max_ms,
        r.server_extract_p50_ms,
        r.errors - shed
    );
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let seconds: f64 = args.first().map_or(Ok(10.0), |s| s.parse())?;
    let max_concurrency: usize = args.get(1).map_or(Ok(2), |s| s.parse())?;
    let queue_wait_us: u64 = std::env::var("QUEUE_WAIT_US").map_or(Ok(1000), |s| s.parse())?;
    let loads: Vec<usize> = if args.len() > 2 {
        args[2..].iter().map(|s| s.parse()).collect::<Result<_, _>>()?
    } else {
        vec![64, 256]
    };
    let (depth, camera) = dmesh_engine::synthetic::terrain_with_boxes(513, 513);
    let hierarchy = Arc::new(Hierarchy::build(&depth, &camera, &Segmentation::default())?);
    let cams = Arc::new(support::orbit(&camera, &depth, 32)?);

    let (engine_rps, triangles) = engine_rate(&hierarchy, &cams, seconds);

    let app = support::serve(dmesh::http::Pipeline {
        max_concurrency,
        queue_wait: Duration::from_micros(queue_wait_us),
        ..Default::default()
    })?;
    let base = app.base.clone();

    // The load generator on one thread, as `dmesh-client loadtest` runs.
    let client_rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    let reports = client_rt.block_on(async {
        let server = Server::new(&base, None);
        let pfm = dmesh_engine::image::encode_pfm(513, 513, &depth.z);
        let mut png = Vec::new();
        image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(513, 513, image::Rgb([128, 128, 128])))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
        let wire = dmesh_proto::Camera::from(&camera);
        server
            .put_view("bench", "v", &serde_json::to_string(&wire)?, &pfm, &png)
            .await?;
        let detail = Detail {
            lod: dmesh_proto::Lod::Tau(1.0),
            max_views: Some(1),
            ..Default::default()
        };
        // Warm-up, then the two loads.
        run(&server, "bench", &cams, detail, 8, Stop::Requests(200)).await?;
        let budget = Detail {
            lod: dmesh_proto::Lod::BudgetMs(0.5),
            max_views: Some(1),
            ..Default::default()
        };
        let mut out = Vec::new();
        for (name, detail) in [("tau = 1", detail), ("budget_ms = 0.5", budget)] {
            for &clients in &loads {
                let stop = Stop::Duration(Duration::from_secs_f64(seconds));
                out.push((
                    name,
                    clients,
                    run(&server, "bench", &cams, detail, clients, stop).await?,
                ));
            }
        }
        anyhow::Ok(out)
    })?;
    app.runtime.shutdown_timeout(Duration::from_secs(1));
    eprintln!();
    println!(
        "2 cores ({} threads available), 513 x 513 view, tau = 1 px, {} orbit viewpoints, {seconds} s per phase, \
         server sheds above {max_concurrency} requests in flight after a {queue_wait_us} us wait; mean {triangles:.0} triangles per mesh\n",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        cams.len()
    );
    println!("| phase | clients | served req/s | p50 ms | p99 ms | max ms | server extract p50 ms | served | shed (503) | other errors |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    println!("| engine, 2 threads, no HTTP | - | {engine_rps:.0} | | | | | | | |");
    for (name, clients, r) in &reports {
        row(&format!("HTTP /render, {name}"), *clients, r);
    }
    for pair in reports.chunks(loads.len()) {
        if let [(name, c0, first), (_, c1, second), ..] = pair {
            println!(
                "\n{name}: served at {c0} clients / engine rate: {:.0} %; p99 at {c1} clients / p99 at {c0}: {:.2}x",
                100.0 * first.throughput_rps / engine_rps,
                second.p99_ms / first.p99_ms
            );
        }
    }
    Ok(())
}
