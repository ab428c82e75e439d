//! Each step of a build is a `trace` span (`hierarchy.rs`), which
//! `examples/build_timeline.rs` prints and `docs/live.md` reads: on two
//! threads, each step comes on the thread the schedule gives it, within
//! the build.

#[path = "../examples/timeline/mod.rs"]
mod timeline;

use std::sync::Arc;

use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Segmentation, Threads};
use timeline::Timeline;

#[test]
fn a_build_on_two_threads_reports_each_step_on_its_thread() {
    let timeline = Arc::new(Timeline::new());
    // The only test of this binary: the helper thread reports to the
    // global subscriber.
    tracing::subscriber::set_global_default(Arc::clone(&timeline)).unwrap();
    // The second size shares level 1 of the pass with the helper.
    for (w, h) in [(257, 193), (1281, 1281)] {
        one_build(&timeline, (w, h));
    }
}

/// A build of a `w x h` ramp with a step on two threads, and its spans.
fn one_build(timeline: &Timeline, (w, h): (usize, usize)) {
    // A ramp with a step, so some cells are segmented.
    let z = (0..w * h)
        .map(|i| {
            if i % w < w / 2 {
                2.0 + (i / w) as f32 * 1e-3
            } else {
                3.0
            }
        })
        .collect();
    let depth = DepthImage::from_z(w as u32, h as u32, z).unwrap();
    let f = 0.8 * w as f64;
    let camera = Camera::perspective(w as u32, h as u32, f, f, 0.5 * w as f64, 0.5 * h as f64).unwrap();
    timeline.restart();
    let mesh = Hierarchy::build_with(&depth, &camera, &Segmentation::default(), Threads::Parallel).unwrap();
    let spans = timeline.spans();
    let on = |thread: &str, name: &str| spans.iter().any(|s| s.thread == thread && s.name == name);
    for (thread, name) in [
        ("helper", "leaf_flags"),
        ("calling", "leaf_flags"),
        ("helper", "deviations_1_3"),
        ("calling", "finest"),
        ("calling", "level g=1"),
        ("calling", "level g=2"),
    ] {
        assert!(
            on(thread, name),
            "no {name} on the {thread} thread: {:?}",
            names(&spans)
        );
    }
    assert!(
        spans.iter().any(|s| s.name == "normals"),
        "no normals: {:?}",
        names(&spans)
    );
    // Every level of the pass, once.
    let levels = spans.iter().filter(|s| s.name.starts_with("level ")).count();
    assert_eq!(levels, mesh.grid().k as usize - 1, "{:?}", names(&spans));
    // Level 1 in two bands on grids of 1.5 million vertices and up
    // (`hierarchy.rs`): the lower one on whichever thread took it first.
    let shared = mesh.grid().len() >= 3 << 19;
    for (thread, name) in [("calling", "level_1_upper"), ("calling", "level_1_meet")] {
        assert_eq!(
            on(thread, name),
            shared,
            "{name} on the {thread} thread: {:?}",
            names(&spans)
        );
    }
    let lower = spans.iter().any(|s| s.name == "level_1_lower");
    assert_eq!(lower, shared, "{:?}", names(&spans));
    let build = spans
        .iter()
        .find(|s| s.name.starts_with("build "))
        .expect("no build span");
    for s in &spans {
        assert!(s.from <= s.to, "{} ends before it starts", s.name);
        assert!(
            s.from >= build.from && s.to <= build.to,
            "{} ({:.3}-{:.3} ms) outside the build ({:.3}-{:.3})",
            s.name,
            s.from,
            s.to,
            build.from,
            build.to
        );
    }
}

fn names(spans: &[timeline::Span]) -> Vec<String> {
    spans.iter().map(|s| format!("{} {}", s.thread, s.name)).collect()
}
