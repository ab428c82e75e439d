//! Camera paths for walkthroughs: key cameras (an eye and where it looks)
//! and a frame count, interpolated smoothly. Eye and target each follow a
//! Catmull-Rom spline through the keys, so position and view direction (hence
//! rotation, kept level by `look_at`) change with continuous velocity; a key
//! marked `cut` is jumped to, as a film cut would (Qu et al. Sec. 3.4 treat
//! such frames as all holes).
//!
//! ```json
//! {"width": 256, "height": 192, "fov_deg": 60, "frames": 360, "closed": true,
//!  "keys": [{"eye": [3.2, 1.8, 0], "target": [0, 0.4, 0]}, ...]}
//! ```

use anyhow::{bail, Context};
use dmesh_engine::camera::Camera;
use glam::DVec3;
use serde::Deserialize;

/// One key of a path.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Key {
    /// Camera centre, world.
    pub eye: [f64; 3],
    /// Where it looks.
    pub target: [f64; 3],
    /// Jump to this key instead of moving to it.
    #[serde(default)]
    pub cut: bool,
}

/// A path file.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Path {
    /// Image width of every frame.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Horizontal field of view, degrees.
    pub fov_deg: f64,
    /// Frames in all.
    pub frames: u32,
    /// The last key leads back to the first.
    #[serde(default)]
    pub closed: bool,
    /// At least two keys.
    pub keys: Vec<Key>,
}

const MAX_FRAMES: u32 = 100_000;

impl Path {
    /// Parses and checks a path file.
    pub fn from_json(text: &str) -> anyhow::Result<Self> {
        let path: Self = serde_json::from_str(text).context("path file")?;
        path.validate()?;
        Ok(path)
    }

    fn validate(&self) -> anyhow::Result<()> {
        if self.keys.len() < 2 {
            bail!("a path needs at least two keys, it has {}", self.keys.len());
        }
        if !(1..=MAX_FRAMES).contains(&self.frames) {
            bail!("frames is {}; it must be 1 to {MAX_FRAMES}", self.frames);
        }
        for (k, key) in self.keys.iter().enumerate() {
            let (e, t) = (DVec3::from(key.eye), DVec3::from(key.target));
            if !(e.is_finite() && t.is_finite()) || (t - e).length() < 1e-9 {
                bail!("key {k}: eye and target must be finite and apart");
            }
        }
        if self.segments().iter().all(|s| s.cut) {
            bail!("every segment of the path is a cut: nothing to move along");
        }
        // One frame checks the camera numbers (size, field of view).
        self.camera(0)?;
        Ok(())
    }

    fn segments(&self) -> Vec<Segment> {
        let n = self.keys.len();
        let count = if self.closed { n } else { n - 1 };
        (0..count)
            .map(|i| Segment {
                from: i,
                cut: self.keys[(i + 1) % n].cut,
            })
            .collect()
    }

    /// Key `i` with the path's wrap-around (closed) or clamping (open), not
    /// reaching across a cut: the neighbour beyond a cut is the key itself.
    fn neighbour(&self, i: usize, step: isize) -> DVec3Pair {
        let n = self.keys.len() as isize;
        let at = |k: isize| -> Option<usize> {
            if self.closed {
                Some(k.rem_euclid(n) as usize)
            } else {
                (0..n).contains(&k).then_some(k as usize)
            }
        };
        let here = i as isize;
        let there = at(here + step);
        let crosses = match there {
            None => true,
            Some(j) if step > 0 => self.keys[j].cut,
            Some(_) => self.keys[i].cut,
        };
        let k = if crosses { i } else { there.unwrap_or(i) };
        let key = &self.keys[k];
        (DVec3::from(key.eye), DVec3::from(key.target))
    }

    /// The camera of frame `t` (`0..frames`).
    pub fn camera(&self, t: u32) -> anyhow::Result<Camera> {
        let (eye, target) = self.pose(t);
        Ok(dmesh_engine::sim::rig::camera(
            self.width,
            self.height,
            self.fov_deg,
            eye,
            target,
        )?)
    }

    /// Eye and target of frame `t`.
    fn pose(&self, t: u32) -> (DVec3, DVec3) {
        let segments = self.segments();
        let moving: Vec<&Segment> = segments.iter().filter(|s| !s.cut).collect();
        // An open path ends on its last key; a closed one comes back to the start.
        let span = if self.closed {
            self.frames
        } else {
            self.frames.saturating_sub(1).max(1)
        };
        let u = f64::from(t.min(span)) / f64::from(span) * moving.len() as f64;
        let k = (u.floor() as usize).min(moving.len() - 1);
        let s = u - k as f64;
        let from = moving[k].from;
        let to = (from + 1) % self.keys.len();
        let (p0, p1, p2, p3) = (
            self.neighbour(from, -1),
            self.neighbour(from, 0),
            self.neighbour(to, 0),
            self.neighbour(to, 1),
        );
        (
            catmull_rom(p0.0, p1.0, p2.0, p3.0, s),
            catmull_rom(p0.1, p1.1, p2.1, p3.1, s),
        )
    }
}

