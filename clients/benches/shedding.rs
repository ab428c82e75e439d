//! Does `dmesh serve` with its defaults shed instead of queueing? (issue 12,
//! defect 2). A scene of four 320 x 240 simulated views (the demo objects,
//! a ring of four cameras), `/render` at tau = 1 from 32 clients for a
//! duration, against the server's stack in process (two worker threads, as
//! `dmesh serve` on this machine), once per admission setting, in one run:
//! the defaults (reads admitted by the number of cores, a 5 ms queue) beside
//! the old default of 64 slots and the hand-tuned 2 slots with a 1 ms queue.
//!
//! Usage: `cargo bench -p dmesh-client --bench shedding [-- SECONDS [CLIENTS]]`
//! (defaults 10 s, 32 clients).

mod support;

use std::time::Duration;

use dmesh::http::Pipeline;
use dmesh_client::http::Server;
use dmesh_client::loadtest::{orbit, run, Detail, Report, Stop};

fn png(width: u32, height: u32, rgb: &[u8]) -> anyhow::Result<Vec<u8>> {
    let img = image::RgbImage::from_raw(width, height, rgb.to_vec()).ok_or_else(|| anyhow::anyhow!("colour size"))?;
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)?;
    Ok(out)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let seconds: f64 = args.first().map_or(Ok(10.0), |s| s.parse())?;
    let clients: usize = args.get(1).map_or(Ok(32), |s| s.parse())?;
    let mut spec = dmesh_engine::sim::SceneSpec::demo();
    spec.width = 320;
    spec.height = 240;
    spec.rig = dmesh_engine::sim::rig::Rig::Ring {
        count: 4,
        radius: 4.0,
        heights: vec![1.6],
        target: [0.0, 0.4, 0.0],
    };
    let views = spec.reference_views()?;
    let cameras: Vec<dmesh_engine::camera::Camera> = views.iter().map(|v| v.camera).collect();
    let novel = orbit(&cameras, 32)?;
    let defaults = Pipeline::default();
    let settings = [
        (
            format!(
                "defaults: {} read slots, {} upload slot(s), 5 ms queue",
                defaults.max_concurrency, defaults.max_uploads
            ),
            defaults,
        ),
        (
            "before: 64 slots for everything, 5 ms queue".to_string(),
            Pipeline {
                max_concurrency: 64,
                max_uploads: 64,
                ..defaults
            },
        ),
        (
            "hand-tuned: 2 read slots, 1 ms queue".to_string(),
            Pipeline {
                max_concurrency: 2,
                queue_wait: Duration::from_millis(1),
                ..defaults
            },
        ),
    ];
    let mut rows: Vec<(String, Report)> = Vec::new();
    for (name, pipeline) in settings {
        let app = support::serve(pipeline)?;
        let base = app.base.clone();
        let client_rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
        let report = client_rt.block_on(async {
            let server = Server::new(&base, None);
            for (k, v) in views.iter().enumerate() {
                let cam = serde_json::to_string(&dmesh_proto::Camera::from(&v.camera))?;
                let depth = dmesh_engine::image::encode_pfm(v.depth.width, v.depth.height, &v.depth.z);
                server
                    .put_view(
                        "ring",
                        &format!("v{k}"),
                        &cam,
                        &depth,
                        &png(v.color.width, v.color.height, &v.color.rgb)?,
                    )
                    .await?;
            }
            let detail = Detail {
                lod: dmesh_proto::Lod::Tau(1.0),
                ..Default::default()
            };
            run(&server, "ring", &novel, detail, 4, Stop::Requests(100)).await?;
            run(
                &server,
                "ring",
                &novel,
                detail,
                clients,
                Stop::Duration(Duration::from_secs_f64(seconds)),
            )
            .await
        })?;
        rows.push((name, report));
        app.runtime.shutdown_timeout(Duration::from_secs(1));
    }
    eprintln!();
    println!(
        "{} cores; four 320 x 240 views, /render at tau = 1 px, {clients} clients for {seconds} s per setting; latency of served requests\n",
        dmesh::http::cores()
    );
    println!("| admission | served req/s | p50 ms | p90 ms | p99 ms | max ms | served | shed (503) | other errors |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, r) in &rows {
        let shed = r.errors_by_status.get(&503).copied().unwrap_or(0);
        println!(
            "| {name} | {:.0} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {shed} | {} |",
            r.throughput_rps,
            r.p50_ms,
            r.p90_ms,
            r.p99_ms,
            r.max_ms,
            r.requests - r.errors,
            r.errors - shed
        );
    }
    Ok(())
}
