//! The camera, in the one JSON form used everywhere (files, multipart parts,
//! request bodies); see the crate docs.

use serde::{Deserialize, Serialize};

/// A camera as it travels on the wire: image size, projection and pose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Intrinsics.
    pub projection: Projection,
    /// Camera-to-world transform; identity when omitted.
    #[serde(default)]
    pub pose: Pose,
}

/// Perspective or orthographic intrinsics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Projection {
    /// Pinhole camera: `u = fx * x / z + cx`, `v = fy * y / z + cy`.
    Perspective {
        /// Focal length along x, in pixels.
        fx: f64,
        /// Focal length along y, in pixels.
        fy: f64,
        /// Principal point x, in pixel coordinates (pixel centres are integers).
        cx: f64,
        /// Principal point y, in pixel coordinates.
        cy: f64,
    },
    /// Parallel projection: `x = (u - cx) * sx`, `y = (v - cy) * sy`, `z = depth`.
    Orthographic {
        /// Metres per pixel along x.
        sx: f64,
        /// Metres per pixel along y.
        sy: f64,
        /// Pixel x of the optical axis.
        cx: f64,
        /// Pixel y of the optical axis.
        cy: f64,
    },
}

/// Camera-to-world rigid transform.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// Unit quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
    /// Camera centre in world coordinates.
    pub translation: [f64; 3],
}

impl Default for Pose {
    fn default() -> Self {
        Self {
            rotation: [0.0, 0.0, 0.0, 1.0],
            translation: [0.0, 0.0, 0.0],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_json_round_trips_and_pose_defaults_to_identity() {
        let text = r#"{"width": 640, "height": 480,
            "projection": {"perspective": {"fx": 525.0, "fy": 525.0, "cx": 319.5, "cy": 239.5}}}"#;
        let cam: Camera = serde_json::from_str(text).unwrap();
        assert_eq!(cam.pose, Pose::default());
        crate::round_trip::both(&cam);
        let ortho = Camera {
            projection: Projection::Orthographic {
                sx: 0.5,
                sy: 0.25,
                cx: 1.0,
                cy: 2.0,
            },
            pose: Pose {
                rotation: [0.0, 0.6, 0.0, 0.8],
                translation: [1.0, -2.0, 3.0],
            },
            ..cam
        };
        crate::round_trip::both(&ortho);
    }

    #[test]
    fn unknown_fields_are_named_in_the_error() {
        let text = r#"{"width": 4, "height": 4, "fov": 3,
            "projection": {"orthographic": {"sx": 1, "sy": 1, "cx": 0, "cy": 0}}}"#;
        let err = serde_json::from_str::<Camera>(text).unwrap_err().to_string();
        assert!(err.contains("fov"), "{err}");
    }
}
