//! Conditional GETs: `If-None-Match` against a strong ETag, and the 304
//! that answers a match. The one place the header is read.

use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};

/// True when `If-None-Match` names `tag` (one of a comma-separated list).
pub fn none_match(headers: &HeaderMap, tag: &str) -> bool {
    headers
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.split(',').any(|t| t.trim() == tag))
}

/// 304 Not Modified with the ETag it matched.
pub fn not_modified(tag: String) -> Response {
    (StatusCode::NOT_MODIFIED, [(header::ETAG, tag)]).into_response()
}
