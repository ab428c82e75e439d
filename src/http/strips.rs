//! Strips of one view (static or view-dependent) and multi-view render requests.

use std::sync::Arc;
use std::time::Instant;

use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use dmesh_engine::mesh::Mesh;
use dmesh_engine::wire::{strip_response, DepthCoding};
use dmesh_engine::wire_compact;
use dmesh_proto::compact::{CompactView, MeshBody, PlaneUpdate, RenderStream};
use dmesh_proto::{
    Lod as WireLod, RenderRequest, RenderResponse, RenderedView, StripRequest, StripResponse, Timings, PROTOCOL_VERSION,
};
use serde::Deserialize;

use crate::store::validate_id;
use dmesh_engine::camera::{camera_from_json, Camera};
use dmesh_engine::render_plan::{self, Ask};

use super::negotiate::{encode, encode_compact, wants_compact};
use super::views::{color_url, load};
use crate::service::stream_tag::StreamTag;
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
    held: Option<String>,
    held_camera: Option<String>,
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

/// The triangles a time budget of `ms` allows: the server's measured
/// extraction rate, and as many more as meshes have recently fallen short
/// of their allowance.
fn triangles_for_ms(state: &AppState, ms: f64) -> f64 {
    ms / state.metrics.ms_per_triangle() / state.metrics.budget_fill()
}

/// One view's mesh for `ask`, with the server's measured extraction rate
/// turning a time budget into triangles (blocking).
fn extract_mesh(state: &AppState, loaded: &Loaded, ask: &Ask) -> Result<Mesh, AppError> {
    // A time budget allows as many more triangles as meshes have recently
    // fallen short of their allowance.
    let (mesh, allowed) = render_plan::extract_mesh(&loaded.hierarchy, ask, |ms| triangles_for_ms(state, ms))?;
    let triangles = mesh.triangles.len();
    state.metrics.extraction(mesh.extract_ms, triangles);
    if let Some(allowed) = allowed {
        state.metrics.budget_filled(triangles as f64 / allowed as f64);
    }
    Ok(mesh)
}

/// One view's strips for `ask` (protocol 5).
fn extract(state: &AppState, scene: &str, view: &str, loaded: &Loaded, ask: &Ask) -> Result<StripResponse, AppError> {
    let mesh = extract_mesh(state, loaded, ask)?;
    let coding = DepthCoding {
        bits: ask.bits,
        root_side: loaded.hierarchy.grid().side(),
        raw_grid: loaded.raw_grid,
    };
    strip_response(&mesh, scene, view, loaded.hierarchy.camera(), coding)
        .map_err(|e| AppError::Internal(format!("encoding the mesh: {e}")))
}

/// What a compact request says the client holds of the view.
enum Held {
    /// The same mesh with the planes its tag names.
    Planes(StreamTag),
    /// Another mesh of the same view version, made by this request.
    Mesh(Ask),
}

impl Held {
    /// What the ETag `held` names, for a request answered as `tag` from the
    /// view stored as `view_etag`; `None` when it names nothing the server
    /// can derive again (then the whole mesh is sent).
    fn of(held: Option<&str>, camera: Option<Camera>, tag: Option<&StreamTag>, view_etag: &str) -> Option<Self> {
        let (held, tag) = (StreamTag::parse(held?)?, tag?);
        if tag.same_mesh(&held) && held.planes != tag.planes {
            return Some(Self::Planes(held));
        }
        tag.same_view(&held)
            .then(|| held.ask(view_etag, camera))
            .flatten()
            .map(Self::Mesh)
    }
}

/// One view's mesh for `ask` in the compact stream (protocol 6), named by
/// `tag`: the whole mesh with the planes asked for; when the client holds
/// the same mesh with fewer planes, only the planes it lacks; when it holds
/// another mesh of the view, the change from it. With the answer's ETag
/// (empty for a time budget).
fn extract_compact(
    state: &AppState,
    (scene, view): (&str, &str),
    loaded: &Loaded,
    ask: &Ask,
    tag: Option<&StreamTag>,
    held: Option<Held>,
) -> Result<(MeshBody, String), AppError> {
    let mesh = extract_mesh(state, loaded, ask)?;
    let etag = tag.map(StreamTag::etag).unwrap_or_default();
    let h = &loaded.hierarchy;
    let encoding = |e: dmesh_proto::compact::CompactError| AppError::Internal(format!("encoding the mesh: {e}"));
    if let Some(Held::Mesh(held)) = &held {
        // The held mesh as the client decoded it, derived again.
        let (before, _) = render_plan::extract_mesh(h, held, |_| 0.0)?;
        let decoded = wire_compact::held(&before, loaded.raw_grid, held.bits);
        let change = wire_compact::mesh_change(
            &mesh,
            h.grid(),
            scene,
            view,
            h.camera(),
            loaded.raw_grid,
            ask.bits,
            etag.clone(),
            &decoded,
        )
        .map_err(encoding)?;
        return Ok((MeshBody::Change(Box::new(change)), etag));
    }
    // The planes asked for (all without `bits`), their error stated.
    let mut stream = wire_compact::mesh_stream(
        &mesh,
        h.grid(),
        scene,
        view,
        h.camera(),
        loaded.raw_grid,
        ask.bits,
        etag,
    )
    .map_err(encoding)?;
    let wanted = stream.planes.len();
    let first = match &held {
        Some(Held::Planes(h)) => h.planes.map(usize::from),
        _ => None,
    };
    if let Some(first) = first.filter(|&f| f < wanted) {
        return Ok((
            MeshBody::Planes(PlaneUpdate {
                version: dmesh_proto::COMPACT_VERSION,
                first: first as u8,
                planes: stream.planes.drain(first..wanted).collect(),
                max_error: stream.max_error,
            }),
            stream.etag,
        ));
    }
    let etag = stream.etag.clone();
    Ok((MeshBody::Mesh(Box::new(stream)), etag))
}

