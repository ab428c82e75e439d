//! A novel-view request and the per-view meshes that answer it (DMesh Sec. 6.2).

use serde::{Deserialize, Serialize};

use crate::camera::Camera;
use crate::strips::StripResponse;

/// Which reference views a novel camera uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Selection {
    /// DMesh: every view whose direction is within `max_angle_deg` (default 135) of the novel one.
    #[default]
    Dmesh,
    /// Verlani et al.'s limited set: views within 40 degrees.
    Limited,
}

/// `POST /v1/scenes/{scene}/render`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderRequest {
    /// The novel camera.
    pub camera: Camera,
    /// The level of detail: `tau` in the novel camera's pixels, `epsilon`,
    /// or a budget shared out by view weight.
    pub lod: crate::strips::Lod,
    /// Residual bit-depth of the depths, `0..=16`; absent: exact.
    #[serde(default)]
    pub bits: Option<u8>,
    /// Largest number of views to return.
    #[serde(default)]
    pub max_views: Option<u32>,
    /// Largest angle between view directions, degrees.
    #[serde(default)]
    pub max_angle_deg: Option<f64>,
    /// Selection rule.
    #[serde(default)]
    pub selection: Selection,
}

/// One selected view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderedView {
    /// Angular x positional weight; the weights of a response sum to 1.
    pub weight: f64,
    /// Its mesh.
    pub strips: StripResponse,
    /// Where its colour texture is served (cacheable, with a strong ETag).
    pub color_url: String,
}

/// Server-side timings of a render request.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timings {
    /// Selecting views and weights.
    pub select_ms: f64,
    /// Extracting all meshes.
    pub extract_ms: f64,
    /// The whole request.
    pub total_ms: f64,
}

/// The answer to a [`RenderRequest`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderResponse {
    /// [`crate::PROTOCOL_VERSION`].
    pub version: u16,
    /// Selected views, heaviest first.
    pub views: Vec<RenderedView>,
    /// Server timings.
    pub timings: Timings,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Pose, Projection};

    fn camera() -> Camera {
        Camera {
            width: 4,
            height: 3,
            projection: Projection::Perspective {
                fx: 4.0,
                fy: 4.0,
                cx: 1.5,
                cy: 1.0,
            },
            pose: Pose::default(),
        }
    }

    #[test]
    fn request_round_trips_and_defaults() {
        let json = r#"{"camera": {"width": 4, "height": 3, "projection": {"perspective": {"fx": 4, "fy": 4, "cx": 1.5, "cy": 1}}}, "lod": {"tau": 1.0}}"#;
        let r: RenderRequest = serde_json::from_str(json).unwrap();
        assert_eq!(r.selection, Selection::Dmesh);
        assert_eq!(r.lod, crate::strips::Lod::Tau(1.0));
        crate::round_trip::both(&r);
        crate::round_trip::both(&RenderRequest {
            selection: Selection::Limited,
            max_views: Some(3),
            ..r
        });
    }

    /// A mesh of no triangles, extracted in `extract_ms`.
    fn empty_strips(extract_ms: f64) -> crate::strips::StripResponse {
        crate::strips::StripResponse {
            version: crate::PROTOCOL_VERSION,
            scene: "s".into(),
            view: "v".into(),
            lod: crate::strips::Lod::Tau(1.0),
            camera: camera(),
            vertices: vec![],
            depths: crate::strips::Depths::Exact(vec![]),
            indices: crate::strips::Indices::U16(vec![]),
            triangles: 0,
            extract_ms,
            reach: None,
            cuts: Vec::new(),
        }
    }

    /// The layout `PROTOCOL.md` gives under "Render response", which the
    /// browser viewer's decoder is written from.
    #[test]
    fn bincode_layout_matches_protocol_md() {
        let strips = empty_strips(0.5);
        let strip_bytes = crate::to_bincode(&strips).unwrap();
        let response = RenderResponse {
            version: crate::PROTOCOL_VERSION,
            views: vec![RenderedView {
                weight: 0.25,
                strips,
                color_url: "/c".into(),
            }],
            timings: Timings {
                select_ms: 1.0,
                extract_ms: 2.0,
                total_ms: 3.0,
            },
        };
        let b = crate::to_bincode(&response).unwrap();
        assert_eq!(&b[0..2], &5u16.to_le_bytes());
        assert_eq!(&b[2..10], &1u64.to_le_bytes());
        assert_eq!(&b[10..18], &0.25f64.to_le_bytes());
        let at = 18 + strip_bytes.len();
        assert_eq!(&b[18..at], &strip_bytes[..]);
        assert_eq!(&b[at..at + 8], &2u64.to_le_bytes());
        assert_eq!(&b[at + 8..at + 10], b"/c");
        let t = at + 10;
        assert_eq!(&b[t..t + 8], &1.0f64.to_le_bytes());
        assert_eq!(&b[t + 8..t + 16], &2.0f64.to_le_bytes());
        assert_eq!(&b[t + 16..], &3.0f64.to_le_bytes());
    }

    #[test]
    fn response_round_trips() {
        let strips = empty_strips(0.0);
        crate::round_trip::both(&RenderResponse {
            version: crate::PROTOCOL_VERSION,
            views: vec![RenderedView {
                weight: 1.0,
                strips,
                color_url: "/c".into(),
            }],
            timings: Timings {
                select_ms: 0.1,
                extract_ms: 0.2,
                total_ms: 0.4,
            },
        });
    }
}
