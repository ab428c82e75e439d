//! The scene file: objects, texture, effects and camera rig, as JSON.
//!
//! ```json
//! {"objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]},
//!              {"type": "box", "min": [-0.5, 0, -0.5], "max": [0.5, 1, 0.5]}],
//!  "texture": {"checker": 0.25},
//!  "effects": {"noise": 0.002},
//!  "rig": {"ring": {"count": 8, "radius": 4, "heights": [1, 2.5], "target": [0, 0.5, 0]}},
//!  "width": 256, "height": 192, "fov_deg": 60}
//! ```
//! World axes: y up. Unknown fields are refused.

use serde::{Deserialize, Serialize};

use super::effects::Effects;
use super::objects::Object;
use super::rig::Rig;

/// A complete scene description.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// What is in the scene.
    pub objects: Vec<Object>,
    /// Procedural texture.
    #[serde(default)]
    pub texture: Texture,
    /// Sensor effects; none by default.
    #[serde(default)]
    pub effects: Effects,
    /// Where the reference cameras are.
    pub rig: Rig,
    /// Reference image width in pixels.
    pub width: u32,
    /// Reference image height in pixels.
    pub height: u32,
    /// Horizontal field of view of the reference cameras, degrees.
    pub fov_deg: f64,
}

/// Albedo pattern: a soft 3D checkerboard of the given cell size in metres,
/// modulating each object's own colour between 60 % and 100 %.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Texture {
    /// Cell size of the checkerboard, metres.
    pub checker: f64,
}

impl Default for Texture {
    fn default() -> Self {
        Self { checker: 0.25 }
    }
}

/// How far [`SceneSpec::swayed`] slides the objects, metres.
pub const SWAY_M: f64 = 0.3;
/// The period of [`SceneSpec::swayed`]'s sway, seconds.
pub const SWAY_PERIOD_S: f64 = 4.0;

impl SceneSpec {
    /// Parses a scene file and checks its numbers.
    pub fn from_json(text: &str) -> crate::Result<Self> {
        let spec: Self = serde_json::from_str(text).map_err(|e| crate::Error::invalid(format!("scene file: {e}")))?;
        spec.validate()?;
        Ok(spec)
    }

    /// Refuses sizes, angles and geometry the renderer cannot use.
    pub fn validate(&self) -> crate::Result<()> {
        if self.width < 2 || self.height < 2 || u64::from(self.width) * u64::from(self.height) > 16 << 20 {
            return Err(crate::Error::invalid(format!(
                "scene image is {}x{}; each side must be at least 2 and the area at most 16 Mpx",
                self.width, self.height
            )));
        }
        if !(self.fov_deg > 1.0 && self.fov_deg < 170.0) {
            return Err(crate::Error::invalid(format!(
                "fov_deg is {}; it must be between 1 and 170",
                crate::error::Shown(self.fov_deg)
            )));
        }
        if !(self.texture.checker.is_finite() && self.texture.checker > 0.0) {
            return Err(crate::Error::invalid(
                "texture checker size must be a positive number of metres",
            ));
        }
        for o in &self.objects {
            o.validate()?;
        }
        self.effects.validate()?;
        self.rig.validate()
    }

    /// The scene at time `t` seconds of a live sequence: every object but
    /// the planes (the background) slid along x by
    /// `SWAY_M * sin(2 pi t / SWAY_PERIOD_S)`.
    pub fn swayed(&self, t: f64) -> Self {
        let x = SWAY_M * (std::f64::consts::TAU * t / SWAY_PERIOD_S).sin();
        Self {
            objects: self.objects.iter().map(|o| o.moved([x, 0.0, 0.0])).collect(),
            ..self.clone()
        }
    }

    /// The box scene the tests and the demo use: a floor, two boxes,
    /// a sphere, a staircase and a thin pole in front of a wall, seen by a
    /// ring of eight cameras at two heights.
    pub fn demo() -> Self {
        use Object::*;
        Self {
            objects: vec![
                // A bounded floor: an infinite plane would alias towards its horizon.
                Box {
                    min: [-4.0, -0.1, -4.0],
                    max: [4.0, 0.0, 4.0],
                    color: [0.55, 0.55, 0.5],
                },
                Box {
                    min: [-1.2, 0.0, -0.4],
                    max: [-0.4, 0.8, 0.4],
                    color: [0.8, 0.3, 0.2],
                },
                Box {
                    min: [0.5, 0.0, 0.3],
                    max: [1.1, 0.5, 0.9],
                    color: [0.2, 0.4, 0.8],
                },
                Sphere {
                    center: [0.2, 0.45, -0.6],
                    radius: 0.45,
                    color: [0.9, 0.8, 0.2],
                },
                Staircase {
                    origin: [0.4, 0.0, -1.6],
                    steps: 4,
                    width: 0.8,
                    rise: 0.15,
                    run: 0.2,
                    color: [0.4, 0.7, 0.4],
                },
                Pole {
                    base: [-0.2, 0.0, 1.0],
                    radius: 0.04,
                    height: 1.4,
                    color: [0.9, 0.9, 0.9],
                },
                Box {
                    min: [-1.6, 0.0, 1.5],
                    max: [1.6, 1.6, 1.6],
                    color: [0.6, 0.5, 0.7],
                },
            ],
            texture: Texture::default(),
            effects: Effects::default(),
            rig: Rig::Ring {
                count: 8,
                radius: 4.0,
                heights: vec![1.2, 2.6],
                target: [0.0, 0.4, 0.0],
            },
            width: 256,
            height: 192,
            fov_deg: 60.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_demo_scene_round_trips_through_json() {
        let demo = SceneSpec::demo();
        demo.validate().unwrap();
        let text = serde_json::to_string_pretty(&demo).unwrap();
        assert_eq!(SceneSpec::from_json(&text).unwrap(), demo);
    }

    #[test]
    fn bad_scene_files_name_the_problem() {
        let e = SceneSpec::from_json(r#"{"objects": [], "rig": {"stereo": {"baseline": 0.1, "eye": [0, 1, 3], "target": [0, 0, 0]}}, "width": 64, "height": 48, "fov_deg": 200}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("fov_deg"), "{e}");
        let e = SceneSpec::from_json(r#"{"objects": [], "rig": {"stereo": {"baseline": 0.1, "eye": [0, 1, 3], "target": [0, 0, 0]}}, "width": 64, "height": 48, "fov_deg": 60, "extra": 1}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("extra"), "{e}");
    }
}