/// True when `If-None-Match` names `tag`.
fn none_match(headers: &HeaderMap, tag: &str) -> bool {
    headers
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.split(',').any(|t| t.trim() == tag))
}

fn not_modified(tag: String) -> Response {
    (StatusCode::NOT_MODIFIED, [(header::ETAG, tag)]).into_response()
}

/// A strip request as the handlers read it: level of detail, camera, bits,
/// held ETag and the held mesh's camera.
type StripAsk = (WireLod, Option<Camera>, Option<u8>, Option<String>, Option<Camera>);

async fn strips(
    state: Arc<AppState>,
    scene: String,
    view: String,
    headers: HeaderMap,
    (lod, camera, bits, held, held_camera): StripAsk,
) -> Result<Response, AppError> {
    let ask = Ask::new(lod, camera, bits)?;
    let loaded = load(&state, &scene, &view).await?;
    let live_age = loaded.live_age_ms();
    if wants_compact(&headers) {
        // Every compact mesh but a time budget's is a function of the stored
        // view and the request, named by its tag.
        let tag = StreamTag::new(&loaded.etag, &ask);
        if let Some(t) = tag.as_ref().map(StreamTag::etag).filter(|t| none_match(&headers, t)) {
            return Ok(not_modified(t));
        }
        let held = Held::of(held.as_deref(), held_camera, tag.as_ref(), &loaded.etag);
        let st = state.clone();
        let start = Instant::now();
        let (body, etag) = tokio::task::spawn_blocking(move || {
            extract_compact(&st, (&scene, &view), &loaded, &ask, tag.as_ref(), held)
        })
        .await??;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let mut out = encode_compact(&body)?;
        server_timing(&mut out, ms, ms);
        live_frame_age(&mut out, live_age);
        if let (false, Ok(v)) = (etag.is_empty(), etag.parse()) {
            out.headers_mut().insert(header::ETAG, v);
        }
        return Ok(out);
    }
    // Static meshes are a function of the stored view and the request: cacheable.
    let etag = ask
        .cache_key()
        .map(|key| format!("{}-{key}\"", loaded.etag.trim_end_matches('"')));
    if let Some(tag) = etag.as_ref().filter(|t| none_match(&headers, t)) {
        return Ok(not_modified(tag.clone()));
    }
    let st = state.clone();
    let response = tokio::task::spawn_blocking(move || extract(&st, &scene, &view, &loaded, &ask)).await??;
    let mut out = encode(&headers, &response)?;
    server_timing(&mut out, response.extract_ms, response.extract_ms);
    live_frame_age(&mut out, live_age);
    if let Some(tag) = etag {
        if let Ok(v) = tag.parse() {
            out.headers_mut().insert(header::ETAG, v);
        }
    }
    Ok(out)
}

