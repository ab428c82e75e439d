//! Strips of one view (static or view-dependent) and multi-view render requests.

use std::sync::Arc;
use std::time::Instant;

use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use dmesh_proto::{
    Lod as WireLod, RenderRequest, RenderResponse, RenderedView, StripRequest, StripResponse, Timings, PROTOCOL_VERSION,
};
use serde::Deserialize;

use crate::camera::{camera_from_json, Camera};
use crate::render_plan::{self, Ask};
use crate::store::validate_id;

use super::negotiate::encode;
use super::views::{color_url, load};
use crate::service::AppError;
use crate::service::{AppState, Loaded};

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
}

impl StripQuery {
    /// The level of detail it names: exactly one of the four.
    fn lod(&self) -> Result<WireLod, AppError> {
        let given = [
            self.epsilon.map(WireLod::Epsilon),
            self.tau.map(WireLod::Tau),
            self.max_triangles.map(WireLod::MaxTriangles),
            self.budget_ms.map(WireLod::BudgetMs),
        ];
        match given.iter().flatten().collect::<Vec<_>>()[..] {
            [lod] => Ok(*lod),
            _ => Err(AppError::BadRequest(
                "give exactly one of epsilon (metres), tau (pixels, with camera), max_triangles or budget_ms".into(),
            )),
        }
    }
}

/// One view's strips for `ask`, with the server's measured extraction rate
/// turning a time budget into triangles (blocking).
fn extract(state: &AppState, scene: &str, view: &str, loaded: &Loaded, ask: &Ask) -> Result<StripResponse, AppError> {
    // A time budget allows as many more triangles as meshes have recently
    // fallen short of their allowance.
    let (rate, fill) = (state.metrics.ms_per_triangle(), state.metrics.budget_fill());
    let out = render_plan::extract(&loaded.hierarchy, loaded.raw_grid, scene, view, ask, |ms| {
        ms / rate / fill
    })?;
    let triangles = out.response.triangles as usize;
    state.metrics.extraction(out.response.extract_ms, triangles);
    if let Some(allowed) = out.allowed {
        state.metrics.budget_filled(triangles as f64 / allowed as f64);
    }
    Ok(out.response)
}

async fn strips(
    state: Arc<AppState>,
    scene: String,
    view: String,
    headers: HeaderMap,
    (lod, camera, bits): (WireLod, Option<Camera>, Option<u8>),
) -> Result<Response, AppError> {
    let ask = Ask::new(lod, camera, bits)?;
    let loaded = load(&state, &scene, &view).await?;
    // Static meshes are a function of the stored view and the request: cacheable.
    let etag = ask
        .cache_key()
        .map(|key| format!("{}-{key}\"", loaded.etag.trim_end_matches('"')));
    if let Some(tag) = &etag {
        let matches = headers
            .get(header::IF_NONE_MATCH)
            .and_then(|v| v.to_str().ok())
            .is_some_and(|v| v.split(',').any(|t| t.trim() == tag));
        if matches {
            return Ok((StatusCode::NOT_MODIFIED, [(header::ETAG, tag.clone())]).into_response());
        }
    }
    let st = state.clone();
    let response = tokio::task::spawn_blocking(move || extract(&st, &scene, &view, &loaded, &ask)).await??;
    let mut out = encode(&headers, &response)?;
    server_timing(&mut out, response.extract_ms, response.extract_ms);
    if let Some(tag) = etag {
        if let Ok(v) = tag.parse() {
            out.headers_mut().insert(header::ETAG, v);
        }
    }
    Ok(out)
}

