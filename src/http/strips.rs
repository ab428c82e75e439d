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
use crate::wire::{strip_response, wire_lod, DepthCoding};

use super::error::AppError;
use super::negotiate::encode;
use super::state::{AppState, Loaded};
use super::views::{color_url, load};

/// Query of `GET .../strips`: `epsilon`, or `tau` with the requesting
/// `camera` (JSON), or a budget (`max_triangles` or `budget_ms`, optionally
/// with `camera`); optionally `bits`.
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

/// What a request asks for: one level of detail and a depth coding.
#[derive(Clone, Debug)]
struct Ask {
    tol: Tolerance,
    bits: Option<u8>,
}

#[derive(Clone, Debug)]
enum Tolerance {
    Epsilon(f64),
    Tau(f64, Camera),
    /// At most this many triangles, view-dependent with a camera.
    Triangles(u64, Option<Camera>),
    /// Aim at this many milliseconds of extraction.
    Millis(f64, Option<Camera>),
}

/// The level-of-detail fields of a strip or render request.
struct Fields {
    epsilon: Option<f64>,
    tau: Option<f64>,
    camera: Option<Camera>,
    max_triangles: Option<u32>,
    budget_ms: Option<f64>,
    bits: Option<u8>,
}

impl Ask {
    fn new(f: Fields) -> Result<Self, AppError> {
        if let Some(b) = f.bits.filter(|&b| b > dmesh_proto::residual::MAX_BITS) {
            return Err(AppError::BadRequest(format!("bits is {b}; it must be 0..=16")));
        }
        let exactly_one = || {
            AppError::BadRequest(
                "give exactly one of epsilon (metres), tau (pixels, with camera), max_triangles or budget_ms".into(),
            )
        };
        let given = [
            f.epsilon.is_some(),
            f.tau.is_some(),
            f.max_triangles.is_some(),
            f.budget_ms.is_some(),
        ];
        if given.iter().filter(|&&g| g).count() != 1 {
            return Err(exactly_one());
        }
        let tol = match f {
            Fields {
                epsilon: Some(_),
                camera: Some(_),
                ..
            } => {
                return Err(AppError::BadRequest(
                    "camera is not used with epsilon; give tau or a budget, or drop camera".into(),
                ))
            }
            Fields { epsilon: Some(e), .. } => Tolerance::Epsilon(e),
            Fields {
                tau: Some(t),
                camera: Some(c),
                ..
            } => Tolerance::Tau(t, c),
            Fields { tau: Some(_), .. } => {
                return Err(AppError::BadRequest("tau needs the requesting camera (camera)".into()))
            }
            Fields {
                max_triangles: Some(m),
                camera,
                ..
            } => Tolerance::Triangles(u64::from(m), camera),
            Fields {
                budget_ms: Some(ms),
                camera,
                ..
            } if ms.is_finite() && ms > 0.0 => Tolerance::Millis(ms, camera),
            Fields {
                budget_ms: Some(ms), ..
            } => {
                return Err(AppError::BadRequest(format!(
                    "budget_ms is {ms}; it must be a finite number of milliseconds > 0"
                )))
            }
            _ => return Err(exactly_one()),
        };
        Ok(Self { tol, bits: f.bits })
    }

    /// The same request with a share of a render request's budget.
    fn share(&self, fraction: f64) -> Self {
        let tol = match &self.tol {
            Tolerance::Triangles(m, c) => Tolerance::Triangles((*m as f64 * fraction).floor() as u64, *c),
            Tolerance::Millis(ms, c) => Tolerance::Millis(ms * fraction, *c),
            other => other.clone(),
        };
        Self { tol, bits: self.bits }
    }

    /// The ETag suffix of a cacheable (static) answer.
    fn cache_key(&self) -> Option<String> {
        let bits = self.bits.map_or(String::new(), |b| format!("-b{b}"));
        match &self.tol {
            Tolerance::Epsilon(e) => Some(format!("{:016x}{bits}", e.to_bits())),
            Tolerance::Triangles(m, None) => Some(format!("t{m}{bits}")),
            _ => None,
        }
    }
}

