//! Ray casting a scene into a camera: depth (`z` along the optical axis) and colour.

use glam::DVec3;

use super::effects::{apply_depth, Rng};
use super::objects::Hit;
use super::spec::SceneSpec;
use crate::camera::{Camera, Projection};
use crate::image::{ColorImage, DepthImage};

/// One rendered view.
#[derive(Clone, Debug)]
pub struct RenderedView {
    /// The camera.
    pub camera: Camera,
    /// Depth; 0 where no object is hit (or an effect dropped the sample).
    pub depth: DepthImage,
    /// Colour (8-bit RGB); black where nothing is hit.
    pub color: ColorImage,
}

/// A soft 3D checkerboard: cells of the texture's size whose edges ramp over
/// about a fifth of a cell, so the pattern is visible yet band-limited
/// (resampling it costs little, as a real photograph's texture would).
fn albedo(scene: &SceneSpec, p: DVec3, base: DVec3) -> DVec3 {
    // A phase offset keeps the pattern on surfaces through the origin planes.
    let q = p * (std::f64::consts::PI / scene.texture.checker) + DVec3::splat(0.7);
    let s = q.x.sin() * q.y.sin() * q.z.sin();
    base * (0.8 + 0.2 * (3.0 * s).clamp(-1.0, 1.0))
}

/// Renders `camera`'s view of `scene`; `reference` applies the scene's depth
/// effects (reference views), otherwise depth is exact (ground truth).
/// Specular highlights, being part of the scene's appearance, are in both.
pub fn render_view(scene: &SceneSpec, camera: &Camera, reference: bool, seed: u64) -> crate::Result<RenderedView> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut z = vec![0f32; w * h];
    let mut rgb = vec![0u8; 3 * w * h];
    let light = DVec3::new(0.4, 1.0, 0.3).normalize();
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (x as f64, y as f64);
            // Camera-frame ray with unit z, so the ray parameter is the depth.
            let (origin_c, dir_c) = match camera.projection {
                Projection::Perspective { fx, fy, cx, cy } => {
                    (DVec3::ZERO, DVec3::new((u - cx) / fx, (v - cy) / fy, 1.0))
                }
                Projection::Orthographic { sx, sy, cx, cy } => {
                    (DVec3::new((u - cx) * sx, (v - cy) * sy, 0.0), DVec3::Z)
                }
            };
            let o = camera.to_world(origin_c);
            let d = camera.rotation * dir_c;
            let best: Option<Hit> = scene
                .objects
                .iter()
                .filter_map(|obj| obj.intersect(o, d, 1e-9))
                .min_by(|a, b| a.t.total_cmp(&b.t));
            let Some(hit) = best else { continue };
            let i = y * w + x;
            z[i] = hit.t as f32;
            let p = o + hit.t * d;
            let mut c = albedo(scene, p, hit.color);
            // Highlights are view-dependent: they belong to reference and ground-truth views alike.
            if let Some(s) = scene.effects.specular {
                let view = -d.normalize();
                let r = 2.0 * hit.normal.dot(light) * hit.normal - light;
                c += DVec3::splat(s * r.dot(view).max(0.0).powi(32));
            }
            for k in 0..3 {
                rgb[3 * i + k] = (c[k].clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
            }
        }
    }
    if reference {
        apply_depth(&scene.effects, w, &mut z, &mut Rng::new(scene.effects.seed ^ seed));
    }
    Ok(RenderedView {
        camera: *camera,
        depth: DepthImage::from_z(camera.width, camera.height, z)?,
        color: ColorImage {
            width: camera.width,
            height: camera.height,
            rgb,
        },
    })
}

impl SceneSpec {
    /// Renders every reference view of the rig (with the scene's effects).
    pub fn reference_views(&self) -> crate::Result<Vec<RenderedView>> {
        self.validate()?;
        self.rig
            .cameras(self.width, self.height, self.fov_deg)?
            .iter()
            .enumerate()
            .map(|(k, cam)| render_view(self, cam, true, k as u64))
            .collect()
    }

