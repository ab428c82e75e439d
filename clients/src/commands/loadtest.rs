//! `dmesh-client loadtest`: `/render` requests for novel cameras on an orbit,
//! bounded in requests or time, loopback only unless allowed.

use anyhow::{bail, Result};
use dmesh_client::http::Server;

use super::detail::DetailArgs;

/// Options of `loadtest`.
#[derive(clap::Args, Debug)]
pub struct LoadtestArgs {
    /// Server base URL.
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub server: String,
    /// Scene id.
    #[arg(long)]
    pub scene: String,
    /// Requests in flight.
    #[arg(long, default_value_t = 8)]
    pub concurrency: usize,
    /// Stop after this many requests.
    #[arg(long, conflicts_with = "duration", required_unless_present = "duration")]
    pub requests: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long)]
    pub duration: Option<f64>,
    #[command(flatten)]
    pub detail: DetailArgs,
    /// Viewpoints on the orbit.
    #[arg(long, default_value_t = 32)]
    pub viewpoints: usize,
    /// Allow a target that is not on this machine's loopback interface.
    #[arg(long)]
    pub allow_remote: bool,
    /// Print JSON: requests, errors, throughput_rps, p50_ms, p90_ms, p99_ms, max_ms, bytes, seconds (per second: at, requests, errors, p99_ms).
    #[arg(long)]
    pub json: bool,
}

/// Runs the load and prints its report (one line, or JSON).
pub fn run(args: LoadtestArgs, rt: &tokio::runtime::Runtime) -> Result<()> {
    let LoadtestArgs {
        server,
        scene,
        concurrency,
        requests,
        duration,
        detail,
        viewpoints,
        allow_remote,
        json,
    } = args;
    let detail = detail.detail()?;
    dmesh_client::loadtest::check_target(&server, allow_remote)?;
    let stop = match (requests, duration) {
        (Some(n), _) => dmesh_client::loadtest::Stop::Requests(n),
        (None, Some(s)) if s.is_finite() && s > 0.0 && s <= 86_400.0 => {
            dmesh_client::loadtest::Stop::Duration(std::time::Duration::from_secs_f64(s))
        }
        _ => bail!("give --requests N or --duration S (seconds, at most a day)"),
    };
    let report = rt.block_on(async {
        let s = Server::new(&server, None).with_wire(detail.wire);
        let cameras = dmesh_client::loadtest::orbit(&s.cameras(&scene).await?, viewpoints)?;
        dmesh_client::loadtest::run(&s, &scene, &cameras, detail, concurrency, stop).await
    })?;
    if json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "{} requests, {} errors, {:.1} req/s; latency p50 {:.2} ms, p90 {:.2} ms, p99 {:.2} ms, max {:.2} ms; \
                 server extraction p50 {:.2} ms; {} bytes",
            report.requests,
            report.errors,
            report.throughput_rps,
            report.p50_ms,
            report.p90_ms,
            report.p99_ms,
            report.max_ms,
            report.server_extract_p50_ms,
            report.bytes
        );
    }
    Ok(())
}
