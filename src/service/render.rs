//! Strip and render requests answered (DMesh Sec. 6.1-6.2 through the
//! engine's render plan, `dmesh_engine::render_plan`): the views selected
//! and loaded, a budget shared by weight, each mesh extracted and encoded
//! as protocol 5 strips (outlines refined) or the compact stream (protocol
//! 7, outlines cut), with the ETag
//! that names it and the timings. A time budget becomes triangles through
//! the server's measured extraction rate and how far recent meshes fell
//! short of their allowance. The HTTP layer only reads the request and
//! writes the answer.

use std::sync::Arc;
use std::time::Instant;

use dmesh_engine::camera::Camera;
use dmesh_engine::mesh::{Mesh, Outlines};
use dmesh_engine::render_plan::{self, Ask};
use dmesh_engine::wire::{strip_response, DepthCoding};
use dmesh_engine::wire_compact;
use dmesh_proto::compact::{CompactView, MeshBody, PlaneUpdate, RenderStream};
use dmesh_proto::{Lod, RenderRequest, RenderResponse, RenderedView, StripResponse, Timings, PROTOCOL_VERSION};

use super::error::AppError;
use super::state::{AppState, Loaded};
use super::stream_tag::StreamTag;
use super::views::{color_url, load};
use crate::store::validate_id;

/// A strip request as the handlers read it, from the query or the body.
#[derive(Debug)]
pub struct StripAsk {
    /// The level of detail.
    pub lod: Lod,
    /// The requesting camera (for `tau`, and optionally for a budget).
    pub camera: Option<Camera>,
    /// Residual bit-depth of the depths.
    pub bits: Option<u8>,
    /// The ETag of the compact mesh the client holds.
    pub held: Option<String>,
    /// The camera the held mesh was asked for.
    pub held_camera: Option<Camera>,
}

/// An answer, or that the client already holds it.
#[derive(Debug)]
pub enum Answer<T> {
    /// The client's `If-None-Match` names this ETag: 304.
    NotModified(String),
    /// A new body.
    Fresh(Fresh<T>),
}

/// A body with what the response states beside it.
#[derive(Debug)]
pub struct Fresh<T> {
    /// The body.
    pub body: T,
    /// Its strong ETag, when the body is a function of the stored views and
    /// the request (not for a time budget).
    pub etag: Option<String>,
    /// Milliseconds spent extracting.
    pub extract_ms: f64,
    /// Milliseconds from the request to the answer.
    pub total_ms: f64,
    /// How long the youngest live frame used had been visible.
    pub live_age_ms: Option<f64>,
}

/// One view's strips in the encoding asked for.
#[derive(Debug)]
pub enum StripBody {
    /// Protocol 5 (boxed: the largest variant by far).
    Strips(Box<StripResponse>),
    /// Protocol 7: a whole mesh, planes or a change.
    Compact(MeshBody),
}

/// A render answer in the encoding asked for.
#[derive(Debug)]
pub enum RenderBody {
    /// Protocol 5.
    Strips(RenderResponse),
    /// Protocol 7.
    Compact(RenderStream),
}

/// The triangles a time budget of `ms` allows: the server's measured
/// extraction rate, and as many more as meshes have recently fallen short
/// of their allowance.
fn triangles_for_ms(state: &AppState, ms: f64) -> f64 {
    ms / state.metrics.ms_per_triangle() / state.metrics.budget_fill()
}

/// One view's mesh for `ask`, its outlines as the answer's wire carries
/// them, with the server's measured extraction rate turning a time budget
/// into triangles (blocking).
fn extract_mesh(state: &AppState, loaded: &Loaded, ask: &Ask, outlines: Outlines) -> Result<Mesh, AppError> {
    let (mesh, allowed) =
        render_plan::extract_mesh(&loaded.hierarchy, ask, outlines, |ms| triangles_for_ms(state, ms))?;
    let triangles = mesh.drawn_triangles();
    state.metrics.extraction(mesh.extract_ms, triangles);
    if let Some(allowed) = allowed {
        state.metrics.budget_filled(triangles as f64 / allowed as f64);
    }
    Ok(mesh)
}

