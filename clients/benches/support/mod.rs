//! What the service benchmarks share: `dmesh serve`'s stack in process.

use std::sync::Arc;

/// The server binary's allocator (see the root `Cargo.toml`), so the
/// benches that include this module measure what the binary runs.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// A server running in this process. Dropping it stops the server and
/// removes its store.
pub struct InProcess {
    /// Its runtime: two worker threads, as `dmesh serve` on this 2-core machine.
    pub runtime: tokio::runtime::Runtime,
    /// `http://127.0.0.1:PORT`.
    pub base: String,
    /// The file store's folder, removed on drop.
    _store: tempfile::TempDir,
}

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
