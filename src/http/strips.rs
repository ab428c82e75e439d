//! Strips of one view (static or view-dependent) and multi-view render requests.

use std::sync::Arc;
use std::time::Instant;

use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use dmesh_proto::{RenderRequest, RenderResponse, RenderedView, Selection, StripRequest, Timings, PROTOCOL_VERSION};
use serde::Deserialize;

use crate::camera::{camera_from_json, Camera};
use crate::mesh::Lod;
use crate::scene::{select_views, SelectionRule};
use crate::store::validate_id;
use crate::wire::{strip_response, wire_lod};

use super::error::AppError;
use super::negotiate::encode;
use super::state::{AppState, Loaded};
use super::views::{color_url, load};

/// Query of `GET .../strips`: `epsilon`, or `tau` with the requesting `camera` (JSON).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StripQuery {
    epsilon: Option<f64>,
    tau: Option<f64>,
    camera: Option<String>,
}

enum Tolerance {
    Epsilon(f64),
    Tau(f64, Camera),
}

fn tolerance(epsilon: Option<f64>, tau: Option<f64>, camera: Option<Camera>) -> Result<Tolerance, AppError> {
    match (epsilon, tau, camera) {
        (Some(e), None, None) => Ok(Tolerance::Epsilon(e)),
        (None, Some(t), Some(c)) => Ok(Tolerance::Tau(t, c)),
        (None, Some(_), None) => Err(AppError::BadRequest("tau needs the requesting camera (camera)".into())),
        (Some(_), None, Some(_)) => Err(AppError::BadRequest(
            "camera is only used with tau; give tau or drop camera".into(),
        )),
        _ => Err(AppError::BadRequest(
            "give exactly one of epsilon (metres) or tau (pixels, with camera)".into(),
        )),
    }
}

fn extract(
    state: &AppState,
    scene: &str,
    view: &str,
    loaded: &Loaded,
    tol: &Tolerance,
) -> Result<dmesh_proto::StripResponse, AppError> {
    let lod = match tol {
        Tolerance::Epsilon(e) => Lod::Epsilon(*e),
        Tolerance::Tau(t, c) => Lod::Tau { tau: *t, view: c },
    };
    let mesh = loaded.hierarchy.extract(lod)?;
    state.metrics.extraction(mesh.extract_ms, mesh.triangles.len());
    Ok(strip_response(&mesh, scene, view, wire_lod(&lod), &loaded.camera))
}

async fn strips(
    state: Arc<AppState>,
    scene: String,
    view: String,
    headers: HeaderMap,
    tol: Tolerance,
) -> Result<Response, AppError> {
    let loaded = load(&state, &scene, &view).await?;
    // Static meshes are a function of the stored view and epsilon: cacheable.
    let etag = match &tol {
        Tolerance::Epsilon(e) => Some(format!("{}-{:016x}\"", loaded.etag.trim_end_matches('"'), e.to_bits())),
        Tolerance::Tau(..) => None,
    };
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
    let response = tokio::task::spawn_blocking(move || extract(&st, &scene, &view, &loaded, &tol)).await??;
    let mut out = encode(&headers, &response)?;
    if let Some(tag) = etag {
        if let Ok(v) = tag.parse() {
            out.headers_mut().insert(header::ETAG, v);
        }
    }
    Ok(out)
}

/// `GET /v1/scenes/{scene}/views/{view}/strips?epsilon=E` or `?tau=T&camera=JSON`.
pub async fn get_strips(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
    query: Result<Query<StripQuery>, axum::extract::rejection::QueryRejection>,
    headers: HeaderMap,
) -> Result<Response, AppError> {
    let Query(q) = query.map_err(|e| AppError::BadRequest(format!("query: {}", e.body_text())))?;
    let camera = q.camera.as_deref().map(camera_from_json).transpose()?;
    strips(state, scene, view, headers, tolerance(q.epsilon, q.tau, camera)?).await
}

/// `POST /v1/scenes/{scene}/views/{view}/strips` with `{"tau", "camera"}` or `{"epsilon"}`.
pub async fn post_strips(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
    headers: HeaderMap,
    body: Result<Json<StripRequest>, axum::extract::rejection::JsonRejection>,
) -> Result<Response, AppError> {
    let Json(b) = body.map_err(json_rejection)?;
    let camera = b.camera.as_ref().map(Camera::try_from).transpose()?;
    strips(state, scene, view, headers, tolerance(b.epsilon, b.tau, camera)?).await
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
    let tol = tolerance(req.epsilon, req.tau, req.tau.map(|_| novel))?;
    let rule = match req.selection {
        Selection::Dmesh => SelectionRule::Dmesh {
            max_angle_deg: req.max_angle_deg.unwrap_or(135.0),
        },
        Selection::Limited => SelectionRule::Limited,
    };
    let max_views = req.max_views.map_or(5, |m| m as usize);
    let st = state.clone();
    let response = tokio::task::spawn_blocking(move || -> Result<RenderResponse, AppError> {
        let names = st
            .store
            .views(&scene)?
            .ok_or_else(|| AppError::NotFound(format!("no scene {scene:?}")))?;
        let loaded: Vec<Arc<Loaded>> = names.iter().map(|v| st.load(&scene, v)).collect::<Result<_, _>>()?;
        let cameras: Vec<Camera> = loaded.iter().map(|l| l.camera).collect();
        let selected = select_views(&novel, &cameras, rule, max_views)?;
        let select_ms = start.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let views = selected
            .iter()
            .map(|w| {
                let name = &names[w.index];
                Ok(RenderedView {
                    weight: w.weight,
                    strips: extract(&st, &scene, name, &loaded[w.index], &tol)?,
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
    encode(&headers, &response)
}
