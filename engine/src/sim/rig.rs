//! Camera rigs: where a scene's reference views are.

use glam::{DMat3, DQuat, DVec3};
use serde::{Deserialize, Serialize};

use crate::camera::{Camera, Projection};

/// Reference camera placements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Rig {
    /// DMesh's six faces of a box around `center`, at `distance`.
    BoxFaces {
        /// Centre of the object.
        center: [f64; 3],
        /// Distance of each camera from the centre.
        distance: f64,
    },
    /// Verlani's ring: `count` cameras on a circle of `radius` around the y
    /// axis through `target`, at each of `heights`, looking at `target`.
    Ring {
        /// Cameras per height.
        count: u32,
        /// Circle radius.
        radius: f64,
        /// Camera heights (world y).
        heights: Vec<f64>,
        /// Where every camera looks.
        target: [f64; 3],
    },
    /// A rectified stereo pair: `eye` and `eye + baseline` along the camera's x.
    Stereo {
        /// Left camera centre.
        eye: [f64; 3],
        /// Where both look.
        target: [f64; 3],
        /// Distance between the centres.
        baseline: f64,
    },
}

/// The camera-to-world rotation of a camera at `eye` looking at `target`
/// (OpenCV axes, world y up); straight up or down uses world z as up.
pub fn look_at(eye: DVec3, target: DVec3) -> DQuat {
    let f = (target - eye).normalize_or(DVec3::NEG_Z);
    let up = if f.cross(DVec3::Y).length() < 1e-9 {
        DVec3::Z
    } else {
        DVec3::Y
    };
    let x = f.cross(up).normalize();
    let y = f.cross(x);
    DQuat::from_mat3(&DMat3::from_cols(x, y, f)).normalize()
}

/// A pinhole camera of `width x height` and horizontal field of view `fov_deg`.
pub fn camera(width: u32, height: u32, fov_deg: f64, eye: DVec3, target: DVec3) -> crate::Result<Camera> {
    let f = f64::from(width) / 2.0 / (fov_deg.to_radians() / 2.0).tan();
    let projection = Projection::Perspective {
        fx: f,
        fy: f,
        cx: f64::from(width - 1) / 2.0,
        cy: f64::from(height - 1) / 2.0,
    };
    Camera::new(width, height, projection, look_at(eye, target), eye)
}

impl Rig {
    /// Checks the numbers.
    pub fn validate(&self) -> crate::Result<()> {
        let ok = match self {
            Self::BoxFaces { center, distance } => center.iter().all(|c| c.is_finite()) && *distance > 0.0,
            Self::Ring {
                count,
                radius,
                heights,
                target,
            } => {
                (1..=360).contains(count)
                    && *radius > 0.0
                    && !heights.is_empty()
                    && heights.iter().chain(target).all(|v| v.is_finite())
            }
            Self::Stereo { eye, target, baseline } => {
                eye.iter().chain(target).all(|v| v.is_finite()) && *baseline > 0.0 && eye != target
            }
        };
        if ok {
            Ok(())
        } else {
            Err(crate::Error::invalid(
                "scene rig: ring needs 1-360 cameras, a positive radius and heights; box_faces a positive distance; \
                 stereo a positive baseline and an eye apart from the target",
            ))
        }
    }

    /// The reference cameras.
    pub fn cameras(&self, width: u32, height: u32, fov_deg: f64) -> crate::Result<Vec<Camera>> {
        let mut out = Vec::new();
        match self {
            Self::BoxFaces { center, distance } => {
                let c = DVec3::from_array(*center);
                for axis in [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z] {
                    out.push(camera(width, height, fov_deg, c + axis * *distance, c)?);
                }
            }
            Self::Ring {
                count,
                radius,
                heights,
                target,
            } => {
                let t = DVec3::from_array(*target);
                for &h in heights {
                    for k in 0..*count {
                        let a = std::f64::consts::TAU * f64::from(k) / f64::from(*count);
                        let eye = DVec3::new(t.x + radius * a.sin(), h, t.z + radius * a.cos());
                        out.push(camera(width, height, fov_deg, eye, t)?);
                    }
                }
            }
            Self::Stereo { eye, target, baseline } => {
                let (e, t) = (DVec3::from_array(*eye), DVec3::from_array(*target));
                let left = camera(width, height, fov_deg, e, t)?;
                let right_eye = e + left.rotation * DVec3::X * *baseline;
                let right = Camera::new(width, height, left.projection, left.rotation, right_eye)?;
                out.extend([left, right]);
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_points_the_optical_axis_at_the_target() {
        let eye = DVec3::new(3.0, 2.0, 4.0);
        let q = look_at(eye, DVec3::ZERO);
        assert!((q * DVec3::Z - (-eye).normalize()).length() < 1e-12);
        // Image "down" points to world down-ish.
        assert!((q * DVec3::Y).y < 0.0);
    }

    #[test]
    fn rigs_have_the_documented_counts() {
        let ring = Rig::Ring {
            count: 8,
            radius: 4.0,
            heights: vec![1.0, 2.0],
            target: [0.0; 3],
        };
        assert_eq!(ring.cameras(32, 24, 60.0).unwrap().len(), 16);
        assert_eq!(
            Rig::BoxFaces {
                center: [0.0; 3],
                distance: 3.0
            }
            .cameras(32, 24, 60.0)
            .unwrap()
            .len(),
            6
        );
        let pair = Rig::Stereo {
            eye: [0.0, 1.0, 3.0],
            target: [0.0; 3],
            baseline: 0.1,
        }
        .cameras(32, 24, 60.0)
        .unwrap();
        assert!(((pair[1].translation - pair[0].translation).length() - 0.1).abs() < 1e-12);
    }
}