fn extract(
    state: &AppState,
    scene: &str,
    view: &str,
    loaded: &Loaded,
    ask: &Ask,
) -> Result<dmesh_proto::StripResponse, AppError> {
    fn budget<'a>(loaded: &'a Loaded, max: u64, camera: Option<&'a Camera>) -> Result<Lod<'a>, AppError> {
        let chosen = loaded.hierarchy.lod_for_triangles(max, camera)?;
        Ok(chosen.lod(camera.unwrap_or(&loaded.camera)))
    }
    let h = &loaded.hierarchy;
    let mut time_budget = None;
    let lod = match &ask.tol {
        Tolerance::Epsilon(e) => Lod::Epsilon(*e),
        Tolerance::Tau(t, c) => Lod::Tau { tau: *t, view: c },
        Tolerance::Triangles(m, c) => budget(loaded, *m, c.as_ref())?,
        Tolerance::Millis(ms, c) => {
            // The triangle bound is conservative; a time budget needs no
            // proof, so it allows as many more as meshes have recently
            // fallen short of their allowance, and never less than the
            // coarsest mesh.
            let target = ms / state.metrics.ms_per_triangle();
            let allowed = ((target / state.metrics.budget_fill()) as u64).max(h.coarsest_triangles());
            time_budget = Some(allowed);
            budget(loaded, allowed, c.as_ref())?
        }
    };
    let mesh = h.extract(lod)?;
    state.metrics.extraction(mesh.extract_ms, mesh.triangles.len());
    if let Some(allowed) = time_budget {
        state
            .metrics
            .budget_filled(mesh.triangles.len() as f64 / allowed as f64);
    }
    let coding = DepthCoding {
        bits: ask.bits,
        root_side: h.grid().side(),
        raw_grid: loaded.raw_grid,
    };
    strip_response(&mesh, scene, view, wire_lod(&lod), &loaded.camera, coding)
        .map_err(|e| AppError::BadRequest(e.to_string()))
}

async fn strips(
    state: Arc<AppState>,
    scene: String,
    view: String,
    headers: HeaderMap,
    ask: Ask,
) -> Result<Response, AppError> {
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
    let camera = q.camera.as_deref().map(camera_from_json).transpose()?;
    let ask = Ask::new(Fields {
        epsilon: q.epsilon,
        tau: q.tau,
        camera,
        max_triangles: q.max_triangles,
        budget_ms: q.budget_ms,
        bits: q.bits,
    })?;
    strips(state, scene, view, headers, ask).await
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
    let ask = Ask::new(Fields {
        epsilon: b.epsilon,
        tau: b.tau,
        camera,
        max_triangles: b.max_triangles,
        budget_ms: b.budget_ms,
        bits: b.bits,
    })?;
    strips(state, scene, view, headers, ask).await
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
    let ask = Ask::new(Fields {
        epsilon: req.epsilon,
        tau: req.tau,
        camera: req.epsilon.is_none().then_some(novel),
        max_triangles: req.max_triangles,
        budget_ms: req.budget_ms,
        bits: req.bits,
    })?;
    let rule = match req.selection {
        Selection::Dmesh => SelectionRule::Dmesh {
            max_angle_deg: req.max_angle_deg.unwrap_or(135.0),
        },
        Selection::Limited => SelectionRule::Limited,
    };
    let max_views = req.max_views.map_or(5, |m| m as usize);
    let st = state.clone();
    let response = tokio::task::spawn_blocking(move || -> Result<RenderResponse, AppError> {
        // Select from the cameras alone; only the selected views are loaded.
        let candidates = st.scene_cameras(&scene)?;
        let cameras: Vec<Camera> = candidates.iter().map(|l| l.camera).collect();
        let selected = select_views(&novel, &cameras, rule, max_views)?;
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
