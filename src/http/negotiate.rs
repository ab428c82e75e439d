//! Content negotiation: bincode when the client's `Accept` names
//! `application/x-bincode`, JSON otherwise.

use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use dmesh_proto::BINCODE_MEDIA_TYPE;
use serde::Serialize;

use crate::service::AppError;

/// True when the request asks for bincode.
pub fn wants_bincode(headers: &HeaderMap) -> bool {
    headers
        .get_all(header::ACCEPT)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .any(|t| {
            t.trim()
                .split(';')
                .next()
                .is_some_and(|m| m.trim().eq_ignore_ascii_case(BINCODE_MEDIA_TYPE))
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
