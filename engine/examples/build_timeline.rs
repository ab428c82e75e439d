//! When each step of a build ran, and on which thread: builds the
//! synthetic scene (or a Middlebury scene of `../shared/data`) a few times
//! to warm up, then prints the spans of one more build (the engine's
//! `trace` spans: leaf flags, deviations, the finest level, each level of
//! the pass, normals) in ms from its start. Usage:
//! `build_timeline [SIZE | WxH | SCENE] [THREADS] [WARMUP]` (threads 1 or
//! 2, default as `Hierarchy::build`; 5 builds of warm-up by default).
//! `docs/live.md` reads two threads' timelines from it.

#[path = "../benches/scenes.rs"]
mod scenes;
/// The server's allocator (see the root `Cargo.toml`), so the figures are
/// the binary's.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::ThreadId;
use std::time::Instant;

use dmesh_engine::mesh::{Hierarchy, Threads};
use tracing::field::{Field, Visit};
use tracing::span::{Attributes, Id, Record};
use tracing::{Event, Metadata, Subscriber};

fn main() {
    let mut args = std::env::args().skip(1);
    let size = args.next().unwrap_or_else(|| "513".into());
    let scene = if size.starts_with(|c: char| c.is_ascii_digit()) {
        let (w, h): (u32, u32) = match size.split_once('x') {
            Some((w, h)) => (w.parse().unwrap_or(513), h.parse().unwrap_or(513)),
            None => {
                let s = size.parse().unwrap_or(513);
                (s, s)
            }
        };
        Some(scenes::synthetic(w, h))
    } else {
        scenes::middlebury(&size)
    };
    let Some((d, c)) = scene else {
        eprintln!("no scene {size:?}: give a size (513, 1920x1080) or a Middlebury scene of ../shared/data");
        std::process::exit(2);
    };
    let threads = match args.next().as_deref() {
        Some("1") => Threads::Single,
        Some("2") => Threads::Parallel,
        _ => Threads::available(),
    };
    let warmup: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(5);
    let timeline = Arc::new(Timeline::new());
    if tracing::subscriber::set_global_default(Arc::clone(&timeline)).is_err() {
        eprintln!("a tracing subscriber is already set");
        std::process::exit(1);
    }
    let build = || Hierarchy::build_with(&d, &c, &Default::default(), threads);
    for _ in 0..warmup {
        if let Err(e) = build() {
            eprintln!("build failed: {e}");
            std::process::exit(1);
        }
    }
    timeline.restart();
    let mesh = match build() {
        Ok(mesh) => mesh,
        Err(e) => {
            eprintln!("build failed: {e}");
            std::process::exit(1);
        }
    };
    println!(
        "{}x{} {threads:?} {}: build {:.2} ms; spans in ms from the start of the build",
        d.width,
        d.height,
        dmesh_engine::simd::tier_in_use().name(),
        mesh.stats().build_ms
    );
    println!("{:<8} {:>8} {:>8} {:>8}  span", "thread", "from", "to", "ms");
    for s in timeline.spans() {
        println!(
            "{:<8} {:>8.2} {:>8.2} {:>8.2}  {}",
            s.thread,
            s.from,
            s.to,
            s.to - s.from,
            s.name
        );
    }
}

/// One span as it ran.
struct Span {
    thread: &'static str,
    from: f64,
    to: f64,
    name: String,
}

/// A subscriber that keeps, for the engine's spans since [`Self::restart`],
/// when each was entered and exited and on which thread (the thread that
/// called `restart` is the calling one, any other a helper).
struct Timeline {
    next: AtomicU64,
    state: Mutex<State>,
}

struct State {
    start: Instant,
    calling: ThreadId,
    names: HashMap<u64, String>,
    entered: HashMap<u64, Instant>,
    done: Vec<Span>,
}

impl Timeline {
    fn new() -> Self {
        Self {
            next: AtomicU64::new(1),
            state: Mutex::new(State {
                start: Instant::now(),
                calling: std::thread::current().id(),
                names: HashMap::new(),
                entered: HashMap::new(),
                done: Vec::new(),
            }),
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Forgets what was kept and counts from now.
    fn restart(&self) {
        let mut s = self.state();
        s.start = Instant::now();
        s.calling = std::thread::current().id();
        s.done.clear();
    }

    /// The spans kept, by start.
    fn spans(&self) -> Vec<Span> {
        let mut done = std::mem::take(&mut self.state().done);
        done.sort_by(|a, b| a.from.total_cmp(&b.from));
        done
    }
}

/// A span's name with its level, if it has one (`level 3`).
struct Name(String);

impl Visit for Name {
    fn record_u64(&mut self, field: &Field, value: u64) {
        self.0 = format!("{} {}={value}", self.0, field.name());
    }

    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        self.0 = format!("{} {}={value:?}", self.0, field.name());
    }
}

impl Subscriber for Timeline {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        metadata.is_span() && metadata.target().starts_with("dmesh_engine")
    }

    fn new_span(&self, span: &Attributes<'_>) -> Id {
        let id = self.next.fetch_add(1, Ordering::Relaxed);
        let mut name = Name(span.metadata().name().to_string());
        span.record(&mut name);
        self.state().names.insert(id, name.0);
        Id::from_u64(id)
    }

    fn record(&self, _: &Id, _: &Record<'_>) {}

    fn record_follows_from(&self, _: &Id, _: &Id) {}

    fn event(&self, _: &Event<'_>) {}

    fn enter(&self, span: &Id) {
        let now = Instant::now();
        self.state().entered.insert(span.into_u64(), now);
    }

    fn exit(&self, span: &Id) {
        let now = Instant::now();
        let mut s = self.state();
        let id = span.into_u64();
        let (Some(entered), Some(name)) = (s.entered.remove(&id), s.names.remove(&id)) else {
            return;
        };
        let ms = |t: Instant| t.saturating_duration_since(s.start).as_secs_f64() * 1e3;
        let thread = if std::thread::current().id() == s.calling {
            "calling"
        } else {
            "helper"
        };
        let span = Span {
            thread,
            from: ms(entered),
            to: ms(now),
            name,
        };
        s.done.push(span);
    }
}
