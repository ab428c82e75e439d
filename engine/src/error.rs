//! The engine's one error type.
//!
//! Variants tell bad input (the caller can fix it) from a broken internal
//! invariant (a bug in dmesh). Messages are lower-case, quote the bad value and
//! say what would be accepted.

/// Everything the engine can refuse or fail at.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An argument or a field has a value the engine does not accept.
    #[error("{0}")]
    InvalidInput(String),
    /// The input declares more pixels or bytes than the configured limit;
    /// detected before anything of that size is allocated.
    #[error("{0}")]
    TooLarge(String),
    /// Image bytes that could not be decoded: truncated, malformed or of an
    /// unsupported kind.
    #[error("{0}")]
    Decode(String),
    /// A well-formed request that the stored data cannot satisfy (a
    /// triangle budget below the view's coarsest mesh).
    #[error("{0}")]
    Unattainable(String),
    /// An internal invariant does not hold. This is a bug in dmesh: please report it.
    #[error("internal error: {0} (this is a bug in dmesh, please report it)")]
    Internal(String),
}

/// A number as a message quotes it: as Rust prints it, but in scientific
/// notation when that would be a long run of digits (`1e300` prints 301
/// of them; a fuzzer sends such values).
#[derive(Clone, Copy, Debug)]
pub struct Shown(pub f64);

impl std::fmt::Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0.abs();
        if v >= 1e15 || (v > 0.0 && v < 1e-6) {
            write!(f, "{:e}", self.0)
        } else {
            write!(f, "{}", self.0)
        }
    }
}

/// Shorthand for results of the engine.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Bad input, with a message that names the field and what is accepted.
    pub fn invalid(message: impl Into<String>) -> Self {
        Self::InvalidInput(message.into())
    }

    /// A valid request this data cannot satisfy.
    pub fn unattainable(message: impl Into<String>) -> Self {
        Self::Unattainable(message.into())
    }

    /// Undecodable image bytes.
    pub fn decode(message: impl Into<String>) -> Self {
        Self::Decode(message.into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quoted_number_is_short() {
        assert_eq!(Shown(6.1e307).to_string(), "6.1e307");
        assert_eq!(Shown(-1e300).to_string(), "-1e300");
        assert_eq!(Shown(1e-9).to_string(), "1e-9");
        assert_eq!(Shown(180.5).to_string(), "180.5");
        assert_eq!(Shown(-1.0).to_string(), "-1");
        assert_eq!(Shown(0.0).to_string(), "0");
        assert_eq!(Shown(f64::NAN).to_string(), "NaN");
        assert_eq!(Shown(f64::INFINITY).to_string(), "inf");
    }
}
