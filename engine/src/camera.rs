//! Cameras: intrinsics, pose, projection and back-projection.
//!
//! Conventions (DESIGN.md, stated here once and used everywhere):
//! - Camera axes follow OpenCV: x right, y down, z forward.
//! - Pixel `(u, v)` is the sample at image coordinates `(u, v)`: pixel centres
//!   are integers, no half-pixel offset, and `cx, cy` use the same coordinates.
//! - Perspective: `u = fx * x / z + cx`, `v = fy * y / z + cy`.
//! - Orthographic: `x = (u - cx) * sx`, `y = (v - cy) * sy`, `z = depth`; a depth
//!   map in it is a height field (how terrain meshers such as martini see it).
//! - Depth is `z`, metres along the optical axis.
//! - The pose maps camera coordinates to world coordinates.

use glam::{DQuat, DVec3};

use crate::error::{Error, Result};

/// Intrinsics of a camera, validated: every number finite, scales positive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Pinhole camera with focal lengths and principal point in pixels.
    Perspective {
        /// Focal length along x, pixels.
        fx: f64,
        /// Focal length along y, pixels.
        fy: f64,
        /// Principal point x.
        cx: f64,
        /// Principal point y.
        cy: f64,
    },
    /// Parallel projection with metres per pixel.
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

/// A validated camera: image size, projection, camera-to-world pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Image width in pixels (at least 1).
    pub width: u32,
    /// Image height in pixels (at least 1).
    pub height: u32,
    /// Intrinsics.
    pub projection: Projection,
    /// Camera-to-world rotation (unit quaternion).
    pub rotation: DQuat,
    /// Camera centre in world coordinates.
    pub translation: DVec3,
}

/// Largest magnitude of a camera number (pixels, metres): far past any real
/// camera, and small enough that products of a few of them stay finite.
pub const MAX_MAGNITUDE: f64 = 1e15;

/// Smallest focal length or pixel size: its inverse stays finite.
pub const MIN_POSITIVE: f64 = 1e-300;

/// Largest image side (the wire's vertex coordinates are 16-bit).
pub const MAX_SIDE: u32 = 65_535;

fn finite(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value.abs() <= MAX_MAGNITUDE {
        Ok(value)
    } else {
        Err(Error::invalid(format!(
            "camera {name} is {value:?}; it must be a finite number of magnitude at most 1e15"
        )))
    }
}

fn positive(name: &str, value: f64) -> Result<f64> {
    if (MIN_POSITIVE..=MAX_MAGNITUDE).contains(&value) {
        Ok(value)
    } else {
        Err(Error::invalid(format!(
            "camera {name} is {value:?}; it must be a number from 1e-300 to 1e15"
        )))
    }
}

impl Camera {
    /// A perspective camera at the world origin looking down +z.
    pub fn perspective(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> Result<Self> {
        Self::new(
            width,
            height,
            Projection::Perspective { fx, fy, cx, cy },
            DQuat::IDENTITY,
            DVec3::ZERO,
        )
    }

    /// An orthographic camera at the world origin looking down +z.
    pub fn orthographic(width: u32, height: u32, sx: f64, sy: f64, cx: f64, cy: f64) -> Result<Self> {
        Self::new(
            width,
            height,
            Projection::Orthographic { sx, sy, cx, cy },
            DQuat::IDENTITY,
            DVec3::ZERO,
        )
    }

    /// Validates every field. The rotation's components must lie in
    /// `[-1, 1]`, not all zero; it is normalised (so a unit quaternion
    /// rounded in transit, or any scaled one, is accepted).
    pub fn new(width: u32, height: u32, projection: Projection, rotation: DQuat, translation: DVec3) -> Result<Self> {
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(Error::invalid(format!(
                "camera is {width}x{height}; width and height must be 1 to 65535"
            )));
        }
        let projection = match projection {
            Projection::Perspective { fx, fy, cx, cy } => Projection::Perspective {
                fx: positive("fx", fx)?,
                fy: positive("fy", fy)?,
                cx: finite("cx", cx)?,
                cy: finite("cy", cy)?,
            },
            Projection::Orthographic { sx, sy, cx, cy } => Projection::Orthographic {
                sx: positive("sx", sx)?,
                sy: positive("sy", sy)?,
                cx: finite("cx", cx)?,
                cy: finite("cy", cy)?,
            },
        };
        let components = [rotation.x, rotation.y, rotation.z, rotation.w];
        if !components.iter().all(|c| (-1.0..=1.0).contains(c)) {
            return Err(Error::invalid(format!(
                "camera rotation is {components:?}; a quaternion [x, y, z, w] has components from -1 to 1"
            )));
        }
        // Scaled by the largest component first, so tiny quaternions normalise too.
        let largest = components.iter().fold(0f64, |m, c| m.max(c.abs()));
        if largest == 0.0 {
            return Err(Error::invalid(
                "camera rotation is [0, 0, 0, 0]; it must be a quaternion [x, y, z, w] of non-zero length",
            ));
        }
        let scaled = rotation / largest;
        let norm = scaled.length();
        for (name, v) in [
            ("translation x", translation.x),
            ("translation y", translation.y),
            ("translation z", translation.z),
        ] {
            finite(name, v)?;
        }
        Ok(Self {
            width,
            height,
            projection,
            rotation: scaled / norm,
            translation,
        })
    }

