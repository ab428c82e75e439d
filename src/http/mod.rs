//! The HTTP service: a thin axum layer over the engine and the store.
//!
//! `app(state)` builds the router (tests drive it without a socket);
//! [`serve`] binds and runs it. The browser viewer is served at `/` from
//! files embedded in the binary ([`web`]). The tower stack, outermost first:
//! compression (gzip, zstd); load shedding over one concurrency limit for
//! every route but the viewer's in-memory files (excess requests get 503 +
//! `Retry-After` at once instead of queueing without bound); per-route
//! metrics; the request timeout (408); the body-size limit. CPU-bound work
//! (decoding, building, extracting) runs on the blocking pool, never on the
//! async workers.

pub mod error;
pub mod metrics;
pub mod negotiate;
pub mod state;
pub mod strips;
pub mod views;
pub mod web;

use std::net::SocketAddr;
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

pub use error::AppError;
pub use state::{AppState, Settings};

/// The port `dmesh serve` listens on by default (on 127.0.0.1).
pub const DEFAULT_PORT: u16 = 8080;

/// The embedded store's default data directory.
pub const DEFAULT_DATA_DIR: &str = "./dmesh-data";

/// Concurrency and timeout of the request pipeline.
#[derive(Clone, Copy, Debug)]
pub struct Pipeline {
    /// Requests served at once; more wait up to `queue_wait` for a slot,
    /// then are shed with 503.
    pub max_concurrency: usize,
    /// Longest a request waits for a free slot before it is shed.
    pub queue_wait: Duration,
    /// Longest a request may take.
    pub timeout: Duration,
}

impl Default for Pipeline {
    fn default() -> Self {
        Self {
            max_concurrency: 64,
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

/// Load shedding with a concurrency limit shared by every route: a request
/// that finds no free slot waits for one at most `queue_wait` (a short queue
/// absorbs bursts without letting latency grow), then is answered 503.
/// (A tower layer on the router would be instantiated per route.)
async fn shed(
    State((slots, wait)): State<(Arc<tokio::sync::Semaphore>, Duration)>,
    request: Request,
    next: Next,
) -> Response {
    if let Ok(_permit) = slots.try_acquire() {
        return next.run(request).await;
    }
    match tokio::time::timeout(wait, slots.acquire()).await {
        Ok(Ok(_permit)) => next.run(request).await,
        _ => AppError::Overloaded(1).into_response(),
    }
}

async fn record(State(state): State<Arc<AppState>>, request: Request, next: Next) -> Response {
    let route = request
        .extensions()
        .get::<MatchedPath>()
        .map_or_else(|| "unmatched".to_string(), |p| p.as_str().to_string());
    let start = Instant::now();
    let response = next.run(request).await;
    state
        .metrics
        .request(&route, response.status().as_u16(), start.elapsed().as_secs_f64() * 1e3);
    response
}

async fn healthz() -> &'static str {
    "ok\n"
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
    let slots = Arc::new(tokio::sync::Semaphore::new(pipeline.max_concurrency.max(1)));
    // The viewer's files are served from memory outside the limit: shedding
    // them would only break a page load without sparing any CPU-bound work.
    api.route_layer(middleware::from_fn_with_state(state.clone(), record))
        .layer(middleware::from_fn_with_state((slots, pipeline.queue_wait), shed))
        .merge(web::routes())
        .layer(CompressionLayer::new())
        .with_state(state)
}

/// Binds `addr` and serves until Ctrl-C.
pub async fn serve(addr: SocketAddr, state: Arc<AppState>, pipeline: Pipeline) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr).await?;
    let local = listener.local_addr()?;
    eprintln!("dmesh listening on http://{local}");
    eprintln!("viewer: open http://{local}/ in a browser");
    serve_on(listener, state, pipeline).await
}

/// Serves on a bound listener until Ctrl-C (tests bind 127.0.0.1:0).
pub async fn serve_on(
    listener: tokio::net::TcpListener,
    state: Arc<AppState>,
    pipeline: Pipeline,
) -> std::io::Result<()> {
    axum::serve(listener, app(state, pipeline))
        .with_graceful_shutdown(async {
            let _ = tokio::signal::ctrl_c().await;
        })
        .await
}