/// `GET /v1/scenes/{scene}/views/{view}/strips?epsilon=E`, `?tau=T&camera=JSON`,
/// `?max_triangles=N[&camera=JSON]` or `?budget_ms=MS[&camera=JSON]`, each with optional `&bits=B`.
pub async fn get_strips(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
    query: Result<Query<StripQuery>, axum::extract::rejection::QueryRejection>,
    headers: HeaderMap,
) -> Result<Response, AppError> {
    let Query(q) = query.map_err(|e| AppError::BadRequest(format!("query: {}", e.body_text())))?;
    let lod = q.lod()?;
    let camera = q.camera.as_deref().map(camera_from_json).transpose()?;
    strips(state, scene, view, headers, (lod, camera, q.bits)).await
}

/// `POST /v1/scenes/{scene}/views/{view}/strips` with a [`StripRequest`] body.
pub async fn post_strips(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
    headers: HeaderMap,
    body: Result<Json<StripRequest>, axum::extract::rejection::JsonRejection>,
) -> Result<Response, AppError> {
    let Json(b) = body.map_err(json_rejection)?;
    let camera = b.camera.as_ref().map(Camera::try_from).transpose()?;
    strips(state, scene, view, headers, (b.lod, camera, b.bits)).await
}

pub(crate) fn json_rejection(e: axum::extract::rejection::JsonRejection) -> AppError {
    use axum::extract::rejection::JsonRejection;
    match e {
        JsonRejection::MissingJsonContentType(_) => AppError::UnsupportedMedia("body must be application/json".into()),
        other if other.status() == axum::http::StatusCode::PAYLOAD_TOO_LARGE => {
            AppError::TooLarge(format!("body: {}", other.body_text()))
        }
        other => AppError::BadRequest(format!("body: {}", other.body_text())),
    }
}

/// `POST /v1/scenes/{scene}/render`: selected views, weights, strips and colour URLs.
pub async fn render(
    State(state): State<Arc<AppState>>,
    Path(scene): Path<String>,
    headers: HeaderMap,
    body: Result<Json<RenderRequest>, axum::extract::rejection::JsonRejection>,
) -> Result<Response, AppError> {
    let start = Instant::now();
    let Json(req) = body.map_err(json_rejection)?;
    validate_id("scene", &scene)?;
    let novel = Camera::try_from(&req.camera)?;
    // The novel camera is the requesting one, except for a static tolerance.
    let requesting = (!matches!(req.lod, WireLod::Epsilon(_))).then_some(novel);
    let ask = Ask::new(req.lod, requesting, req.bits)?;
    let st = state.clone();
    let response = tokio::task::spawn_blocking(move || -> Result<RenderResponse, AppError> {
        // Select from the cameras alone; only the selected views are loaded.
        let candidates = st.scene_cameras(&scene)?;
        let cameras: Vec<Camera> = candidates.iter().map(|l| l.camera).collect();
        let selected = render_plan::select(&novel, &cameras, req.selection, req.max_views, req.max_angle_deg)?;
        let select_ms = start.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let views = selected
            .iter()
            .map(|w| {
                let listed = &candidates[w.index];
                let name = &listed.name;
                let loaded = st.load_listed(&scene, listed)?;
                Ok(RenderedView {
                    weight: w.weight,
                    strips: extract(&st, &scene, name, &loaded, &ask.share(w.weight))?,
                    color_url: color_url(&scene, name),
                })
            })
            .collect::<Result<Vec<_>, AppError>>()?;
        let extract_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok(RenderResponse {
            version: PROTOCOL_VERSION,
            views,
            timings: Timings {
                select_ms,
                extract_ms,
                total_ms: start.elapsed().as_secs_f64() * 1e3,
            },
        })
    })
    .await??;
    let mut out = encode(&headers, &response)?;
    server_timing(&mut out, response.timings.extract_ms, response.timings.total_ms);
    Ok(out)
}

/// `Server-Timing: extract;dur=MS, total;dur=MS`, which load generators read
/// without decoding the body.
fn server_timing(out: &mut Response, extract_ms: f64, total_ms: f64) {
    if let Ok(v) = format!("extract;dur={extract_ms:.3}, total;dur={total_ms:.3}").parse() {
        out.headers_mut().insert("server-timing", v);
    }
}