    /// True for an orthographic camera.
    pub fn is_orthographic(&self) -> bool {
        matches!(self.projection, Projection::Orthographic { .. })
    }

    /// Per-pixel factors `(ax, bx)` so that the camera-frame `x` of pixel
    /// column `u` at depth `z` is `(ax + bx * z)`: perspective `(0, (u - cx) / fx)`,
    /// orthographic `((u - cx) * sx, 0)`. Lets the mesher back-project a whole
    /// row with one multiply-add per sample.
    pub fn column_factors(&self, u: f64) -> (f64, f64) {
        match self.projection {
            Projection::Perspective { fx, cx, .. } => (0.0, (u - cx) / fx),
            Projection::Orthographic { sx, cx, .. } => ((u - cx) * sx, 0.0),
        }
    }

    /// Same as [`Camera::column_factors`] for the camera-frame `y` of row `v`.
    pub fn row_factors(&self, v: f64) -> (f64, f64) {
        match self.projection {
            Projection::Perspective { fy, cy, .. } => (0.0, (v - cy) / fy),
            Projection::Orthographic { sy, cy, .. } => ((v - cy) * sy, 0.0),
        }
    }

    /// The camera-frame point of pixel `(u, v)` at depth `z`.
    pub fn back_project(&self, u: f64, v: f64, z: f64) -> DVec3 {
        let (ax, bx) = self.column_factors(u);
        let (ay, by) = self.row_factors(v);
        DVec3::new(ax + bx * z, ay + by * z, z)
    }

    /// Projects a camera-frame point to `(u, v, z)`; `None` when the point is
    /// not in front of a perspective camera (z <= 0) or the result is not finite.
    pub fn project(&self, p: DVec3) -> Option<(f64, f64, f64)> {
        let (u, v) = match self.projection {
            Projection::Perspective { fx, fy, cx, cy } => {
                if p.z <= 0.0 {
                    return None;
                }
                (fx * p.x / p.z + cx, fy * p.y / p.z + cy)
            }
            Projection::Orthographic { sx, sy, cx, cy } => (p.x / sx + cx, p.y / sy + cy),
        };
        (u.is_finite() && v.is_finite()).then_some((u, v, p.z))
    }

    /// Unit direction from the camera centre to camera-frame point `p`
    /// (orthographic: the optical axis). Falls back to +z at the centre itself.
    pub fn view_direction(&self, p: DVec3) -> DVec3 {
        if self.is_orthographic() {
            return DVec3::Z;
        }
        p.try_normalize().unwrap_or(DVec3::Z)
    }

    /// Length of the camera-frame ray through `(u, v)` per metre of depth:
    /// `range = z * ray_length(u, v)`. Always >= 1 for perspective, 1 for orthographic.
    pub fn ray_length(&self, u: f64, v: f64) -> f64 {
        let (_, bx) = self.column_factors(u);
        let (_, by) = self.row_factors(v);
        (1.0 + bx * bx + by * by).sqrt()
    }

    /// Focal length in pixels used to turn object-space errors into pixels
    /// (DMesh Eq. 4): the larger of `fx, fy`, so `tau` is never exceeded along
    /// either axis. `None` for orthographic cameras, whose scale is [`Camera::pixel_size`].
    pub fn focal_pixels(&self) -> Option<f64> {
        match self.projection {
            Projection::Perspective { fx, fy, .. } => Some(fx.max(fy)),
            Projection::Orthographic { .. } => None,
        }
    }

    /// Metres covered by one pixel at depth `z` (the larger of the two axes).
    pub fn pixel_size(&self, z: f64) -> f64 {
        match self.projection {
            Projection::Perspective { fx, fy, .. } => z.abs() / fx.min(fy),
            Projection::Orthographic { sx, sy, .. } => sx.max(sy),
        }
    }

    /// Camera-frame point to world coordinates.
    pub fn to_world(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }

    /// World point to this camera's frame.
    pub fn to_camera(&self, p: DVec3) -> DVec3 {
        self.rotation.inverse() * (p - self.translation)
    }
}

impl TryFrom<&dmesh_proto::Camera> for Camera {
    type Error = Error;

