//! The HTTP service: a thin axum layer over the engine and the store.
//!
//! `app(state)` builds the router (tests drive it without a socket);
//! [`serve`] binds and runs it. The browser viewer is served at `/` from
//! files embedded in the binary ([`web`]). The tower stack, outermost first:
//! compression (zstd, br at quality 4, gzip); load shedding over two concurrency limits,
//! reads by the number of cores and uploads apart from them (excess
//! requests get 503 + `Retry-After` after a short wait instead of queueing
//! without bound; the viewer's files, health and metrics are never shed); per-route
//! metrics; the request timeout (408); the body-size limit. CPU-bound work
//! (decoding, building, extracting) runs on the blocking pool, never on the
//! async workers.

pub mod conditional;
pub mod error;
pub mod negotiate;
mod slots;
pub mod strips;
pub mod views;
pub mod web;

use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::error_handling::HandleErrorLayer;
use axum::extract::{DefaultBodyLimit, MatchedPath, Request, State};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{BoxError, Router};
use tower::ServiceBuilder;
use tower_http::compression::CompressionLayer;

use slots::Slots;

pub use crate::service::{AppState, Settings, DEFAULT_REVALIDATE};
pub use error::AppError;

/// The port `dmesh serve` listens on by default (on 127.0.0.1).
pub const DEFAULT_PORT: u16 = 8080;

/// The embedded store's default data directory.
pub const DEFAULT_DATA_DIR: &str = "./dmesh-data";

/// Concurrency and timeout of the request pipeline.
#[derive(Clone, Copy, Debug)]
pub struct Pipeline {
    /// Reads served at once (renders, strips, summaries, colours, lists:
    /// CPU-bound when they extract or rebuild a hierarchy); more wait up to
    /// `queue_wait` for a slot, then are shed with 503.
    pub max_concurrency: usize,
    /// Uploads served at once, limited apart from reads so that slow
    /// uploads never hold a render's slot.
    pub max_uploads: usize,
    /// Longest a request waits for a free slot before it is shed.
    pub queue_wait: Duration,
    /// Longest a request may take.
    pub timeout: Duration,
}

/// The machine's cores, as the process may use them (at least 1).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
}

impl Default for Pipeline {
    /// Reads admitted by the number of cores and uploads by half of them,
    /// each after a wait of at most 5 ms: latency stays flat and the excess
    /// is shed, on any machine.
    fn default() -> Self {
        Self {
            max_concurrency: cores(),
            max_uploads: (cores() / 2).max(1),
            queue_wait: Duration::from_millis(5),
            timeout: Duration::from_secs(30),
        }
    }
}

async fn timed_out(error: BoxError) -> AppError {
    if error.is::<tower::timeout::error::Elapsed>() {
        AppError::Timeout
    } else {
        AppError::Internal(format!("middleware: {error}"))
    }
}

/// Load shedding: a request that finds no free slot of its class (uploads
/// are `PUT`s, everything else under `/v1` is a read) waits for one at most
/// `queue_wait` (a short queue absorbs bursts without letting latency
/// grow), then is answered 503. Health and metrics are never shed. (A tower
/// layer on the router would be instantiated per route.)
async fn shed(State(slots): State<Arc<Slots>>, mut request: Request, next: Next) -> Response {
    let path = request.uri().path();
    if !path.starts_with("/v1/") {
        return next.run(request).await;
    }
    let upload = request.method() == axum::http::Method::PUT;
    if upload {
        request.extensions_mut().insert(BuildSlot(slots.clone()));
    }
    let free = if upload { slots.try_upload() } else { slots.try_read() };
    if let Some(_permit) = free {
        return next.run(request).await;
    }
    let wait = async {
        if upload {
            slots.upload().await
        } else {
            slots.read().await
        }
    };
    match tokio::time::timeout(slots.wait, wait).await {
        Ok(Some(_permit)) => next.run(request).await,
        _ => AppError::Overloaded(1).into_response(),
    }
}

/// Handed to an upload: its build takes one of the read slots too, once
/// the body is in, so that while a frame builds the renders hold at most
/// the other cores and the build has one of its own (a live view keeps its
/// frame rate while clients render it). It goes ahead of the reads queued
/// (`slots.rs`), and is never shed: the upload was admitted.
#[derive(Clone)]
pub struct BuildSlot(Arc<Slots>);

