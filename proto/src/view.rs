//! The summary of a stored reference view.

use serde::{Deserialize, Serialize};

use crate::camera::Camera;

/// What the service knows of one stored view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewSummary {
    /// [`crate::PROTOCOL_VERSION`].
    pub version: u16,
    /// Scene id.
    pub scene: String,
    /// View id.
    pub view: String,
    /// The reference camera.
    pub camera: Camera,
    /// Vertices of the padded hierarchy grid.
    pub grid_vertices: u64,
    /// Full-resolution triangles removed by segmentation.
    pub segmented_triangles: u64,
    /// Valid depth samples.
    pub valid_samples: u64,
    /// Hierarchy build time in milliseconds.
    pub build_ms: f64,
    /// Where the colour image is served.
    pub color_url: String,
    /// Depth `z` of the sample nearest the principal point, metres (`None`
    /// where it is invalid): what stands in front of the reference, so a
    /// viewer can start from a reference that sees the scene's centre.
    #[serde(default)]
    pub center_depth: Option<f64>,
}

/// `GET /v1/scenes`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneList {
    /// [`crate::PROTOCOL_VERSION`].
    pub version: u16,
    /// Scene ids, sorted.
    pub scenes: Vec<String>,
}

/// `GET /v1/scenes/{scene}/views`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewList {
    /// [`crate::PROTOCOL_VERSION`].
    pub version: u16,
    /// The scene.
    pub scene: String,
    /// View ids, sorted.
    pub views: Vec<String>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Pose, Projection};

    #[test]
    fn round_trips_in_both_encodings() {
        crate::round_trip::both(&ViewSummary {
            version: crate::PROTOCOL_VERSION,
            scene: "s".into(),
            view: "v".into(),
            camera: Camera {
                width: 2,
                height: 2,
                projection: Projection::Orthographic {
                    sx: 1.0,
                    sy: 1.0,
                    cx: 0.0,
                    cy: 0.0,
                },
                pose: Pose::default(),
            },
            grid_vertices: 9,
            center_depth: Some(1.5),
            segmented_triangles: 0,
            valid_samples: 4,
            build_ms: 0.1,
            color_url: "/v1/scenes/s/views/v/color".into(),
        });
    }

    #[test]
    fn lists_round_trip() {
        crate::round_trip::both(&SceneList {
            version: crate::PROTOCOL_VERSION,
            scenes: vec!["a".into(), "b".into()],
        });
        crate::round_trip::both(&ViewList {
            version: crate::PROTOCOL_VERSION,
            scene: "a".into(),
            views: vec![],
        });
    }
}
