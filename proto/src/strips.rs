//! One reference view's extracted mesh, as a thin client draws it.
//!
//! Vertices come coarse to fine and carry grid coordinates `(i, j)` (the
//! pixel of the reference image, hence also the texture coordinate); their
//! depths come separately, exact or residual-coded ([`Depths`]), and the client
//! rebuilds positions from both with the view's camera. The normal is
//! octahedron-encoded in two bytes and the sampling quality rho is one byte.
//! Indices form generalised triangle strips with primitive restart (the
//! largest value of the index width), drawable as `TRIANGLE_STRIP`.

use serde::{Deserialize, Serialize};

use crate::camera::Camera;
use crate::residual::{ResidualDepths, ResidualError};

/// A level of detail: what a request asks for (any variant) and what a
/// response was extracted at (`epsilon` or `tau`: a budget is answered with
/// the tolerance it resolved to). JSON: one key, `{"tau": 1.0}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Lod {
    /// Static: object-space tolerance in metres.
    Epsilon(f64),
    /// View-dependent: tolerance in pixels of the requesting camera.
    Tau(f64),
    /// At most this many triangles (shared by weight over a render's
    /// views); the server picks the finest tolerance it can guarantee meets it.
    MaxTriangles(u32),
    /// Extraction time to aim for in milliseconds (shared likewise), turned
    /// into a triangle budget by the server's measured extraction rate.
    BudgetMs(f64),
}

impl Lod {
    /// The one level of detail a flat form names (a query string, a command
    /// line, the viewer's address): exactly one of the four may be given.
    /// The one place that rule is stated; the error says it.
    pub fn exactly_one(
        epsilon: Option<f64>,
        tau: Option<f64>,
        max_triangles: Option<u32>,
        budget_ms: Option<f64>,
    ) -> Result<Self, &'static str> {
        let given = [
            epsilon.map(Self::Epsilon),
            tau.map(Self::Tau),
            max_triangles.map(Self::MaxTriangles),
            budget_ms.map(Self::BudgetMs),
        ];
        match given.iter().flatten().collect::<Vec<_>>()[..] {
            [lod] => Ok(*lod),
            _ => Err("give exactly one of epsilon (metres), tau (pixels, with camera), max_triangles or budget_ms"),
        }
    }
}

impl Default for Lod {
    /// Full resolution.
    fn default() -> Self {
        Self::Epsilon(0.0)
    }
}

/// One vertex (its depth travels in [`Depths`]): 7 bytes in bincode.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WireVertex {
    /// Pixel column in the reference image.
    pub i: u16,
    /// Pixel row in the reference image.
    pub j: u16,
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

/// Vertex depths, in vertex order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Depths {
    /// Lossless: `z` in metres (finite, positive), 4 bytes per vertex.
    Exact(Vec<f32>),
    /// Residuals from parent-edge predictions (request `bits`), see [`crate::residual`].
    Residual(ResidualDepths),
}

/// Body of `POST .../strips`: one level of detail, `{"lod": {"epsilon": E}}`,
/// `{"lod": {"tau": T}, "camera": {...}}`, or a budget (`max_triangles` or
/// `budget_ms`, with `camera` for a view-dependent mesh); optionally `bits`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StripRequest {
    /// The level of detail.
    pub lod: Lod,
    /// The requesting camera: needed with `tau`, optional with a budget
    /// (view-dependent then), refused with `epsilon`.
    #[serde(default)]
    pub camera: Option<Camera>,
    /// Residual bit-depth of the depths, `0..=16`; absent: exact `f32`. In
    /// the compact stream, the number of depth planes; absent: all.
    #[serde(default)]
    pub bits: Option<u8>,
    /// Compact stream only: the ETag of a compact response of this view the
    /// client holds. For the same request with fewer planes the answer is
    /// only the planes it lacks; for another level of detail or camera, the
    /// change from the held mesh (with `held_camera` when the held mesh was
    /// view-dependent). Ignored (the whole mesh is sent) when it names
    /// another view version, or a mesh the server cannot derive again.
    #[serde(default)]
    pub held: Option<String>,
    /// The requesting camera of the held mesh, when it had one.
    #[serde(default)]
    pub held_camera: Option<Camera>,
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