impl BuildSlot {
    /// A read slot, held while the permit lives.
    pub async fn acquire(&self) -> Option<tokio::sync::SemaphorePermit<'_>> {
        self.0.build().await
    }
}

async fn record(State(state): State<Arc<AppState>>, request: Request, next: Next) -> Response {
    let route = request
        .extensions()
        .get::<MatchedPath>()
        .map_or_else(|| "unmatched".to_string(), |p| p.as_str().to_string());
    let start = Instant::now();
    let span = tracing::debug_span!("request", method = %request.method(), route = %route);
    let response = tracing::Instrument::instrument(next.run(request), span.clone()).await;
    let (status, ms) = (response.status().as_u16(), start.elapsed().as_secs_f64() * 1e3);
    span.in_scope(|| {
        if status >= 500 {
            tracing::warn!(status, ms, "answered");
        } else {
            tracing::debug!(status, ms, "answered");
        }
    });
    state.metrics.request(&route, status, ms);
    response
}

/// 200 `ok`; 503 `warming` while a restarted replica builds the views it
/// held, so a balancer's health check holds traffic back until then.
async fn healthz(State(state): State<Arc<AppState>>) -> (axum::http::StatusCode, &'static str) {
    if state.ready() {
        (axum::http::StatusCode::OK, "ok\n")
    } else {
        (axum::http::StatusCode::SERVICE_UNAVAILABLE, "warming\n")
    }
}

async fn metrics_text(State(state): State<Arc<AppState>>) -> Result<Response, AppError> {
    let st = state.clone();
    let bytes = tokio::task::spawn_blocking(move || st.store.bytes_stored()).await??;
    Ok((
        [(axum::http::header::CONTENT_TYPE, "text/plain; version=0.0.4")],
        state.metrics.render(bytes),
    )
        .into_response())
}

/// The router over `state`.
pub fn app(state: Arc<AppState>, pipeline: Pipeline) -> Router {
    let api = Router::new()
        .route("/v1/scenes", get(views::list_scenes))
        .route("/v1/scenes/{scene}", axum::routing::delete(views::delete_scene))
        .route("/v1/scenes/{scene}/views", get(views::list_views))
        .route(
            "/v1/scenes/{scene}/views/{view}",
            get(views::get_view).put(views::put_view).delete(views::delete_view),
        )
        .route("/v1/scenes/{scene}/views/{view}/color", get(views::get_color))
        .route(
            "/v1/scenes/{scene}/views/{view}/strips",
            get(strips::get_strips).post(strips::post_strips),
        )
        .route("/v1/scenes/{scene}/render", post(strips::render))
        .route("/healthz", get(healthz))
        .route("/metrics", get(metrics_text))
        .fallback(|| async { AppError::NotFound("no such endpoint; see proto/openapi.yaml".into()) })
        .method_not_allowed_fallback(|| async { AppError::MethodNotAllowed })
        .layer(DefaultBodyLimit::max(state.settings.max_upload_bytes))
        .layer(
            ServiceBuilder::new()
                .layer(HandleErrorLayer::new(timed_out))
                .timeout(pipeline.timeout),
        );
    let slots = Arc::new(Slots::new(
        pipeline.max_concurrency,
        pipeline.max_uploads,
        pipeline.queue_wait,
    ));
    // The viewer's files are served from memory outside the limit: shedding
    // them would only break a page load without sparing any CPU-bound work.
    api.route_layer(middleware::from_fn_with_state(state.clone(), record))
        .layer(middleware::from_fn_with_state(slots, shed))
        .merge(web::routes())
        .layer(CompressionLayer::new())
        .with_state(state)
}

/// Serves on `listener` until Ctrl-C, saying where.
pub async fn serve(listener: tokio::net::TcpListener, state: Arc<AppState>, pipeline: Pipeline) -> std::io::Result<()> {
    let local = listener.local_addr()?;
    tracing::info!("dmesh listening on http://{local}");
    tracing::info!("viewer: open http://{local}/ in a browser");
    serve_on(listener, state, pipeline).await
}