type DVec3Pair = (DVec3, DVec3);

struct Segment {
    from: usize,
    cut: bool,
}

/// Uniform Catmull-Rom between `p1` (s = 0) and `p2` (s = 1).
fn catmull_rom(p0: DVec3, p1: DVec3, p2: DVec3, p3: DVec3, s: f64) -> DVec3 {
    let (s2, s3) = (s * s, s * s * s);
    0.5 * (2.0 * p1 + (p2 - p0) * s + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * s2 + (3.0 * p1 - p0 - 3.0 * p2 + p3) * s3)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(closed: bool, cut_at: Option<usize>) -> Path {
        let eyes = [[4.0, 1.0, 0.0], [0.0, 1.0, 4.0], [-4.0, 1.0, 0.0], [0.0, 1.0, -4.0]];
        Path {
            width: 64,
            height: 48,
            fov_deg: 60.0,
            frames: 40,
            closed,
            keys: eyes
                .iter()
                .enumerate()
                .map(|(k, e)| Key {
                    eye: *e,
                    target: [0.0, 0.0, 0.0],
                    cut: cut_at == Some(k),
                })
                .collect(),
        }
    }

    #[test]
    fn a_path_passes_through_its_keys_and_moves_smoothly() {
        let path = square(true, None);
        assert!((path.camera(0).unwrap().translation - DVec3::new(4.0, 1.0, 0.0)).length() < 1e-12);
        assert!((path.camera(10).unwrap().translation - DVec3::new(0.0, 1.0, 4.0)).length() < 1e-12);
        let step = |t: u32| (path.camera(t + 1).unwrap().translation - path.camera(t).unwrap().translation).length();
        let steps: Vec<f64> = (0..39).map(step).collect();
        let (lo, hi) = steps.iter().fold((f64::MAX, 0f64), |(a, b), &s| (a.min(s), b.max(s)));
        assert!(hi < 1.6 * lo, "steps from {lo} to {hi}");
        // Closed: the last frame leads back to the first.
        assert!(step(39) < 1.6 * lo);
    }

    #[test]
    fn a_cut_jumps_instead_of_moving() {
        let path = square(false, Some(2));
        let eyes: Vec<DVec3> = (0..40).map(|t| path.camera(t).unwrap().translation).collect();
        let steps: Vec<f64> = eyes.windows(2).map(|w| (w[1] - w[0]).length()).collect();
        let jump = steps.iter().cloned().fold(0f64, f64::max);
        let typical = {
            let mut s = steps.clone();
            s.sort_by(f64::total_cmp);
            s[s.len() / 2]
        };
        assert!(jump > 10.0 * typical, "a jump of {jump} against steps of {typical}");
        assert!((eyes[39] - DVec3::new(0.0, 1.0, -4.0)).length() < 1e-12);
    }

    proptest::proptest! {
        /// Any path that parses gives every frame a finite camera or a clear
        /// error, never a panic, whatever its keys (repeated, crossing, cut).
        #[test]
        fn every_frame_of_a_valid_path_is_a_finite_camera_or_a_clear_error(
            keys in proptest::collection::vec(
                (proptest::array::uniform3(-5.0f64..5.0), proptest::array::uniform3(-5.0f64..5.0), proptest::bool::ANY),
                2..7,
            ),
            frames in 1u32..200,
            closed in proptest::bool::ANY,
        ) {
            let path = Path {
                width: 32,
                height: 24,
                fov_deg: 60.0,
                frames,
                closed,
                keys: keys.into_iter().map(|(eye, target, cut)| Key { eye, target, cut }).collect(),
            };
            if path.validate().is_ok() {
                for t in 0..frames {
                    // An eye that meets its target between keys, or looks
                    // straight up or down, has no camera (`rig::camera`):
                    // that frame is refused, and says why.
                    match path.camera(t) {
                        Ok(c) => proptest::prop_assert!(c.translation.is_finite() && c.rotation.is_finite()),
                        Err(e) => proptest::prop_assert!(!e.to_string().trim().is_empty()),
                    }
                }
            }
        }
    }

    #[test]
    fn bad_paths_are_refused_with_a_reason() {
        let one = r#"{"width": 64, "height": 48, "fov_deg": 60, "frames": 10, "keys": [{"eye": [0,0,0], "target": [0,0,1]}]}"#;
        assert!(Path::from_json(one).unwrap_err().to_string().contains("two keys"));
        let same = r#"{"width": 64, "height": 48, "fov_deg": 60, "frames": 10, "keys": [{"eye": [0,0,0], "target": [0,0,0]}, {"eye": [1,0,0], "target": [0,0,1]}]}"#;
        assert!(Path::from_json(same).unwrap_err().to_string().contains("apart"));
        let wide = r#"{"width": 64, "height": 48, "fov_deg": 190, "frames": 10, "keys": [{"eye": [0,0,0], "target": [0,0,1]}, {"eye": [1,0,0], "target": [0,0,1]}]}"#;
        assert!(Path::from_json(wide).is_err());
        assert!(Path::from_json("{").is_err());
    }
}