impl StripResponse {
    /// The vertex depths in metres, decoding residuals if need be; a depth
    /// that is not finite and positive is an error (fuzz regression
    /// `wire_bincode`: exact depths were passed on unchecked).
    pub fn decode_depths(&self) -> Result<Vec<f32>, ResidualError> {
        match &self.depths {
            Depths::Exact(z) if z.len() == self.vertices.len() => {
                match z.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
                    // The wire promises finite positive depths; a body that breaks it is refused.
                    Some(&bad) => Err(ResidualError::Invalid(bad)),
                    None => Ok(z.clone()),
                }
            }
            Depths::Exact(z) => Err(ResidualError::Count {
                depths: z.len(),
                vertices: self.vertices.len(),
            }),
            Depths::Residual(r) => {
                let ij: Vec<(u16, u16)> = self.vertices.iter().map(|v| (v.i, v.j)).collect();
                r.decode(&ij)
            }
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
    /// The tolerance the mesh meets (for a budget request, the one the server chose).
    pub lod: Lod,
    /// The reference camera (positions and texture coordinates come from it).
    pub camera: Camera,
    /// Vertices, coarse to fine.
    pub vertices: Vec<WireVertex>,
    /// Their depths.
    pub depths: Depths,
    /// Generalised strips with primitive restart.
    pub indices: Indices,
    /// Number of (non-degenerate) triangles the strips draw.
    pub triangles: u32,
    /// Server-side extraction time in milliseconds.
    pub extract_ms: f64,
    /// For a view-dependent mesh (`lod` is `Tau`), how far its camera may move
    /// before it must be fetched again; `None` for a static one.
    #[serde(default)]
    pub reach: Option<Reach>,
    /// The cut triangles of a mesh that came in the compact stream
    /// (protocol 7), decoded, with their parts drawn beside `indices`. Never
    /// on the protocol 5 wire, whose meshes refine their outlines instead.
    #[serde(skip)]
    pub cuts: Vec<crate::compact::CutTriangle>,
}

/// What a view-dependent mesh still serves once the camera moves
/// (PROTOCOL.md, "Reach"): for a camera with eye `E'` and focal length `f'`
/// at distance `d` from `view`'s eye, the mesh's error is at most
/// `tau * (f' / f) * clearance / (clearance - d)` pixels while `d <
/// clearance`, and a camera whose frustum misses every `culled` sphere sees
/// nothing the mesh lacks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reach {
    /// The camera the vertices were selected and the triangles culled for.
    pub view: Camera,
    /// Smallest `|p - E| - r` in metres over the vertices the tolerance left
    /// out with a nonzero error (`p` the vertex, `r` its nested bounding
    /// radius, `E` the eye); `None` when there was none, and always for an
    /// orthographic camera, whose test does not depend on the eye.
    pub clearance: Option<f64>,
    /// World-frame spheres `[x, y, z, radius]` holding every triangle the
    /// frustum culled (at most 1024; f32, radii padded for the rounding).
    pub culled: Vec<[f32; 4]>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Pose, Projection};

    #[test]
    fn a_flat_form_names_exactly_one_level_of_detail() {
        assert_eq!(Lod::exactly_one(Some(0.01), None, None, None), Ok(Lod::Epsilon(0.01)));
        assert_eq!(Lod::exactly_one(None, Some(1.0), None, None), Ok(Lod::Tau(1.0)));
        assert_eq!(Lod::exactly_one(None, None, Some(7), None), Ok(Lod::MaxTriangles(7)));
        assert_eq!(Lod::exactly_one(None, None, None, Some(2.0)), Ok(Lod::BudgetMs(2.0)));
        let none = Lod::exactly_one(None, None, None, None).unwrap_err();
        assert!(none.contains("exactly one"), "{none}");
        assert!(Lod::exactly_one(Some(0.01), Some(1.0), None, None).is_err());
        assert!(Lod::exactly_one(None, Some(1.0), Some(5), Some(1.0)).is_err());
    }

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
                    normal: [128, 128],
                    rho: 255,
                },
                WireVertex {
                    i: 3,
                    j: 2,
                    normal: [120, 130],
                    rho: 200,
                },
                WireVertex {
                    i: 3,
                    j: 0,
                    normal: [128, 128],
                    rho: 250,
                },
            ],
            depths: Depths::Exact(vec![2.0, 2.5, 2.25]),
            indices: Indices::U16(vec![0, 1, 2, u16::MAX, 2, 1, 0]),
            triangles: 2,
            extract_ms: 0.25,
            reach: None,
            cuts: Vec::new(),
        }
    }

    #[test]
    fn round_trips_in_both_encodings() {
        crate::round_trip::both(&sample());
        let mut wide = sample();
        wide.indices = Indices::U32(vec![0, 1, 2, u32::MAX, 2, 1, 0]);
        wide.lod = Lod::Epsilon(0.01);
        crate::round_trip::both(&wide);
        let ij: Vec<(u16, u16)> = wide.vertices.iter().map(|v| (v.i, v.j)).collect();
        wide.depths = Depths::Residual(ResidualDepths::encode(&ij, &[2.0, 2.5, 2.25], 8, 4, None).unwrap());
        crate::round_trip::both(&wide);
        let back = wide.decode_depths().unwrap();
        assert!(
            back.iter().zip([2.0, 2.5, 2.25]).all(|(a, b)| (a - b).abs() < 1e-2),
            "{back:?}"
        );
    }

    #[test]
    fn depth_count_must_match_the_vertices() {
        let mut r = sample();
        assert_eq!(r.decode_depths().unwrap(), vec![2.0, 2.5, 2.25]);
        r.depths = Depths::Exact(vec![1.0]);
        assert!(r.decode_depths().is_err());
    }

    #[test]
    fn sixteen_bit_indices_widen_with_their_restart_marker() {
        assert_eq!(Indices::U16(vec![0, 7, u16::MAX, 3]).to_u32(), vec![0, 7, u32::MAX, 3]);
        assert_eq!(Indices::U32(vec![1, u32::MAX]).to_u32(), vec![1, u32::MAX]);
    }

    #[test]
    fn request_round_trips() {
        for (lod, camera, bits) in [
            (Lod::Epsilon(0.01), None, None),
            (Lod::Tau(1.0), Some(sample().camera), Some(8)),
            (Lod::MaxTriangles(5000), None, None),
            (Lod::BudgetMs(2.5), Some(sample().camera), None),
        ] {
            crate::round_trip::both(&StripRequest {
                lod,
                camera,
                bits,
                held: None,
                held_camera: None,
            });
        }
        let r: StripRequest = serde_json::from_str(r#"{"lod": {"epsilon": 0.5}}"#).unwrap();
        assert_eq!(r.lod, Lod::Epsilon(0.5));
        let r: StripRequest = serde_json::from_str(r#"{"lod": {"max_triangles": 500}, "bits": 4}"#).unwrap();
        assert_eq!((r.lod, r.bits), (Lod::MaxTriangles(500), Some(4)));
        // One key: two levels of detail, or an unknown one, are refused.
        assert!(serde_json::from_str::<StripRequest>(r#"{"lod": {"tau": 1, "epsilon": 1}}"#).is_err());
        assert!(serde_json::from_str::<StripRequest>(r#"{"lod": {"pixels": 1}}"#).is_err());
        assert!(serde_json::from_str::<StripRequest>(r#"{"tau": 1}"#).is_err());
    }

    #[test]
    fn bincode_layout_matches_protocol_md() {
        let r = sample();
        let b = crate::to_bincode(&r).unwrap();
        // version
        assert_eq!(&b[0..2], &5u16.to_le_bytes());
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
        // vertices: u64 count + 7 bytes each
        assert_eq!(&b[after_camera..after_camera + 8], &3u64.to_le_bytes());
        let v1 = after_camera + 8 + 7;
        assert_eq!(&b[v1..v1 + 2], &3u16.to_le_bytes());
        assert_eq!(b[v1 + 6], 200);
        // depths: u32 variant 0 (exact) + u64 count + f32 values
        let d = after_camera + 8 + 3 * 7;
        assert_eq!(&b[d..d + 4], &0u32.to_le_bytes());
        assert_eq!(&b[d + 4..d + 12], &3u64.to_le_bytes());
        assert_eq!(&b[d + 12 + 4..d + 12 + 8], &2.5f32.to_le_bytes());
        // indices: u32 variant 0 (u16) + u64 count + values
        let idx = d + 12 + 3 * 4;
        assert_eq!(&b[idx..idx + 4], &0u32.to_le_bytes());
        assert_eq!(&b[idx + 4..idx + 12], &7u64.to_le_bytes());
        assert_eq!(&b[idx + 12 + 6..idx + 12 + 8], &u16::MAX.to_le_bytes());
        // triangles, extract_ms, end
        let tail = idx + 12 + 14;
        assert_eq!(&b[tail..tail + 4], &2u32.to_le_bytes());
        assert_eq!(&b[tail + 4..tail + 12], &0.25f64.to_le_bytes());
        // reach: Option tag 0 (static)
        assert_eq!(b[tail + 12], 0);
        assert_eq!(b.len(), tail + 13);
        // with a reach: tag 1, the camera (100 bytes), Option<f64>, Vec<[f32; 4]>
        let mut r = sample();
        r.reach = Some(Reach {
            view: r.camera.clone(),
            clearance: Some(1.5),
            culled: vec![[1.0, 2.0, 3.0, 0.5]],
        });
        let b = crate::to_bincode(&r).unwrap();
        let at = tail + 12;
        assert_eq!(b[at], 1);
        assert_eq!(&b[at + 1..at + 101], &crate::to_bincode(&r.camera).unwrap()[..]);
        assert_eq!(b[at + 101], 1);
        assert_eq!(&b[at + 102..at + 110], &1.5f64.to_le_bytes());
        assert_eq!(&b[at + 110..at + 118], &1u64.to_le_bytes());
        assert_eq!(&b[at + 118..at + 122], &1.0f32.to_le_bytes());
        assert_eq!(b.len(), at + 134);
        crate::round_trip::both(&r);
    }
}
