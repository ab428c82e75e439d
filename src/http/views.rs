//! Views: upload, list, summary, colour, delete.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::{Multipart, Path, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use dmesh_proto::{SceneList, ViewList, PROTOCOL_VERSION};

use crate::store::validate_id;
use dmesh_engine::image::DepthOptions;
use dmesh_engine::mesh::SegmentationSpec;

use super::conditional::{none_match, not_modified};
use super::negotiate::encode;
use crate::service::ingest::{ingest, Upload};
use crate::service::views::{load, summary};
use crate::service::AppError;
use crate::service::AppState;

fn number(name: &str, text: &str) -> Result<f64, AppError> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| AppError::BadRequest(format!("field {name} is {text:?}; it must be a finite number")))
}

/// The multipart fields as they arrive.
#[derive(Default)]
struct Fields {
    camera: Option<String>,
    depth: Option<Bytes>,
    color: Option<Bytes>,
    mask: Option<Bytes>,
    options: DepthOptions,
    segmentation: SegmentationSpec,
}

async fn read_upload(mut multipart: Multipart) -> Result<Fields, AppError> {
    let mut u = Fields::default();
    while let Some(field) = multipart.next_field().await? {
        let name = field.name().unwrap_or_default().to_string();
        let data = field.bytes().await?;
        let text = || {
            String::from_utf8(data.to_vec())
                .map_err(|_| AppError::BadRequest(format!("field {name} is not UTF-8 text")))
        };
        match name.as_str() {
            "camera" => u.camera = Some(text()?),
            "depth" => u.depth = Some(data.clone()),
            "color" => u.color = Some(data.clone()),
            "mask" => u.mask = Some(data.clone()),
            "depth_kind" => u.options.kind = text()?.trim().parse()?,
            "scale" => u.options.scale = number(&name, &text()?)?,
            "offset" => u.options.offset = number(&name, &text()?)?,
            "focal_baseline" => u.options.focal_baseline = Some(number(&name, &text()?)?),
            "channel" => u.options.channel = Some(text()?),
            "segment" => {
                u.segmentation.method = text()?
                    .trim()
                    .parse()
                    .map_err(|e| AppError::BadRequest(format!("field segment: {e}")))?
            }
            "omega" => u.segmentation.omega = number(&name, &text()?)?,
            "sigma" => u.segmentation.sigma = number(&name, &text()?)?,
            "kappa" => u.segmentation.kappa = number(&name, &text()?)?,
            "lambda" => u.segmentation.lambda = number(&name, &text()?)?,
            other => {
                return Err(AppError::BadRequest(format!(
                    "unknown field {other:?}; accepted: camera, depth, color, mask, depth_kind, scale, offset, \
                     focal_baseline, channel, segment, omega, sigma, kappa, lambda"
                )))
            }
        }
    }
    Ok(u)
}

/// Query of `PUT .../views/{view}`: `live=true` for a frame of a live view
/// (visible at once, made durable within `--live-persist-secs`).
#[derive(Debug, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PutQuery {
    #[serde(default)]
    live: bool,
}

/// `PUT /v1/scenes/{scene}/views/{view}[?live=true]` (multipart).
pub async fn put_view(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
    query: Result<axum::extract::Query<PutQuery>, axum::extract::rejection::QueryRejection>,
    headers: HeaderMap,
    slot: Option<axum::Extension<super::BuildSlot>>,
    multipart: Result<Multipart, axum::extract::multipart::MultipartRejection>,
) -> Result<Response, AppError> {
    let axum::extract::Query(query) = query.map_err(|e| AppError::BadRequest(format!("query: {}", e.body_text())))?;
    validate_id("scene", &scene)?;
    validate_id("view", &view)?;
    let multipart =
        multipart.map_err(|e| AppError::UnsupportedMedia(format!("upload must be multipart/form-data: {e}")))?;
    let u = read_upload(multipart).await?;
    let upload = Upload {
        camera: u
            .camera
            .ok_or_else(|| AppError::BadRequest("field camera (JSON) is missing".into()))?,
        depth: u
            .depth
            .ok_or_else(|| AppError::BadRequest("field depth (EXR, PNG, PFM or PGM) is missing".into()))?,
        color: u
            .color
            .ok_or_else(|| AppError::BadRequest("field color (PNG or JPEG) is missing".into()))?,
        mask: u.mask,
        options: u.options,
        segmentation: u.segmentation,
    };
    let st = state.clone();
    let (sc, vw) = (scene.clone(), view.clone());
    let live = query.live;
    let _core = match &slot {
        Some(axum::Extension(slot)) => slot.acquire().await,
        None => None,
    };
    let loaded = tokio::task::spawn_blocking(move || ingest(&st, &sc, &vw, upload, live)).await??;
    let mut response = encode(&headers, &summary(&scene, &view, &loaded))?;
    *response.status_mut() = StatusCode::CREATED;
    Ok(response)
}

