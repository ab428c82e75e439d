//! How the service's one error type answers over HTTP: every failure,
//! extractor rejections included, answers `{"error": {"code", "message"}}`
//! with the right status.

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use dmesh_proto::ErrorBody;

pub use crate::service::AppError;

impl AppError {
    fn parts(&self) -> (StatusCode, &'static str, String) {
        match self {
            Self::BadRequest(m) => (StatusCode::BAD_REQUEST, "bad_request", m.clone()),
            Self::NotFound(m) => (StatusCode::NOT_FOUND, "not_found", m.clone()),
            Self::TooLarge(m) => (StatusCode::PAYLOAD_TOO_LARGE, "too_large", m.clone()),
            Self::UnsupportedMedia(m) => (StatusCode::UNSUPPORTED_MEDIA_TYPE, "unsupported_media_type", m.clone()),
            Self::Undecodable(m) => (StatusCode::UNPROCESSABLE_ENTITY, "undecodable_image", m.clone()),
            Self::Conflict(m) => (StatusCode::CONFLICT, "unattainable", m.clone()),
            Self::MethodNotAllowed => (
                StatusCode::METHOD_NOT_ALLOWED,
                "method_not_allowed",
                "this endpoint does not take that method; see proto/openapi.yaml".into(),
            ),
            Self::Timeout => (
                StatusCode::REQUEST_TIMEOUT,
                "timeout",
                "the request took longer than the server's timeout".into(),
            ),
            Self::Overloaded(_) => (
                StatusCode::SERVICE_UNAVAILABLE,
                "overloaded",
                "the server is at capacity; retry shortly".into(),
            ),
            Self::Unavailable(m, _) => (
                StatusCode::SERVICE_UNAVAILABLE,
                "store_unavailable",
                format!("the view store did not answer; retry shortly ({m})"),
            ),
            Self::Internal(_) => (StatusCode::INTERNAL_SERVER_ERROR, "internal", "internal error".into()),
        }
    }
}

impl IntoResponse for AppError {
    fn into_response(self) -> Response {
        match &self {
            Self::Internal(detail) => tracing::error!("internal error: {detail}"),
            Self::Unavailable(detail, _) => tracing::warn!("store unavailable: {detail}"),
            _ => {}
        }
        let (status, code, message) = self.parts();
        let body = serde_json::to_vec(&ErrorBody::new(code, message)).unwrap_or_default();
        let mut response = (status, [(header::CONTENT_TYPE, "application/json")], body).into_response();
        if let Self::Overloaded(secs) | Self::Unavailable(_, secs) = self {
            if let Ok(v) = HeaderValue::from_str(&secs.to_string()) {
                response.headers_mut().insert(header::RETRY_AFTER, v);
            }
        }
        response
    }
}

impl From<axum::extract::multipart::MultipartError> for AppError {
    fn from(e: axum::extract::multipart::MultipartError) -> Self {
        if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
            Self::TooLarge(format!("upload: {}", e.body_text()))
        } else {
            Self::BadRequest(format!("upload: {}", e.body_text()))
        }
    }
}

/// A JSON body the extractor refused: 415 without the JSON content type,
/// 413 past the body limit, 400 otherwise, each with the extractor's reason.
pub fn json_rejection(e: axum::extract::rejection::JsonRejection) -> AppError {
    use axum::extract::rejection::JsonRejection;
    match e {
        JsonRejection::MissingJsonContentType(_) => AppError::UnsupportedMedia("body must be application/json".into()),
        other if other.status() == StatusCode::PAYLOAD_TOO_LARGE => {
            AppError::TooLarge(format!("body: {}", other.body_text()))
        }
        other => AppError::BadRequest(format!("body: {}", other.body_text())),
    }
}