/// One view's strips for `ask` (protocol 5).
fn extract(state: &AppState, scene: &str, view: &str, loaded: &Loaded, ask: &Ask) -> Result<StripResponse, AppError> {
    let mesh = extract_mesh(state, loaded, ask, Outlines::Kept)?;
    let coding = DepthCoding {
        bits: ask.bits(),
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

/// One view's mesh for `ask` in the compact stream (protocol 7), named by
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
    let mesh = extract_mesh(state, loaded, ask, Outlines::Cut)?;
    let etag = tag.map(StreamTag::etag).unwrap_or_default();
    let h = &loaded.hierarchy;
    let encoding = |e: dmesh_proto::compact::CompactError| AppError::Internal(format!("encoding the mesh: {e}"));
    if let Some(Held::Mesh(held)) = &held {
        // The held mesh as the client decoded it, derived again.
        let (before, _) = render_plan::extract_mesh(h, held, Outlines::Cut, |_| 0.0)?;
        let decoded = wire_compact::held(&before, loaded.raw_grid, held.bits());
        let change = wire_compact::mesh_change(
            &mesh,
            h.grid(),
            scene,
            view,
            h.camera(),
            loaded.raw_grid,
            ask.bits(),
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
        ask.bits(),
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

/// One view's strips for `request`, compact or not; `holds` says whether
/// the client's `If-None-Match` names an ETag (then nothing is extracted).
pub async fn strips(
    state: &Arc<AppState>,
    (scene, view): (String, String),
    request: StripAsk,
    compact: bool,
    holds: impl Fn(&str) -> bool,
) -> Result<Answer<StripBody>, AppError> {
    let StripAsk {
        lod,
        camera,
        bits,
        held,
        held_camera,
    } = request;
    let ask = Ask::new(lod, camera, bits)?;
    let loaded = load(state, &scene, &view).await?;
    let live_age_ms = loaded.live_age_ms();
    let st = state.clone();
    let start = Instant::now();
    if compact {
        // Every compact mesh but a time budget's is a function of the stored
        // view and the request, named by its tag.
        let tag = StreamTag::new(&loaded.etag, &ask);
        if let Some(t) = tag.as_ref().map(StreamTag::etag).filter(|t| holds(t)) {
            return Ok(Answer::NotModified(t));
        }
        let held = Held::of(held.as_deref(), held_camera, tag.as_ref(), &loaded.etag);
        let (body, etag) = tokio::task::spawn_blocking(move || {
            extract_compact(&st, (&scene, &view), &loaded, &ask, tag.as_ref(), held)
        })
        .await??;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        return Ok(Answer::Fresh(Fresh {
            body: StripBody::Compact(body),
            etag: (!etag.is_empty()).then_some(etag),
            extract_ms: ms,
            total_ms: ms,
            live_age_ms,
        }));
    }
    // Static meshes are a function of the stored view and the request: cacheable.
    let etag = ask
        .cache_key()
        .map(|key| format!("{}-{key}\"", loaded.etag.trim_end_matches('"')));
    if let Some(tag) = etag.as_ref().filter(|t| holds(t)) {
        return Ok(Answer::NotModified(tag.clone()));
    }
    let response = tokio::task::spawn_blocking(move || extract(&st, &scene, &view, &loaded, &ask)).await??;
    Ok(Answer::Fresh(Fresh {
        extract_ms: response.extract_ms,
        total_ms: response.extract_ms,
        body: StripBody::Strips(Box::new(response)),
        etag,
        live_age_ms,
    }))
}

/// A novel view: the views selected for `request`'s camera (only they are
/// loaded), a budget shared by weight (views whose share fits no mesh of
/// theirs left out), each view's mesh, its weight and colour URL.
pub async fn render(
    state: &Arc<AppState>,
    scene: String,
    request: RenderRequest,
    compact: bool,
) -> Result<Fresh<RenderBody>, AppError> {
    let start = Instant::now();
    validate_id("scene", &scene)?;
    let novel = Camera::try_from(&request.camera)?;
    // The novel camera is the requesting one, except for a static tolerance.
    let requesting = (!matches!(request.lod, Lod::Epsilon(_))).then_some(novel);
    let ask = Ask::new(request.lod, requesting, request.bits)?;
    let st = state.clone();
    tokio::task::spawn_blocking(move || render_blocking(&st, &scene, &request, &novel, &ask, compact, start)).await?
}

/// [`render`]'s work, off the async workers.
fn render_blocking(
    st: &AppState,
    scene: &str,
    req: &RenderRequest,
    novel: &Camera,
    ask: &Ask,
    compact: bool,
    start: Instant,
) -> Result<Fresh<RenderBody>, AppError> {
    // Select from the cameras alone; only the selected views are loaded.
    let candidates = st.scene_cameras(scene)?;
    let cameras: Vec<Camera> = candidates.iter().map(|l| l.camera).collect();
    let selected = render_plan::select(novel, &cameras, req.selection, req.max_views, req.max_angle_deg)?;
    let select_ms = start.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let loaded = selected
        .iter()
        .map(|w| {
            let listed = &candidates[w.index];
            Ok((w.weight, &listed.name, st.load_listed(scene, listed)?))
        })
        .collect::<Result<Vec<_>, AppError>>()?;
    // A budget leaves out the views whose share no mesh of theirs fits.
    let budget = match req.lod {
        Lod::MaxTriangles(m) => Some(f64::from(m)),
        Lod::BudgetMs(ms) => Some(triangles_for_ms(st, ms)),
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
    let live_age_ms = loaded
        .iter()
        .filter_map(|(_, _, l)| l.live_age_ms())
        .min_by(f64::total_cmp);
    let timings = |t: Instant| Timings {
        select_ms,
        extract_ms: t.elapsed().as_secs_f64() * 1e3,
        total_ms: start.elapsed().as_secs_f64() * 1e3,
    };
    let (body, timings) = if compact {
        let views = loaded
            .iter()
            .map(|(weight, name, loaded)| {
                let ask = ask.share(*weight);
                let tag = StreamTag::new(&loaded.etag, &ask);
                let (MeshBody::Mesh(mesh), _) = extract_compact(st, (scene, name), loaded, &ask, tag.as_ref(), None)?
                else {
                    return Err(AppError::Internal("a render answered with planes".into()));
                };
                Ok(CompactView {
                    weight: *weight,
                    mesh: *mesh,
                    color_url: color_url(scene, name),
                })
            })
            .collect::<Result<Vec<_>, AppError>>()?;
        let timings = timings(t);
        let body = RenderStream {
            version: dmesh_proto::COMPACT_VERSION,
            views,
            timings,
        };
        (RenderBody::Compact(body), timings)
    } else {
        let views = loaded
            .iter()
            .map(|(weight, name, loaded)| {
                Ok(RenderedView {
                    weight: *weight,
                    strips: extract(st, scene, name, loaded, &ask.share(*weight))?,
                    color_url: color_url(scene, name),
                })
            })
            .collect::<Result<Vec<_>, AppError>>()?;
        let timings = timings(t);
        let body = RenderResponse {
            version: PROTOCOL_VERSION,
            views,
            timings,
        };
        (RenderBody::Strips(body), timings)
    };
    Ok(Fresh {
        body,
        etag: None,
        extract_ms: timings.extract_ms,
        total_ms: timings.total_ms,
        live_age_ms,
    })
}
