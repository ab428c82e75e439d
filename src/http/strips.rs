//! Strips of one view (static or view-dependent) and multi-view render
//! requests: each handler reads the request, calls `service::render` and
//! writes the answer with its headers.

use std::sync::Arc;

use axum::extract::rejection::{JsonRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap};
use axum::response::Response;
use axum::Json;
use dmesh_engine::camera::{camera_from_json, Camera};
use dmesh_proto::{Lod, RenderRequest, StripRequest};
use serde::Deserialize;

use super::conditional::{none_match, not_modified};
use super::error::json_rejection;
use super::negotiate::{encode, encode_compact, wants_compact};
use crate::service::render::{self, Answer, Fresh, RenderBody, StripAsk, StripBody};
use crate::service::{AppError, AppState};

/// Query of `GET .../strips`: `epsilon`, or `tau` with the requesting
/// `camera` (JSON), or a budget (`max_triangles` or `budget_ms`, optionally
/// with `camera`); optionally `bits`. The flat form of the body's `lod`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StripQuery {
    epsilon: Option<f64>,
    tau: Option<f64>,
    camera: Option<String>,
    max_triangles: Option<u32>,
    budget_ms: Option<f64>,
    bits: Option<u8>,
    held: Option<String>,
    held_camera: Option<String>,
}

impl StripQuery {
    /// The request it states.
    fn ask(self) -> Result<StripAsk, AppError> {
        Ok(StripAsk {
            lod: Lod::exactly_one(self.epsilon, self.tau, self.max_triangles, self.budget_ms)
                .map_err(|e| AppError::BadRequest(e.into()))?,
            camera: self.camera.as_deref().map(camera_from_json).transpose()?,
            bits: self.bits,
            held: held(self.held)?,
            held_camera: self.held_camera.as_deref().map(camera_from_json).transpose()?,
        })
    }
}

/// Longest `held` ETag accepted, in characters (`openapi.yaml`, `Held`): an
/// ETag the server wrote is far shorter, so a longer one is a client's bug,
/// answered 400 rather than silently treated as "holds nothing".
pub const MAX_HELD_CHARS: usize = 512;

/// `held` checked against [`MAX_HELD_CHARS`].
fn held(held: Option<String>) -> Result<Option<String>, AppError> {
    let chars = held.as_deref().map_or(0, |h| h.chars().count());
    if chars > MAX_HELD_CHARS {
        return Err(AppError::BadRequest(format!(
            "held: {chars} characters; an ETag this server wrote has at most {MAX_HELD_CHARS}"
        )));
    }
    Ok(held)
}

/// The strips answer with its ETag, timing and frame age, or a 304.
async fn strips(
    state: Arc<AppState>,
    at: (String, String),
    headers: HeaderMap,
    ask: StripAsk,
) -> Result<Response, AppError> {
    let answer = render::strips(&state, at, ask, wants_compact(&headers), |tag| {
        none_match(&headers, tag)
    })
    .await?;
    match answer {
        Answer::NotModified(tag) => Ok(not_modified(tag)),
        Answer::Fresh(fresh) => {
            let out = match &fresh.body {
                StripBody::Compact(body) => encode_compact(body)?,
                StripBody::Strips(body) => encode(&headers, body)?,
            };
            Ok(with_headers(out, &fresh))
        }
    }
}

/// `GET /v1/scenes/{scene}/views/{view}/strips?epsilon=E`, `?tau=T&camera=JSON`,
/// `?max_triangles=N[&camera=JSON]` or `?budget_ms=MS[&camera=JSON]`, each with optional `&bits=B`
/// (and, for the compact stream, `&held=ETAG[&held_camera=JSON]`).
pub async fn get_strips(
    State(state): State<Arc<AppState>>,
    Path(at): Path<(String, String)>,
    query: Result<Query<StripQuery>, QueryRejection>,
    headers: HeaderMap,
) -> Result<Response, AppError> {
    let Query(q) = query.map_err(|e| AppError::BadRequest(format!("query: {}", e.body_text())))?;
    strips(state, at, headers, q.ask()?).await
}

/// `POST /v1/scenes/{scene}/views/{view}/strips` with a [`StripRequest`] body.
pub async fn post_strips(
    State(state): State<Arc<AppState>>,
    Path(at): Path<(String, String)>,
    headers: HeaderMap,
    body: Result<Json<StripRequest>, JsonRejection>,
) -> Result<Response, AppError> {
    let Json(b) = body.map_err(json_rejection)?;
    let ask = StripAsk {
        lod: b.lod,
        camera: b.camera.as_ref().map(Camera::try_from).transpose()?,
        bits: b.bits,
        held: held(b.held)?,
        held_camera: b.held_camera.as_ref().map(Camera::try_from).transpose()?,
    };
    strips(state, at, headers, ask).await
}

/// `POST /v1/scenes/{scene}/render`: selected views, weights, strips and colour URLs.
pub async fn render(
    State(state): State<Arc<AppState>>,
    Path(scene): Path<String>,
    headers: HeaderMap,
    body: Result<Json<RenderRequest>, JsonRejection>,
) -> Result<Response, AppError> {
    let Json(request) = body.map_err(json_rejection)?;
    let fresh = render::render(&state, scene, request, wants_compact(&headers)).await?;
    let out = match &fresh.body {
        RenderBody::Compact(r) => encode_compact(r)?,
        RenderBody::Strips(r) => encode(&headers, r)?,
    };
    Ok(with_headers(out, &fresh))
}

/// The header that carries a live frame's age (see [`with_headers`]).
pub const FRAME_AGE: &str = "dmesh-frame-age";

/// An answer's headers:
/// - `ETag` when the body has one;
/// - `Server-Timing: extract;dur=MS, total;dur=MS`, which load generators
///   read without decoding the body;
/// - `Dmesh-Frame-Age: MS` on an answer drawn from live frames: how long
///   the youngest had been visible when it was read. A viewer that sees it
///   keeps asking, and so follows the live view.
fn with_headers<T>(mut out: Response, fresh: &Fresh<T>) -> Response {
    let headers = out.headers_mut();
    if let Some(v) = fresh.etag.as_deref().and_then(|t| t.parse().ok()) {
        headers.insert(header::ETAG, v);
    }
    let timing = format!("extract;dur={:.3}, total;dur={:.3}", fresh.extract_ms, fresh.total_ms);
    if let Ok(v) = timing.parse() {
        headers.insert("server-timing", v);
    }
    if let Some(v) = fresh.live_age_ms.and_then(|a| format!("{a:.1}").parse().ok()) {
        headers.insert(FRAME_AGE, v);
    }
    out
}
