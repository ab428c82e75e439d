//! Content negotiation: the compact stream (protocol 7) when the client's
//! `Accept` names `application/vnd.dmesh.mesh` (mesh routes only), bincode
//! when it names `application/x-bincode`, JSON otherwise.

use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use dmesh_proto::{BINCODE_MEDIA_TYPE, MESH_MEDIA_TYPE};
use serde::Serialize;

use crate::service::AppError;

/// True when the request asks for bincode.
pub fn wants_bincode(headers: &HeaderMap) -> bool {
    accepts(headers, BINCODE_MEDIA_TYPE)
}

/// True when the request asks for the compact mesh stream.
pub fn wants_compact(headers: &HeaderMap) -> bool {
    accepts(headers, MESH_MEDIA_TYPE)
}

/// Encodes a compact body (bincode framing, PROTOCOL.md "Protocol 7").
pub fn encode_compact<T: Serialize>(value: &T) -> Result<Response, AppError> {
    let body = dmesh_proto::to_bincode(value).map_err(|e| AppError::Internal(format!("compact stream: {e}")))?;
    Ok(([(header::CONTENT_TYPE, MESH_MEDIA_TYPE)], body).into_response())
}

fn accepts(headers: &HeaderMap, media: &str) -> bool {
    headers
        .get_all(header::ACCEPT)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .any(|t| {
            t.trim()
                .split(';')
                .next()
                .is_some_and(|m| m.trim().eq_ignore_ascii_case(media))
        })
}

/// Encodes `value` as the client asked.
pub fn encode<T: Serialize>(headers: &HeaderMap, value: &T) -> Result<Response, AppError> {
    if wants_bincode(headers) {
        let body = dmesh_proto::to_bincode(value).map_err(|e| AppError::Internal(format!("bincode: {e}")))?;
        Ok(([(header::CONTENT_TYPE, BINCODE_MEDIA_TYPE)], body).into_response())
    } else {
        let body = serde_json::to_vec(value).map_err(|e| AppError::Internal(format!("json: {e}")))?;
        Ok(([(header::CONTENT_TYPE, "application/json")], body).into_response())
    }
}
