//! Prometheus text metrics: request latency histograms per route, extraction
//! time, triangles per response, views loaded, bytes stored.

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

const BUCKETS_MS: [f64; 12] = [
    0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 5000.0,
];
const BUCKETS_TRIANGLES: [f64; 8] = [100.0, 1e3, 1e4, 3e4, 1e5, 3e5, 1e6, 1e7];

#[derive(Clone, Default)]
struct Histogram {
    counts: Vec<u64>,
    sum: f64,
    count: u64,
}

impl Histogram {
    fn observe(&mut self, buckets: &[f64], v: f64) {
        if self.counts.is_empty() {
            self.counts = vec![0; buckets.len()];
        }
        for (c, &b) in self.counts.iter_mut().zip(buckets) {
            if v <= b {
                *c += 1;
            }
        }
        self.sum += v;
        self.count += 1;
    }

    fn render(&self, out: &mut String, name: &str, labels: &str, buckets: &[f64]) {
        let sep = if labels.is_empty() { "" } else { "," };
        for (c, b) in self.counts.iter().zip(buckets) {
            let _ = writeln!(out, "{name}_bucket{{{labels}{sep}le=\"{b}\"}} {c}");
        }
        let _ = writeln!(out, "{name}_bucket{{{labels}{sep}le=\"+Inf\"}} {}", self.count);
        let braces = if labels.is_empty() {
            String::new()
        } else {
            format!("{{{labels}}}")
        };
        let _ = writeln!(out, "{name}_sum{braces} {}", self.sum);
        let _ = writeln!(out, "{name}_count{braces} {}", self.count);
    }
}

/// The service's metrics.
#[derive(Default)]
pub struct Metrics {
    requests: Mutex<BTreeMap<(String, u16), Histogram>>,
    extract: Mutex<Histogram>,
    triangles: Mutex<Histogram>,
    views_loaded: AtomicU64,
    /// Extraction milliseconds per triangle.
    ms_per_triangle: MovingAverage,
    /// The fraction of a time budget's triangle allowance that meshes used.
    budget_fill: MovingAverage,
}

/// An exponential moving average (weight 0.1 per sample) shared between
/// threads; a lost race between two updates drops one sample, harmlessly.
#[derive(Default)]
struct MovingAverage(AtomicU64);

impl MovingAverage {
    /// The average, `None` until the first sample.
    fn get(&self) -> Option<f64> {
        Some(f64::from_bits(self.0.load(Ordering::Relaxed))).filter(|v| *v > 0.0 && v.is_finite())
    }

    /// Adds a positive finite `sample`, keeping the average in `[lo, hi]`.
    fn add(&self, sample: f64, lo: f64, hi: f64) {
        if sample.is_finite() && sample > 0.0 {
            let new = self.get().map_or(sample, |old| 0.9 * old + 0.1 * sample);
            self.0.store(new.clamp(lo, hi).to_bits(), Ordering::Relaxed);
        }
    }
}

/// Assumed extraction cost before the first measurement: 100 ns per triangle,
/// about twice what one core of the reference machine takes.
const DEFAULT_MS_PER_TRIANGLE: f64 = 1e-4;

impl Metrics {
    /// Records one request's latency.
    pub fn request(&self, route: &str, status: u16, ms: f64) {
        let mut r = self.requests.lock().unwrap_or_else(|p| p.into_inner());
        r.entry((route.to_string(), status))
            .or_default()
            .observe(&BUCKETS_MS, ms);
    }

    /// Extraction milliseconds per triangle: a moving average over recent
    /// extractions of 1,000 triangles or more (which includes the slowdown
    /// of a loaded machine, so budgets shrink under load).
    pub fn ms_per_triangle(&self) -> f64 {
        self.ms_per_triangle.get().unwrap_or(DEFAULT_MS_PER_TRIANGLE)
    }

    /// The fraction of their triangle allowance that time-budgeted meshes
    /// have used lately, in `[0.05, 1]` (0.5 before any).
    pub fn budget_fill(&self) -> f64 {
        self.budget_fill.get().map_or(0.5, |v| v.clamp(0.05, 1.0))
    }

    /// Records the fraction of its allowance one time-budgeted mesh used.
    pub fn budget_filled(&self, fraction: f64) {
        self.budget_fill.add(fraction, 0.05, 1.0);
    }

    /// Records one extraction.
    pub fn extraction(&self, ms: f64, triangles: usize) {
        if triangles >= 1000 {
            self.ms_per_triangle
                .add(ms / triangles as f64, f64::MIN_POSITIVE, f64::MAX);
        }
        self.extract
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .observe(&BUCKETS_MS, ms);
        self.triangles
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .observe(&BUCKETS_TRIANGLES, triangles as f64);
    }

    /// Sets the number of hierarchies in memory.
    pub fn set_views_loaded(&self, n: usize) {
        self.views_loaded.store(n as u64, Ordering::Relaxed);
    }

    /// The Prometheus text exposition.
    pub fn render(&self, bytes_stored: u64) -> String {
        let mut out = String::new();
        out.push_str("# HELP dmesh_request_duration_ms Request latency by route and status.\n");
        out.push_str("# TYPE dmesh_request_duration_ms histogram\n");
        for ((route, status), h) in self.requests.lock().unwrap_or_else(|p| p.into_inner()).iter() {
            h.render(
                &mut out,
                "dmesh_request_duration_ms",
                &format!("route=\"{route}\",status=\"{status}\""),
                &BUCKETS_MS,
            );
        }
        out.push_str("# HELP dmesh_extract_ms Mesh extraction time.\n# TYPE dmesh_extract_ms histogram\n");
        self.extract
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .render(&mut out, "dmesh_extract_ms", "", &BUCKETS_MS);
        out.push_str("# HELP dmesh_response_triangles Triangles per extracted mesh.\n# TYPE dmesh_response_triangles histogram\n");
        self.triangles.lock().unwrap_or_else(|p| p.into_inner()).render(
            &mut out,
            "dmesh_response_triangles",
            "",
            &BUCKETS_TRIANGLES,
        );
        let _ = writeln!(
            out,
            "# HELP dmesh_extract_ms_per_triangle Moving average used to turn budget_ms into triangles.\n# TYPE dmesh_extract_ms_per_triangle gauge\ndmesh_extract_ms_per_triangle {}",
            self.ms_per_triangle()
        );
        let _ = writeln!(
            out,
            "# HELP dmesh_views_loaded Hierarchies in memory.\n# TYPE dmesh_views_loaded gauge\ndmesh_views_loaded {}",
            self.views_loaded.load(Ordering::Relaxed)
        );
        let _ = writeln!(
            out,
            "# HELP dmesh_bytes_stored Bytes in the view store.\n# TYPE dmesh_bytes_stored gauge\ndmesh_bytes_stored {bytes_stored}"
        );
        out
    }
}
