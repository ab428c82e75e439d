//! A bounded load generator for `/render`: novel cameras on an orbit around
//! the scene, `concurrency` clients in flight, stopping by itself after a
//! request count or a duration. Loopback only unless allowed otherwise.
//!
//! Each client sends its next request as soon as the previous one is
//! answered, except after a 503: then it backs off as a well-behaved client
//! does, 5 ms doubling up to 160 ms with jitter, reset by a success (the
//! server's `Retry-After` is in whole seconds, too coarse to keep 64 clients
//! busy). Latencies are of served requests; shed ones are counted by status.

use std::net::{IpAddr, ToSocketAddrs};
use std::sync::Arc;
use std::time::{Duration, Instant};

use dmesh_engine::camera::Camera;
use glam::{DMat3, DVec3};
use hdrhistogram::Histogram;
use serde::Serialize;
use tokio::sync::Mutex;

use crate::http::Server;

/// When to stop.
#[derive(Clone, Copy, Debug)]
pub enum Stop {
    /// After this many requests.
    Requests(u64),
    /// After this long.
    Duration(Duration),
}

/// The level of detail every request of a run asks for (default: tau 1
/// pixel), its depth coding and how many views.
#[derive(Clone, Copy, Debug)]
pub struct Detail {
    /// The level of detail.
    pub lod: dmesh_proto::Lod,
    /// Residual bit-depth.
    pub bits: Option<u8>,
    /// Most views per answer (server default when absent).
    pub max_views: Option<u32>,
    /// How meshes travel.
    pub wire: crate::http::Wire,
}

impl Default for Detail {
    fn default() -> Self {
        Self {
            lod: dmesh_proto::Lod::Tau(1.0),
            bits: None,
            max_views: None,
            wire: crate::http::Wire::Compact,
        }
    }
}

impl Detail {
    /// The render request for `camera`.
    pub fn request(&self, camera: dmesh_proto::Camera) -> dmesh_proto::RenderRequest {
        dmesh_proto::RenderRequest {
            camera,
            lod: self.lod,
            bits: self.bits,
            max_views: self.max_views,
            max_angle_deg: None,
            selection: dmesh_proto::Selection::Dmesh,
        }
    }
}

/// What a run measured.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    /// Requests sent.
    pub requests: u64,
    /// Requests that failed (any non-2xx or transport error).
    pub errors: u64,
    /// Failed requests by status (0 for transport errors).
    pub errors_by_status: std::collections::BTreeMap<u16, u64>,
    /// Successful requests per second.
    pub throughput_rps: f64,
    /// Client-side latency percentiles, milliseconds.
    pub p50_ms: f64,
    /// 90th percentile.
    pub p90_ms: f64,
    /// 99th percentile.
    pub p99_ms: f64,
    /// Largest latency.
    pub max_ms: f64,
    /// Median server-side extraction time reported by the responses.
    pub server_extract_p50_ms: f64,
    /// Response bytes received in all.
    pub bytes: u64,
    /// One entry per second of the run, by when each request ended: what an
    /// outage and its recovery look like over time.
    pub seconds: Vec<Second>,
}

/// The requests that ended within one second of a run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Second {
    /// Seconds since the run started (this window is `[at, at + 1)`).
    pub at: u64,
    /// Requests that ended in it.
    pub requests: u64,
    /// Of which failed.
    pub errors: u64,
    /// 99th percentile latency of its served requests (0 when none).
    pub p99_ms: f64,
}

/// Refuses a server that is not on the loopback interface unless `allow_remote`.
pub fn check_target(base: &str, allow_remote: bool) -> anyhow::Result<()> {
    if allow_remote {
        return Ok(());
    }
    let host_port = base.trim_start_matches("http://").split('/').next().unwrap_or_default();
    let addrs: Vec<IpAddr> = host_port
        .to_socket_addrs()
        .map(|a| a.map(|s| s.ip()).collect())
        .unwrap_or_default();
    if addrs.is_empty() || !addrs.iter().all(IpAddr::is_loopback) {
        anyhow::bail!("load test target {base} is not a loopback address; pass --allow-remote to load another host");
    }
    Ok(())
}

/// Cameras on a circle around the point the reference views look at (the
/// least-squares meeting point of their optical axes), at their mean height
/// and distance.
pub fn orbit(references: &[Camera], count: usize) -> anyhow::Result<Vec<Camera>> {
    let first = references
        .first()
        .ok_or_else(|| anyhow::anyhow!("the scene has no view"))?;
    let (mut a, mut b) = (DMat3::ZERO, DVec3::ZERO);
    for c in references {
        let d = c.rotation * DVec3::Z;
        let m = DMat3::IDENTITY - DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        a += m;
        b += m * c.translation;
    }
    let centroid = references.iter().map(|c| c.translation).sum::<DVec3>() / references.len() as f64;
    let target = if a.determinant().abs() > 1e-9 {
        a.inverse() * b
    } else {
        centroid + direction(first)
    };
    let radius = references
        .iter()
        .map(|c| (c.translation - target).length())
        .sum::<f64>()
        / references.len() as f64;
    let height = centroid.y;
    (0..count.max(1))
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / count.max(1) as f64;
            let flat = (radius * radius - (height - target.y).powi(2))
                .max(radius * radius * 0.25)
                .sqrt();
            let eye = DVec3::new(target.x + flat * t.sin(), height, target.z + flat * t.cos());
            let rotation = dmesh_engine::sim::rig::look_at(eye, target);
            Ok(Camera::new(first.width, first.height, first.projection, rotation, eye)?)
        })
        .collect()
}

