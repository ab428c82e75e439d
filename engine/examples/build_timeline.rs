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

#[path = "timeline/mod.rs"]
mod timeline;

use std::sync::Arc;

use dmesh_engine::mesh::{Hierarchy, Threads};
use timeline::Timeline;

fn main() {
    let mut args = std::env::args().skip(1);
    let size = args.next().unwrap_or_else(|| "513".into());
    let Some((d, c)) = scenes::from_arg(&size) else {
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
