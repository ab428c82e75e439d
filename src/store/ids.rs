//! Scene and view ids: 1-64 characters of `[A-Za-z0-9._-]`, never `.` or
//! `..`, so nothing a request names can reach outside the data directory.

use super::StoreError;

/// Checks an id, naming `what` (scene or view) in the error.
pub fn validate_id(what: &str, id: &str) -> Result<(), StoreError> {
    let ok_chars = id
        .bytes()
        .all(|b| b.is_ascii_alphanumeric() || b == b'.' || b == b'_' || b == b'-');
    if id.is_empty() || id.len() > 64 || !ok_chars || id == "." || id == ".." {
        return Err(StoreError::BadId(format!(
            "{what} id {id:?} is not accepted; use 1-64 characters of A-Z, a-z, 0-9, '.', '_' and '-', not '.' or '..'"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids() {
        for good in ["a", "scene-1", "v.2_x", &"x".repeat(64)] {
            assert!(validate_id("view", good).is_ok(), "{good}");
        }
        for bad in ["", ".", "..", "a/b", "a\\b", "é", &"x".repeat(65), "a b", "..%2f"] {
            assert!(validate_id("view", bad).is_err(), "{bad}");
        }
    }
}