    /// Renders the exact ground truth of a novel camera.
    pub fn ground_truth(&self, camera: &Camera) -> crate::Result<RenderedView> {
        render_view(self, camera, false, 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::effects::{Effects, Quantize};
    use crate::sim::objects::Object;
    use crate::sim::rig::{camera, Rig};
    use crate::sim::spec::Texture;

    fn sphere_scene(effects: Effects) -> SceneSpec {
        SceneSpec {
            objects: vec![Object::Sphere {
                center: [0.0, 0.0, 0.0],
                radius: 1.0,
                color: [0.8, 0.5, 0.2],
            }],
            texture: Texture::default(),
            effects,
            rig: Rig::Stereo {
                eye: [0.0, 0.0, 5.0],
                target: [0.0; 3],
                baseline: 0.2,
            },
            width: 64,
            height: 48,
            fov_deg: 40.0,
        }
    }

    #[test]
    fn a_scene_without_effects_is_exact() {
        let s = sphere_scene(Effects::default());
        let views = s.reference_views().unwrap();
        assert_eq!(views.len(), 2);
        let v = &views[0];
        // The central pixel looks straight at the sphere: depth 4 (to within half a pixel's tilt).
        let (cx, cy) = (32usize, 24usize);
        let z = v.depth.z[cy * 64 + cx];
        assert!((z - 4.0).abs() < 1e-3, "{z}");
        // Every hit is on the sphere: back-projected points are at distance 1 from the centre.
        for (i, &z) in v.depth.z.iter().enumerate().filter(|(_, z)| **z > 0.0) {
            let p = v
                .camera
                .to_world(v.camera.back_project((i % 64) as f64, (i / 64) as f64, f64::from(z)));
            assert!((p.length() - 1.0).abs() < 1e-4, "sample {i} at {}", p.length());
        }
        // And the ground truth from the same camera is identical.
        assert_eq!(s.ground_truth(&v.camera).unwrap().depth, v.depth);
    }

    #[test]
    fn effects_appear_only_when_asked() {
        let exact = sphere_scene(Effects::default()).reference_views().unwrap();
        let valid = |v: &RenderedView| v.depth.valid_count();
        let holes = sphere_scene(Effects {
            holes: Some(0.3),
            ..Default::default()
        })
        .reference_views()
        .unwrap();
        let (a, b) = (valid(&exact[0]), valid(&holes[0]));
        assert!(b < a && (b as f64) > 0.5 * a as f64, "{a} -> {b}");
        let noisy = sphere_scene(Effects {
            noise: Some(0.01),
            ..Default::default()
        })
        .reference_views()
        .unwrap();
        let diff: f32 = exact[0]
            .depth
            .z
            .iter()
            .zip(&noisy[0].depth.z)
            .map(|(a, b)| (a - b).abs())
            .sum();
        assert!(diff > 0.0);
        let q = Quantize {
            focal_baseline: 10.0,
            steps_per_pixel: 4.0,
        };
        let quant = sphere_scene(Effects {
            quantize_disparity: Some(q),
            ..Default::default()
        })
        .reference_views()
        .unwrap();
        for &z in quant[0].depth.z.iter().filter(|z| **z > 0.0) {
            let steps = 10.0 / f64::from(z) * 4.0;
            assert!(
                (steps - steps.round()).abs() < 1e-3,
                "disparity {steps} is not on a quarter pixel"
            );
        }
    }

    #[test]
    fn a_camera_outside_everything_sees_nothing() {
        let s = sphere_scene(Effects::default());
        let cam = camera(16, 12, 40.0, DVec3::new(0.0, 0.0, 5.0), DVec3::new(0.0, 0.0, 10.0)).unwrap();
        assert_eq!(s.ground_truth(&cam).unwrap().depth.valid_count(), 0);
    }
}