/// `GET /v1/scenes/{scene}/views/{view}/strips?epsilon=E`, `?tau=T&camera=JSON`,
/// `?max_triangles=N[&camera=JSON]` or `?budget_ms=MS[&camera=JSON]`, each with optional `&bits=B`
/// (and, for the compact stream, `&held=ETAG[&held_camera=JSON]`).
pub async fn get_strips(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
    query: Result<Query<StripQuery>, axum::extract::rejection::QueryRejection>,
    headers: HeaderMap,
) -> Result<Response, AppError> {
    let Query(q) = query.map_err(|e| AppError::BadRequest(format!("query: {}", e.body_text())))?;
    let lod = q.lod()?;
    let camera = q.camera.as_deref().map(camera_from_json).transpose()?;
    let held_camera = q.held_camera.as_deref().map(camera_from_json).transpose()?;
    strips(state, scene, view, headers, (lod, camera, q.bits, q.held, held_camera)).await
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
    let held_camera = b.held_camera.as_ref().map(Camera::try_from).transpose()?;
    strips(
        state,
        scene,
        view,
        headers,
        (b.lod, camera, b.bits, b.held, held_camera),
    )
    .await
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
    let compact = wants_compact(&headers);
    let st = state.clone();
    let (response, live_age) = tokio::task::spawn_blocking(move || -> Result<(Rendered, Option<f64>), AppError> {
        // Select from the cameras alone; only the selected views are loaded.
        let candidates = st.scene_cameras(&scene)?;
        let cameras: Vec<Camera> = candidates.iter().map(|l| l.camera).collect();
        let selected = render_plan::select(&novel, &cameras, req.selection, req.max_views, req.max_angle_deg)?;
        let select_ms = start.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let loaded = selected
            .iter()
            .map(|w| {
                let listed = &candidates[w.index];
                Ok((w.weight, &listed.name, st.load_listed(&scene, listed)?))
            })
            .collect::<Result<Vec<_>, AppError>>()?;
        // A budget leaves out the views whose share no mesh of theirs fits.
        let budget = match req.lod {
            WireLod::MaxTriangles(m) => Some(f64::from(m)),
            WireLod::BudgetMs(ms) => Some(triangles_for_ms(&st, ms)),
            _ => None,
        };
        let loaded = match budget {
            Some(budget) => {
                let weights: Vec<f64> = loaded.iter().map(|l| l.0).collect();
                let coarsest: Vec<u64> = loaded.iter().map(|l| l.2.hierarchy.coarsest_triangles()).collect();
                render_plan::afford(&weights, &coarsest, budget)
                    .into_iter()
                    .zip(loaded)
                    .filter(|(w, _)| *w > 0.0)
                    .map(|(w, (_, name, l))| (w, name, l))
                    .collect()
            }
            None => loaded,
        };
        // The youngest live frame among them, read before extracting.
        let live_age = loaded
            .iter()
            .filter_map(|(_, _, l)| l.live_age_ms())
            .min_by(f64::total_cmp);
        let timings = |t: Instant| Timings {
            select_ms,
            extract_ms: t.elapsed().as_secs_f64() * 1e3,
            total_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        if compact {
            let views = loaded
                .iter()
                .map(|(weight, name, loaded)| {
                    let ask = ask.share(*weight);
                    let tag = StreamTag::new(&loaded.etag, &ask);
                    let (MeshBody::Mesh(mesh), _) =
                        extract_compact(&st, (&scene, name), loaded, &ask, tag.as_ref(), None)?
                    else {
                        return Err(AppError::Internal("a render answered with planes".into()));
                    };
                    Ok(CompactView {
                        weight: *weight,
                        mesh: *mesh,
                        color_url: color_url(&scene, name),
                    })
                })
                .collect::<Result<Vec<_>, AppError>>()?;
            return Ok((
                Rendered::Compact(RenderStream {
                    version: dmesh_proto::COMPACT_VERSION,
                    views,
                    timings: timings(t),
                }),
                live_age,
            ));
        }
        let views = loaded
            .iter()
            .map(|(weight, name, loaded)| {
                Ok(RenderedView {
                    weight: *weight,
                    strips: extract(&st, &scene, name, loaded, &ask.share(*weight))?,
                    color_url: color_url(&scene, name),
                })
            })
            .collect::<Result<Vec<_>, AppError>>()?;
        Ok((
            Rendered::Strips(RenderResponse {
                version: PROTOCOL_VERSION,
                views,
                timings: timings(t),
            }),
            live_age,
        ))
    })
    .await??;
    let (mut out, timings) = match &response {
        Rendered::Compact(r) => (encode_compact(r)?, r.timings),
        Rendered::Strips(r) => (encode(&headers, r)?, r.timings),
    };
    server_timing(&mut out, timings.extract_ms, timings.total_ms);
    live_frame_age(&mut out, live_age);
    Ok(out)
}

/// `Dmesh-Frame-Age: MS` on an answer drawn from live frames: how long
/// the youngest had been visible when it was read. A viewer that sees it
/// keeps asking, and so follows the live view.
fn live_frame_age(out: &mut Response, age_ms: Option<f64>) {
    if let Some(v) = age_ms.and_then(|a| format!("{a:.1}").parse().ok()) {
        out.headers_mut().insert(FRAME_AGE, v);
    }
}

/// The header [`live_frame_age`] sets.
pub const FRAME_AGE: &str = "dmesh-frame-age";

/// A render answer in the encoding the client asked for.
enum Rendered {
    Strips(RenderResponse),
    Compact(RenderStream),
}

/// `Server-Timing: extract;dur=MS, total;dur=MS`, which load generators read
/// without decoding the body.
fn server_timing(out: &mut Response, extract_ms: f64, total_ms: f64) {
    if let Ok(v) = format!("extract;dur={extract_ms:.3}, total;dur={total_ms:.3}").parse() {
        out.headers_mut().insert("server-timing", v);
    }
}
