//! Wire types of dmesh: every value that crosses a process boundary, with
//! serde derives for JSON and bincode 2.
//!
//! - [`camera`]: the camera, in the one JSON form used everywhere:
//!   `{"width": 640, "height": 480, "projection": {"perspective": {"fx": 525.0,
//!   "fy": 525.0, "cx": 319.5, "cy": 239.5}}, "pose": {"rotation": [0, 0, 0, 1],
//!   "translation": [0, 0, 0]}}`, or `{"orthographic": {"sx", "sy", "cx", "cy"}}`
//!   (metres per pixel); `pose` maps camera to world and may be omitted;
//!   unknown fields are refused;
//! - [`strips`]: one view's extracted mesh: vertices and strip indices;
//! - [`view`]: the summary of a stored reference view;
//! - [`render`]: a novel-view request and its per-view answer;
//! - [`error`]: the one error body;
//! - [`diamond`]: the hierarchy's geometry, which edge each grid vertex bisects;
//! - [`compact`]: protocol 7, the compact mesh stream (`application/vnd.dmesh.mesh`).
//!
//! These types check shape only; the engine validates values. Binary bodies
//! use [`to_bincode`] / [`from_bincode`]: bincode 2 with fixed-size
//! little-endian integers, laid out byte by byte in `PROTOCOL.md`. Every
//! response carries `version` = [`PROTOCOL_VERSION`].

mod bits;
pub mod camera;
pub mod compact;
pub mod diamond;
pub mod error;
pub mod render;
pub mod residual;
pub mod strips;
pub mod view;

pub use camera::{Camera, Pose, Projection};
pub use compact::{MeshBody, MeshStream, RenderStream, COMPACT_VERSION, MESH_MEDIA_TYPE};
pub use error::{ErrorBody, ErrorDetail};
pub use render::{RenderRequest, RenderResponse, RenderedView, Selection, Timings};
pub use residual::{RawGrid, ResidualDepths, ResidualError};
pub use strips::{Depths, Indices, Lod, Reach, StripRequest, StripResponse, WireVertex};
pub use view::{SceneList, ViewList, ViewSummary};

/// Version of the wire format, sent in every response.
pub const PROTOCOL_VERSION: u16 = 5;

/// Media type of bincode bodies.
pub const BINCODE_MEDIA_TYPE: &str = "application/x-bincode";

/// The bincode configuration of the wire: fixed-size little-endian integers,
/// `u64` lengths, `u32` enum variant indices (see `PROTOCOL.md`).
pub fn wire_config() -> bincode::config::Configuration<bincode::config::LittleEndian, bincode::config::Fixint> {
    bincode::config::standard()
        .with_little_endian()
        .with_fixed_int_encoding()
}

/// Encodes a wire value as bincode.
pub fn to_bincode<T: serde::Serialize>(value: &T) -> Result<Vec<u8>, bincode::error::EncodeError> {
    bincode::serde::encode_to_vec(value, wire_config())
}

/// Decodes a wire value from bincode; trailing bytes are an error.
///
/// A length field may claim more than the body holds; bincode allocates
/// what it claims, so the decoder runs with a byte limit just above the
/// body's size (the smallest of a few powers of two): such a claim is an
/// error before anything that large is allocated, never a panic or an
/// out-of-memory abort.
pub fn from_bincode<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Result<T, bincode::error::DecodeError> {
    fn limited<T: serde::de::DeserializeOwned, const N: usize>(
        bytes: &[u8],
    ) -> Result<(T, usize), bincode::error::DecodeError> {
        bincode::serde::decode_from_slice(bytes, wire_config().with_limit::<N>())
    }
    let (value, read) = match bytes.len() {
        n if n <= 1 << 16 => limited::<T, { 1 << 16 }>(bytes),
        n if n <= 1 << 20 => limited::<T, { 1 << 20 }>(bytes),
        n if n <= 1 << 24 => limited::<T, { 1 << 24 }>(bytes),
        n if n <= 1 << 28 => limited::<T, { 1 << 28 }>(bytes),
        _ => limited::<T, { 1 << 32 }>(bytes),
    }?;
    if read != bytes.len() {
        return Err(bincode::error::DecodeError::OtherString(format!(
            "{} trailing bytes after the value",
            bytes.len() - read
        )));
    }
    Ok(value)
}

#[cfg(test)]
pub(crate) mod round_trip {

    /// Fuzz regression (wire_bincode, crash-aee8424f): a strip response
    /// whose string length claims more than usize can hold made bincode
    /// panic with "capacity overflow"; now it is an error.
    #[test]
    fn a_length_claiming_more_than_the_body_is_an_error_not_a_panic() {
        let mut body = 2u16.to_le_bytes().to_vec();
        body.extend_from_slice(&u64::MAX.to_le_bytes());
        body.extend_from_slice(b"s0");
        assert!(crate::from_bincode::<crate::StripResponse>(&body).is_err());
        let mut body = 2u16.to_le_bytes().to_vec();
        body.extend_from_slice(&(1u64 << 40).to_le_bytes());
        assert!(crate::from_bincode::<crate::StripResponse>(&body).is_err());
        let crash = include_bytes!("../../fuzz/regressions/wire_bincode-capacity-overflow");
        // Fuzz regression (wire_bincode): exact depths of NaN were handed on.
        let nan = include_bytes!("../../fuzz/regressions/wire_bincode-nan-depth");
        let strips: Vec<crate::StripResponse> = match crate::from_bincode::<crate::StripResponse>(nan) {
            Ok(s) => vec![s],
            Err(_) => crate::from_bincode::<crate::RenderResponse>(nan)
                .unwrap()
                .views
                .into_iter()
                .map(|v| v.strips)
                .collect(),
        };
        assert!(strips.iter().any(|s| s.decode_depths().is_err()));
        assert!(crate::from_bincode::<crate::RenderResponse>(crash).is_err());
    }

    use serde::{de::DeserializeOwned, Serialize};
    use std::fmt::Debug;

    /// Asserts that `value` survives JSON and bincode unchanged.
    pub fn both<T: Serialize + DeserializeOwned + PartialEq + Debug>(value: &T) {
        let json = serde_json::to_string(value).unwrap();
        assert_eq!(&serde_json::from_str::<T>(&json).unwrap(), value, "JSON: {json}");
        let bin = super::to_bincode(value).unwrap();
        assert_eq!(&super::from_bincode::<T>(&bin).unwrap(), value, "bincode");
    }
}
