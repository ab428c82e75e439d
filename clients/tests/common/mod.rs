//! The real server in process on a loopback port, and scene ingest through
//! the client, shared by the client's end-to-end tests.
#![allow(dead_code)]

use std::sync::Arc;

use dmesh_client::http::Server;
use dmesh_engine::sim::SceneSpec;

/// A running server; dropping it stops the server and removes its store.
pub struct Running {
    pub base: String,
    task: tokio::task::JoinHandle<std::io::Result<()>>,
    _dir: tempfile::TempDir,
}

impl Drop for Running {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// Starts `dmesh serve` on a fresh file store and port 0.
pub async fn start() -> Running {
    let dir = tempfile::tempdir().unwrap();
    let store = dmesh::store::FileStore::open(dir.path()).unwrap();
    let state = Arc::new(dmesh::http::AppState::new(
        Arc::new(store),
        dmesh::http::Settings::default(),
    ));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    // Slots for every client these tests run at once: they check what is
    // served, not shedding (tests/server.rs and the browser tests do).
    let pipeline = dmesh::http::Pipeline {
        max_concurrency: 16,
        ..dmesh::http::Pipeline::default()
    };
    let task = tokio::spawn(dmesh::http::serve_on(listener, state, pipeline));
    Running { base, task, _dir: dir }
}

/// Uploads every reference view of `spec` as scene `scene`, views `v00`, `v01`, ...
pub async fn ingest(server: &Server, scene: &str, spec: &SceneSpec) {
    for (k, v) in spec.reference_views().unwrap().iter().enumerate() {
        let cam = serde_json::to_string(&dmesh_proto::Camera::from(&v.camera)).unwrap();
        let depth = dmesh_engine::image::encode_pfm(v.depth.width, v.depth.height, &v.depth.z);
        let img = image::RgbImage::from_raw(v.color.width, v.color.height, v.color.rgb.clone()).unwrap();
        let mut color = Vec::new();
        image::DynamicImage::ImageRgb8(img)
            .write_to(&mut std::io::Cursor::new(&mut color), image::ImageFormat::Png)
            .unwrap();
        server
            .put_view(scene, &format!("v{k:02}"), &cam, &depth, &color)
            .await
            .unwrap();
    }
}
