//! What the service benchmarks share: `dmesh serve`'s stack in process.

use std::sync::Arc;

/// The server binary's allocator (see the root `Cargo.toml`), so the
/// benches that include this module measure what the binary runs.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// A server running in this process. Dropping it stops the server and
/// removes its store.
#[allow(dead_code)] // the codec bench serves nothing
pub struct InProcess {
    /// Its runtime: two worker threads, as `dmesh serve` on this 2-core machine.
    pub runtime: tokio::runtime::Runtime,
    /// `http://127.0.0.1:PORT`.
    pub base: String,
    /// The file store's folder, removed on drop.
    _store: tempfile::TempDir,
}

#[allow(dead_code)] // the codec bench serves nothing
/// Starts the server's stack with `pipeline` over a file store in a fresh
/// temporary folder, on a free loopback port.
pub fn serve(pipeline: dmesh::http::Pipeline) -> anyhow::Result<InProcess> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let store = tempfile::tempdir()?;
    let state = Arc::new(dmesh::http::AppState::new(
        Arc::new(dmesh::store::FileStore::open(store.path())?),
        dmesh::http::Settings::default(),
    ));
    let listener = runtime.block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))?;
    let base = format!("http://{}", listener.local_addr()?);
    runtime.spawn(dmesh::http::serve_on(listener, state, pipeline));
    Ok(InProcess {
        runtime,
        base,
        _store: store,
    })
}

/// Cameras on a circle of eyes 20 degrees off the reference axis, looking at
/// the surface point under the image centre.
#[allow(dead_code)] // the load benches' scene only
pub fn orbit(
    reference: &dmesh_engine::camera::Camera,
    depth: &dmesh_engine::image::DepthImage,
    count: usize,
) -> anyhow::Result<Vec<dmesh_engine::camera::Camera>> {
    let (w, h) = (reference.width, reference.height);
    let z = f64::from(depth.z[(h / 2 * w + w / 2) as usize]);
    let target = reference.to_world(reference.back_project(f64::from(w / 2), f64::from(h / 2), z));
    let eye0 = reference.translation;
    let axis = target - eye0;
    let side = axis.cross(glam::DVec3::Y).normalize() * axis.length() * 20f64.to_radians().tan();
    let up = side.cross(axis).normalize() * side.length();
    (0..count)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / count as f64;
            let eye = eye0 + side * t.cos() + up * t.sin();
            let rotation = dmesh_engine::sim::rig::look_at(eye, target);
            Ok(dmesh_engine::camera::Camera::new(
                w,
                h,
                reference.projection,
                rotation,
                eye,
            )?)
        })
        .collect()
}
