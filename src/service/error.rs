//! The service's one error type, which the HTTP layer turns into a status
//! and a JSON body (`http/error.rs`).

use crate::store::StoreError;

/// A failed request.
#[derive(Debug)]
pub enum AppError {
    /// 400: a bad field; the message names it and what is accepted.
    BadRequest(String),
    /// 404: no such scene or view.
    NotFound(String),
    /// 413: body or image over a limit.
    TooLarge(String),
    /// 415: a body or part of a type the endpoint does not take.
    UnsupportedMedia(String),
    /// 422: image bytes that do not decode.
    Undecodable(String),
    /// 409: a valid request the stored data cannot satisfy.
    Conflict(String),
    /// 405: the endpoint exists but not with this method.
    MethodNotAllowed,
    /// 408: the request took longer than the configured timeout.
    Timeout,
    /// 503: shed under overload; retry after the given seconds.
    Overloaded(u64),
    /// 503: a store the server depends on is down; retry after the given
    /// seconds.
    Unavailable(String, u64),
    /// 500: logged in full, reported briefly.
    Internal(String),
}

impl std::fmt::Display for AppError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::BadRequest(m)
            | Self::NotFound(m)
            | Self::TooLarge(m)
            | Self::UnsupportedMedia(m)
            | Self::Undecodable(m)
            | Self::Conflict(m)
            | Self::Unavailable(m, _)
            | Self::Internal(m) => f.write_str(m),
            Self::MethodNotAllowed => f.write_str("method not allowed"),
            Self::Timeout => f.write_str("timed out"),
            Self::Overloaded(after) => write!(f, "overloaded; retry after {after} s"),
        }
    }
}

impl std::error::Error for AppError {}

impl From<dmesh_engine::Error> for AppError {
    fn from(e: dmesh_engine::Error) -> Self {
        match e {
            dmesh_engine::Error::InvalidInput(m) => Self::BadRequest(m),
            dmesh_engine::Error::TooLarge(m) => Self::TooLarge(m),
            dmesh_engine::Error::Decode(m) => Self::Undecodable(m),
            dmesh_engine::Error::Unattainable(m) => Self::Conflict(m),
            dmesh_engine::Error::Internal(m) => Self::Internal(m),
        }
    }
}

impl From<StoreError> for AppError {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::BadId(m) => Self::BadRequest(m),
            StoreError::Unavailable(m) => Self::Unavailable(m, 1),
            other => Self::Internal(other.to_string()),
        }
    }
}

impl From<tokio::task::JoinError> for AppError {
    fn from(e: tokio::task::JoinError) -> Self {
        Self::Internal(format!("worker task failed: {e}"))
    }
}
