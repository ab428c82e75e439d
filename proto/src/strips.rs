//! One reference view's extracted mesh, as a thin client draws it.
//!
//! Vertices come coarse to fine and carry grid coordinates `(i, j)` (the
//! pixel of the reference image, hence also the texture coordinate) and depth,
//! from which the client rebuilds positions with the view's camera; the normal
//! is octahedron-encoded in two bytes and the sampling quality rho is one byte.
//! Indices form generalised triangle strips with primitive restart (the
//! largest value of the index width), drawable as `TRIANGLE_STRIP`.

use serde::{Deserialize, Serialize};

use crate::camera::Camera;

/// The level of detail a mesh was extracted at.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Lod {
    /// Static: object-space tolerance in metres.
    Epsilon(f64),
    /// View-dependent: tolerance in pixels of the requesting camera.
    Tau(f64),
}

/// One vertex: 11 bytes in bincode.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WireVertex {
    /// Pixel column in the reference image.
    pub i: u16,
    /// Pixel row in the reference image.
    pub j: u16,
    /// Depth `z` in metres (finite, positive).
    pub depth: f32,
    /// Octahedron-encoded unit normal facing the reference camera.
    pub normal: [u8; 2],
    /// Sampling quality rho in 1/255.
    pub rho: u8,
}

/// Strip indices, 16-bit when the mesh has fewer than 65,535 vertices.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Indices {
    /// Restart marker `u16::MAX`.
    U16(Vec<u16>),
    /// Restart marker `u32::MAX`.
    U32(Vec<u32>),
}

/// Body of `POST .../strips`: `{"epsilon": E}` or `{"tau": T, "camera": {...}}`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StripRequest {
    /// Static tolerance in metres.
    #[serde(default)]
    pub epsilon: Option<f64>,
    /// View-dependent tolerance in pixels of `camera`.
    #[serde(default)]
    pub tau: Option<f64>,
    /// The requesting camera, with `tau`.
    #[serde(default)]
    pub camera: Option<Camera>,
}

impl Indices {
    /// The indices as 32-bit, the restart marker mapped to `u32::MAX`.
    pub fn to_u32(&self) -> Vec<u32> {
        match self {
            Self::U16(v) => v
                .iter()
                .map(|&i| if i == u16::MAX { u32::MAX } else { u32::from(i) })
                .collect(),
            Self::U32(v) => v.clone(),
        }
    }
}

/// A view's mesh for one request.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StripResponse {
    /// [`crate::PROTOCOL_VERSION`].
    pub version: u16,
    /// Scene id.
    pub scene: String,
    /// View id.
    pub view: String,
    /// The tolerance the mesh meets.
    pub lod: Lod,
    /// The reference camera (positions and texture coordinates come from it).
    pub camera: Camera,
    /// Vertices, coarse to fine.
    pub vertices: Vec<WireVertex>,
    /// Generalised strips with primitive restart.
    pub indices: Indices,
    /// Number of (non-degenerate) triangles the strips draw.
    pub triangles: u32,
    /// Server-side extraction time in milliseconds.
    pub extract_ms: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Pose, Projection};

    pub(crate) fn sample() -> StripResponse {
        StripResponse {
            version: crate::PROTOCOL_VERSION,
            scene: "demo".into(),
            view: "front".into(),
            lod: Lod::Tau(1.0),
            camera: Camera {
                width: 4,
                height: 3,
                projection: Projection::Perspective {
                    fx: 4.0,
                    fy: 4.0,
                    cx: 1.5,
                    cy: 1.0,
                },
                pose: Pose::default(),
            },
            vertices: vec![
                WireVertex {
                    i: 0,
                    j: 0,
                    depth: 2.0,
                    normal: [128, 128],
                    rho: 255,
                },
                WireVertex {
                    i: 3,
                    j: 2,
                    depth: 2.5,
                    normal: [120, 130],
                    rho: 200,
                },
                WireVertex {
                    i: 3,
                    j: 0,
                    depth: 2.25,
                    normal: [128, 128],
                    rho: 250,
                },
            ],
            indices: Indices::U16(vec![0, 1, 2, u16::MAX, 2, 1, 0]),
            triangles: 2,
            extract_ms: 0.25,
        }
    }

    #[test]
    fn round_trips_in_both_encodings() {
        crate::round_trip::both(&sample());
        let mut wide = sample();
        wide.indices = Indices::U32(vec![0, 1, 2, u32::MAX, 2, 1, 0]);
        wide.lod = Lod::Epsilon(0.01);
        crate::round_trip::both(&wide);
    }

    #[test]
    fn sixteen_bit_indices_widen_with_their_restart_marker() {
        assert_eq!(Indices::U16(vec![0, 7, u16::MAX, 3]).to_u32(), vec![0, 7, u32::MAX, 3]);
        assert_eq!(Indices::U32(vec![1, u32::MAX]).to_u32(), vec![1, u32::MAX]);
    }

    #[test]
    fn request_round_trips() {
        crate::round_trip::both(&StripRequest {
            epsilon: Some(0.01),
            ..Default::default()
        });
        crate::round_trip::both(&StripRequest {
            tau: Some(1.0),
            camera: Some(sample().camera),
            epsilon: None,
        });
        let r: StripRequest = serde_json::from_str(r#"{"epsilon": 0.5}"#).unwrap();
        assert_eq!(r.epsilon, Some(0.5));
    }

    #[test]
    fn bincode_layout_matches_protocol_md() {
        let r = sample();
        let b = crate::to_bincode(&r).unwrap();
        // version
        assert_eq!(&b[0..2], &1u16.to_le_bytes());
        // scene: u64 length + bytes
        assert_eq!(&b[2..10], &4u64.to_le_bytes());
        assert_eq!(&b[10..14], b"demo");
        // view
        assert_eq!(&b[14..22], &5u64.to_le_bytes());
        assert_eq!(&b[22..27], b"front");
        // lod: u32 variant (1 = tau) + f64
        assert_eq!(&b[27..31], &1u32.to_le_bytes());
        assert_eq!(&b[31..39], &1.0f64.to_le_bytes());
        // camera: width, height, projection variant 0 + 4 f64, rotation 4 f64, translation 3 f64
        assert_eq!(&b[39..43], &4u32.to_le_bytes());
        assert_eq!(&b[47..51], &0u32.to_le_bytes());
        let after_camera = 39 + 4 + 4 + 4 + 32 + 32 + 24;
        // vertices: u64 count + 11 bytes each
        assert_eq!(&b[after_camera..after_camera + 8], &3u64.to_le_bytes());
        let v1 = after_camera + 8 + 11;
        assert_eq!(&b[v1..v1 + 2], &3u16.to_le_bytes());
        assert_eq!(&b[v1 + 4..v1 + 8], &2.5f32.to_le_bytes());
        assert_eq!(b[v1 + 10], 200);
        // indices: u32 variant 0 (u16) + u64 count + values
        let idx = after_camera + 8 + 3 * 11;
        assert_eq!(&b[idx..idx + 4], &0u32.to_le_bytes());
        assert_eq!(&b[idx + 4..idx + 12], &7u64.to_le_bytes());
        assert_eq!(&b[idx + 12 + 6..idx + 12 + 8], &u16::MAX.to_le_bytes());
        // triangles, extract_ms, end
        let tail = idx + 12 + 14;
        assert_eq!(&b[tail..tail + 4], &2u32.to_le_bytes());
        assert_eq!(&b[tail + 4..tail + 12], &0.25f64.to_le_bytes());
        assert_eq!(b.len(), tail + 12);
    }
}