/// Over a shared store: the check of the scenes in use every third of
/// `revalidate` ([`AppState::revalidate_used`]); with a replica id, the
/// warm-up from its note and the note kept every [`NOTE_EVERY`].
fn background_replica_tasks(state: &Arc<AppState>) -> Vec<tokio::task::JoinHandle<()>> {
    let mut tasks = Vec::new();
    if !state.store.shared() {
        return tasks;
    }
    let revalidate = state.settings.revalidate;
    if !revalidate.is_zero() {
        let state = state.clone();
        tasks.push(tokio::spawn(async move {
            let tick = (revalidate / 3).max(Duration::from_millis(20));
            loop {
                tokio::time::sleep(tick).await;
                let st = state.clone();
                let _ = tokio::task::spawn_blocking(move || st.revalidate_used()).await;
            }
        }));
    }
    if state.settings.replica.is_some() {
        let state = state.clone();
        tasks.push(tokio::spawn(async move {
            let st = state.clone();
            let _ = tokio::task::spawn_blocking(move || st.warm()).await;
            loop {
                tokio::time::sleep(NOTE_EVERY).await;
                let st = state.clone();
                if let Ok(Err(e)) = tokio::task::spawn_blocking(move || st.keep_note()).await {
                    tracing::warn!(error = ?e, "keeping this replica's note");
                }
            }
        }));
    }
    tasks
}

/// How often a replica notes the views it holds, for its restart.
pub const NOTE_EVERY: Duration = Duration::from_secs(2);

/// Serves on a bound listener until Ctrl-C (tests bind 127.0.0.1:0).
pub async fn serve_on(
    listener: tokio::net::TcpListener,
    state: Arc<AppState>,
    pipeline: Pipeline,
) -> std::io::Result<()> {
    // Live views' latest frames reach the disk within `live_persist`.
    let every = state.settings.live_persist;
    let persister = {
        let state = state.clone();
        tokio::spawn(async move {
            let tick = (every / 4).clamp(Duration::from_millis(10), Duration::from_millis(250));
            loop {
                tokio::time::sleep(tick).await;
                let st = state.clone();
                if let Ok(Err(e)) = tokio::task::spawn_blocking(move || st.persist_live(every)).await {
                    tracing::warn!(error = ?e, "making live frames durable");
                }
            }
        })
    };
    let replica = background_replica_tasks(&state);
    let served = axum::serve(listener, app(state.clone(), pipeline))
        .with_graceful_shutdown(async {
            let _ = tokio::signal::ctrl_c().await;
        })
        .await;
    persister.abort();
    for task in replica {
        task.abort();
    }
    // What is still waiting reaches the disk before the server exits.
    let st = state.clone();
    if let Ok(Err(e)) = tokio::task::spawn_blocking(move || st.persist_live(Duration::ZERO)).await {
        tracing::warn!(error = ?e, "making live frames durable at shutdown");
    }
    served
}

#[cfg(test)]
mod tests {
    //! The router without a socket: requests through `app(state)` with
    //! `tower::ServiceExt::oneshot`.
    use super::*;
    use crate::store::FileStore;
    use axum::body::{to_bytes, Body};
    use axum::http::{header, StatusCode};
    use tower::ServiceExt;

    fn router(dir: &std::path::Path) -> Router {
        let store = Arc::new(FileStore::open(dir).unwrap());
        app(Arc::new(AppState::new(store, Settings::default())), Pipeline::default())
    }

    async fn call(router: &Router, request: Request<Body>) -> (StatusCode, serde_json::Value) {
        let response = router.clone().oneshot(request).await.unwrap();
        let status = response.status();
        let bytes = to_bytes(response.into_body(), 1 << 24).await.unwrap();
        (
            status,
            serde_json::from_slice(&bytes).unwrap_or(serde_json::Value::Null),
        )
    }