    fn try_from(c: &dmesh_proto::Camera) -> Result<Self> {
        let projection = match c.projection {
            dmesh_proto::Projection::Perspective { fx, fy, cx, cy } => Projection::Perspective { fx, fy, cx, cy },
            dmesh_proto::Projection::Orthographic { sx, sy, cx, cy } => Projection::Orthographic { sx, sy, cx, cy },
        };
        let [x, y, z, w] = c.pose.rotation;
        let [tx, ty, tz] = c.pose.translation;
        Self::new(
            c.width,
            c.height,
            projection,
            DQuat::from_xyzw(x, y, z, w),
            DVec3::new(tx, ty, tz),
        )
    }
}

impl From<&Camera> for dmesh_proto::Camera {
    fn from(c: &Camera) -> Self {
        let projection = match c.projection {
            Projection::Perspective { fx, fy, cx, cy } => dmesh_proto::Projection::Perspective { fx, fy, cx, cy },
            Projection::Orthographic { sx, sy, cx, cy } => dmesh_proto::Projection::Orthographic { sx, sy, cx, cy },
        };
        let q = c.rotation;
        let t = c.translation;
        dmesh_proto::Camera {
            width: c.width,
            height: c.height,
            projection,
            pose: dmesh_proto::Pose {
                rotation: [q.x, q.y, q.z, q.w],
                translation: [t.x, t.y, t.z],
            },
        }
    }
}

/// Parses the camera JSON form (see `dmesh_proto`) and validates it.
pub fn camera_from_json(text: &str) -> Result<Camera> {
    let wire: dmesh_proto::Camera =
        serde_json::from_str(text).map_err(|e| Error::invalid(format!("camera JSON: {e}")))?;
    Camera::try_from(&wire)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn back_projection_inverts_projection() {
        let cam = Camera::perspective(640, 480, 500.0, 510.0, 319.5, 239.5).unwrap();
        let p = cam.back_project(100.0, 400.0, 2.5);
        let (u, v, z) = cam.project(p).unwrap();
        assert!((u - 100.0).abs() < 1e-9 && (v - 400.0).abs() < 1e-9 && (z - 2.5).abs() < 1e-12);
    }

    #[test]
    fn orthographic_is_a_height_field() {
        let cam = Camera::orthographic(10, 10, 0.5, 0.25, 0.0, 0.0).unwrap();
        assert_eq!(cam.back_project(4.0, 8.0, 3.0), DVec3::new(2.0, 2.0, 3.0));
        assert_eq!(cam.ray_length(9.0, 9.0), 1.0);
    }

    #[test]
    fn bad_values_are_refused_with_the_field_named() {
        let e = Camera::perspective(4, 4, 0.0, 1.0, 0.0, 0.0).unwrap_err().to_string();
        assert!(e.contains("fx"), "{e}");
        let e = Camera::perspective(4, 4, 1.0, f64::NAN, 0.0, 0.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("fy"), "{e}");
        let e = camera_from_json(r#"{"width":4,"height":4,"projection":{"perspective":{"fx":1,"fy":1,"cx":0,"cy":0}},"pose":{"rotation":[0,0,0,2],"translation":[0,0,0]}}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("components from -1 to 1"), "{e}");
        let json = |rotation: &str| {
            camera_from_json(&format!(
                r#"{{"width":4,"height":4,"projection":{{"perspective":{{"fx":1,"fy":1,"cx":0,"cy":0}}}},"pose":{{"rotation":{rotation},"translation":[0,0,0]}}}}"#
            ))
        };
        assert!(json("[0,0,0,0]").unwrap_err().to_string().contains("non-zero length"));
        // Any non-zero quaternion in range is normalised, however small.
        for r in ["[0,0,0,0.5]", "[0,0,0,1e-320]", "[0.5,0.5,0.5,0.5]"] {
            let c = json(r).unwrap();
            assert!((c.rotation.length() - 1.0).abs() < 1e-12, "{r}");
        }
        assert!(Camera::perspective(70_000, 4, 1.0, 1.0, 0.0, 0.0).is_err());
        assert!(Camera::perspective(4, 4, 1e16, 1.0, 0.0, 0.0).is_err());
        assert!(Camera::perspective(4, 4, 1.0, 1.0, -2e15, 0.0).is_err());
        assert!(Camera::perspective(4, 4, 1e-301, 1.0, 0.0, 0.0).is_err());
    }

    #[test]
    fn pose_round_trips_world_points() {
        let q = DQuat::from_rotation_y(0.3);
        let cam = Camera::new(
            4,
            4,
            Projection::Orthographic {
                sx: 1.0,
                sy: 1.0,
                cx: 0.0,
                cy: 0.0,
            },
            q,
            DVec3::new(1.0, 2.0, 3.0),
        )
        .unwrap();
        let p = DVec3::new(0.5, -1.0, 7.0);
        assert!((cam.to_camera(cam.to_world(p)) - p).length() < 1e-12);
    }
}