fn direction(c: &Camera) -> DVec3 {
    c.rotation * DVec3::Z
}

/// Runs the load test.
pub async fn run(
    server: &Server,
    scene: &str,
    cameras: &[Camera],
    detail: Detail,
    concurrency: usize,
    stop: Stop,
) -> anyhow::Result<Report> {
    struct Shared {
        latency: Histogram<u64>,
        extract: Histogram<u64>,
        report: Report,
        issued: u64,
        /// Per second: requests, errors, latencies of the served ones.
        seconds: Vec<(u64, u64, Histogram<u64>)>,
    }
    let shared = Arc::new(Mutex::new(Shared {
        latency: Histogram::new_with_bounds(1, 600_000_000, 3)?,
        extract: Histogram::new_with_bounds(1, 600_000_000, 3)?,
        report: Report::default(),
        issued: 0,
        seconds: Vec::new(),
    }));
    let started = Instant::now();
    let cameras: Arc<Vec<dmesh_proto::Camera>> = Arc::new(cameras.iter().map(dmesh_proto::Camera::from).collect());
    let mut workers = Vec::new();
    for worker in 0..concurrency.max(1) {
        let (shared, cameras, server, scene) = (shared.clone(), cameras.clone(), server.clone(), scene.to_string());
        workers.push(tokio::spawn(async move {
            let mut backoff_us = 0u64;
            // Per-client jitter without a random number crate.
            let mut jitter = 0x9e37_79b9_7f4a_7c15u64.wrapping_mul(1 + worker as u64);
            loop {
                if backoff_us > 0 {
                    jitter ^= jitter << 13;
                    jitter ^= jitter >> 7;
                    jitter ^= jitter << 17;
                    let wait = backoff_us / 2 + jitter % (backoff_us / 2 + 1);
                    tokio::time::sleep(Duration::from_micros(wait)).await;
                }
                let k = {
                    let mut s = shared.lock().await;
                    let done = match stop {
                        Stop::Requests(n) => s.issued >= n,
                        Stop::Duration(d) => started.elapsed() >= d,
                    };
                    if done {
                        break;
                    }
                    s.issued += 1;
                    s.issued
                };
                let request = detail.request(cameras[(k as usize) % cameras.len()].clone());
                let t = Instant::now();
                let result = server.render_timed(&scene, &request).await;
                let micros = (t.elapsed().as_micros() as u64).max(1);
                let at = started.elapsed().as_secs() as usize;
                let mut s = shared.lock().await;
                while s.seconds.len() <= at {
                    let h = Histogram::new_with_bounds(1, 600_000_000, 2).expect("valid bounds");
                    s.seconds.push((0, 0, h));
                }
                s.seconds[at].0 += 1;
                s.report.requests += 1;
                if s.report.requests % 100 == 0 {
                    eprint!("\r{} requests", s.report.requests);
                }
                backoff_us = match result {
                    Err(503) => (backoff_us * 2).clamp(5_000, 160_000),
                    _ => 0,
                };
                match result {
                    Ok((bytes, extract_ms)) => {
                        let _ = s.latency.record(micros);
                        let _ = s.seconds[at].2.record(micros);
                        let _ = s.extract.record(((extract_ms * 1e3) as u64).max(1));
                        s.report.bytes += bytes;
                    }
                    Err(status) => {
                        s.seconds[at].1 += 1;
                        s.report.errors += 1;
                        *s.report.errors_by_status.entry(status).or_default() += 1;
                    }
                }
            }
        }));
    }
    for w in workers {
        w.await?;
    }
    eprintln!();
    let elapsed = started.elapsed().as_secs_f64();
    let s = shared.lock().await;
    let ms = |h: &Histogram<u64>, q: f64| {
        if h.is_empty() {
            0.0
        } else {
            h.value_at_quantile(q) as f64 / 1e3
        }
    };
    let mut report = s.report.clone();
    report.throughput_rps = (report.requests - report.errors) as f64 / elapsed.max(1e-9);
    report.p50_ms = ms(&s.latency, 0.5);
    report.p90_ms = ms(&s.latency, 0.9);
    report.p99_ms = ms(&s.latency, 0.99);
    report.max_ms = if s.latency.is_empty() {
        0.0
    } else {
        s.latency.max() as f64 / 1e3
    };
    report.server_extract_p50_ms = ms(&s.extract, 0.5);
    report.seconds = (s.seconds.iter().enumerate())
        .map(|(at, (requests, errors, h))| Second {
            at: at as u64,
            requests: *requests,
            errors: *errors,
            p99_ms: ms(h, 0.99),
        })
        .collect();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_loopback_targets_by_default() {
        assert!(check_target("http://127.0.0.1:8080", false).is_ok());
        assert!(check_target("http://localhost:8080", false).is_ok());
        let e = check_target("http://10.1.2.3:8080", false).unwrap_err().to_string();
        assert!(e.contains("--allow-remote"), "{e}");
        assert!(check_target("http://10.1.2.3:8080", true).is_ok());
    }

    #[test]
    fn the_orbit_circles_the_meeting_point_of_the_reference_axes() {
        let refs = dmesh_engine::sim::SceneSpec::demo().rig.cameras(64, 48, 60.0).unwrap();
        let cams = orbit(&refs, 8).unwrap();
        assert_eq!(cams.len(), 8);
        let target = DVec3::new(0.0, 0.4, 0.0);
        for c in &cams {
            // Every orbit camera looks at the demo rig's target.
            let to = (target - c.translation).normalize();
            assert!(direction(c).dot(to) > 0.999, "{:?}", direction(c));
        }
    }
}
