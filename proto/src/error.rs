//! The one error body of every failure: `{"error": {"code": "...", "message": "..."}}`.

use serde::{Deserialize, Serialize};

/// The body of every error response.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorBody {
    /// What went wrong.
    pub error: ErrorDetail,
}

/// A stable code and a message for people.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorDetail {
    /// Stable, machine-readable: `bad_request`, `not_found`, `too_large`,
    /// `unsupported_media_type`, `undecodable_image`, `method_not_allowed`, `timeout`, `overloaded`, `internal`.
    pub code: String,
    /// Names the bad field and what is accepted.
    pub message: String,
}

impl ErrorBody {
    /// An error body with `code` and `message`.
    pub fn new(code: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            error: ErrorDetail {
                code: code.into(),
                message: message.into(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_has_the_documented_json_shape() {
        let e = ErrorBody::new("not_found", "scene \"a\" has no view \"b\"");
        crate::round_trip::both(&e);
        let json: serde_json::Value = serde_json::to_value(&e).unwrap();
        assert_eq!(json["error"]["code"], "not_found");
    }
}