/// `GET /v1/scenes`.
pub async fn list_scenes(State(state): State<Arc<AppState>>, headers: HeaderMap) -> Result<Response, AppError> {
    let st = state.clone();
    let scenes = tokio::task::spawn_blocking(move || st.store.scenes()).await??;
    encode(
        &headers,
        &SceneList {
            version: PROTOCOL_VERSION,
            scenes,
        },
    )
}

/// `GET /v1/scenes/{scene}/views`.
pub async fn list_views(
    State(state): State<Arc<AppState>>,
    Path(scene): Path<String>,
    headers: HeaderMap,
) -> Result<Response, AppError> {
    validate_id("scene", &scene)?;
    let (st, sc) = (state.clone(), scene.clone());
    let views = tokio::task::spawn_blocking(move || st.store.views(&sc))
        .await??
        .ok_or_else(|| AppError::NotFound(format!("no scene {scene:?}")))?;
    encode(
        &headers,
        &ViewList {
            version: PROTOCOL_VERSION,
            scene,
            views,
        },
    )
}

/// `GET /v1/scenes/{scene}/views/{view}`.
pub async fn get_view(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
    headers: HeaderMap,
) -> Result<Response, AppError> {
    let loaded = load(&state, &scene, &view).await?;
    encode(&headers, &summary(&scene, &view, &loaded))
}

/// `GET /v1/scenes/{scene}/views/{view}/color`: the stored image, strong ETag.
pub async fn get_color(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
    headers: HeaderMap,
) -> Result<Response, AppError> {
    let loaded = load(&state, &scene, &view).await?;
    let etag = loaded.etag.clone();
    if none_match(&headers, &etag) {
        return Ok(not_modified(etag));
    }
    Ok((
        [
            (header::CONTENT_TYPE, loaded.color_type.to_string()),
            (header::ETAG, etag),
            (header::CACHE_CONTROL, "public, max-age=3600".to_string()),
        ],
        loaded.color.clone(),
    )
        .into_response())
}

/// `DELETE /v1/scenes/{scene}/views/{view}`.
pub async fn delete_view(
    State(state): State<Arc<AppState>>,
    Path((scene, view)): Path<(String, String)>,
) -> Result<StatusCode, AppError> {
    validate_id("scene", &scene)?;
    validate_id("view", &view)?;
    let (st, sc, vw) = (state.clone(), scene.clone(), view.clone());
    let existed = tokio::task::spawn_blocking(move || st.delete(&sc, Some(&vw))).await??;
    if existed {
        Ok(StatusCode::NO_CONTENT)
    } else {
        Err(AppError::NotFound(format!("scene {scene:?} has no view {view:?}")))
    }
}

/// `DELETE /v1/scenes/{scene}`.
pub async fn delete_scene(
    State(state): State<Arc<AppState>>,
    Path(scene): Path<String>,
) -> Result<StatusCode, AppError> {
    validate_id("scene", &scene)?;
    let (st, sc) = (state.clone(), scene.clone());
    let existed = tokio::task::spawn_blocking(move || st.delete(&sc, None)).await??;
    if existed {
        Ok(StatusCode::NO_CONTENT)
    } else {
        Err(AppError::NotFound(format!("no scene {scene:?}")))
    }
}