    fn json(method: &str, uri: &str, body: String) -> Request<Body> {
        Request::builder()
            .method(method)
            .uri(uri)
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body))
            .unwrap()
    }

    /// A 16 x 12 view: a slanted plane and a grey image.
    fn upload() -> (String, Request<Body>) {
        let camera = dmesh_engine::camera::Camera::perspective(16, 12, 14.0, 14.0, 7.5, 5.5).unwrap();
        let camera = serde_json::to_string(&dmesh_proto::Camera::from(&camera)).unwrap();
        let z: Vec<f32> = (0..16 * 12).map(|i| 2.0 + 0.01 * (i % 16) as f32).collect();
        let depth = dmesh_engine::image::encode_pfm(16, 12, &z);
        let mut color = Vec::new();
        image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(16, 12, image::Rgb([90, 90, 90])))
            .write_to(&mut std::io::Cursor::new(&mut color), image::ImageFormat::Png)
            .unwrap();
        let mut body = Vec::new();
        for (name, data) in [
            ("camera", camera.as_bytes()),
            ("depth", &depth[..]),
            ("color", &color[..]),
        ] {
            body.extend_from_slice(
                format!("--b\r\nContent-Disposition: form-data; name=\"{name}\"\r\n\r\n").as_bytes(),
            );
            body.extend_from_slice(data);
            body.extend_from_slice(b"\r\n");
        }
        body.extend_from_slice(b"--b--\r\n");
        let request = Request::put("/v1/scenes/s/views/v")
            .header(header::CONTENT_TYPE, "multipart/form-data; boundary=b")
            .body(Body::from(body))
            .unwrap();
        (camera, request)
    }

    #[tokio::test]
    async fn uploads_strips_and_renders_answer_through_the_router() {
        let dir = tempfile::tempdir().unwrap();
        let router = router(dir.path());
        let (camera, put) = upload();
        let (status, summary) = call(&router, put).await;
        assert_eq!(status, StatusCode::CREATED, "{summary}");
        assert_eq!(summary["view"], "v");

        // The query form and the body form of one level of detail.
        let get = Request::get("/v1/scenes/s/views/v/strips?epsilon=0.001")
            .body(Body::empty())
            .unwrap();
        let (status, strips) = call(&router, get).await;
        assert_eq!(status, StatusCode::OK, "{strips}");
        assert_eq!(strips["lod"]["epsilon"], 0.001);
        let body = r#"{"lod": {"max_triangles": 200}}"#.to_string();
        let (status, budgeted) = call(&router, json("POST", "/v1/scenes/s/views/v/strips", body)).await;
        assert_eq!(status, StatusCode::OK, "{budgeted}");
        assert!(budgeted["triangles"].as_u64().unwrap() <= 200);
        assert!(
            budgeted["lod"]["epsilon"].is_number(),
            "a static budget states epsilon: {budgeted}"
        );

        let body = format!(r#"{{"camera": {camera}, "lod": {{"tau": 1}}}}"#);
        let (status, render) = call(&router, json("POST", "/v1/scenes/s/render", body)).await;
        assert_eq!(status, StatusCode::OK, "{render}");
        assert_eq!(render["views"].as_array().unwrap().len(), 1);
        assert_eq!(render["views"][0]["strips"]["lod"]["tau"], 1.0);
    }

    #[tokio::test]
    async fn a_level_of_detail_is_one_value() {
        let dir = tempfile::tempdir().unwrap();
        let router = router(dir.path());
        let (camera, put) = upload();
        assert_eq!(call(&router, put).await.0, StatusCode::CREATED);
        let refused = [
            // The flat fields of protocol 4 are no longer a body's form.
            json("POST", "/v1/scenes/s/views/v/strips", r#"{"epsilon": 0.01}"#.into()),
            json(
                "POST",
                "/v1/scenes/s/views/v/strips",
                r#"{"lod": {"tau": 1, "epsilon": 1}}"#.into(),
            ),
            json("POST", "/v1/scenes/s/views/v/strips", r#"{"lod": {"tau": 1}}"#.into()),
            json(
                "POST",
                "/v1/scenes/s/views/v/strips",
                format!(r#"{{"lod": {{"epsilon": 1}}, "camera": {camera}}}"#),
            ),
            json(
                "POST",
                "/v1/scenes/s/views/v/strips",
                r#"{"lod": {"budget_ms": 0}}"#.into(),
            ),
            Request::get("/v1/scenes/s/views/v/strips?epsilon=1&tau=1")
                .body(Body::empty())
                .unwrap(),
            json(
                "POST",
                "/v1/scenes/s/render",
                format!(r#"{{"camera": {camera}, "tau": 1}}"#),
            ),
        ];
        for request in refused {
            let what = format!("{} {}", request.method(), request.uri());
            let (status, body) = call(&router, request).await;
            assert_eq!(status, StatusCode::BAD_REQUEST, "{what}: {body}");
            assert!(body["error"]["message"].is_string(), "{what}: {body}");
        }
        // A share below the coarsest mesh is refused, not exceeded.
        let body = format!(r#"{{"camera": {camera}, "lod": {{"max_triangles": 1}}}}"#);
        let (status, body) = call(&router, json("POST", "/v1/scenes/s/render", body)).await;
        assert_eq!(status, StatusCode::CONFLICT, "{body}");
    }
}
