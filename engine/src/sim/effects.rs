//! Sensor effects, each applied only when the scene lists it.

use serde::{Deserialize, Serialize};

/// The effects a scene asks for; the default is none, and then depth is exact.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    /// Gaussian depth noise, standard deviation in metres.
    #[serde(default)]
    pub noise: Option<f64>,
    /// 8-bit disparity quantisation with this `focal * baseline`: depth is
    /// turned into disparity, rounded to 1/`disparity_steps` pixel, and back.
    #[serde(default)]
    pub quantize_disparity: Option<Quantize>,
    /// Fraction of samples lost (invalid depth), scattered.
    #[serde(default)]
    pub holes: Option<f64>,
    /// Fraction of samples at depth discontinuities that land between the two surfaces.
    #[serde(default)]
    pub flying_pixels: Option<f64>,
    /// Strength of a white specular highlight (view-dependent colour).
    #[serde(default)]
    pub specular: Option<f64>,
    /// Seed of the effects' random numbers.
    #[serde(default)]
    pub seed: u64,
}

/// Disparity quantisation settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Quantize {
    /// Focal length in pixels times baseline in metres.
    pub focal_baseline: f64,
    /// Steps per pixel of disparity (Middlebury 2003 stores 4).
    pub steps_per_pixel: f64,
}

impl Effects {
    /// Checks the numbers.
    pub fn validate(&self) -> crate::Result<()> {
        let fraction = |name: &str, v: Option<f64>| match v {
            Some(f) if !(0.0..=1.0).contains(&f) => Err(crate::Error::invalid(format!(
                "effect {name} is {}; it must be a fraction between 0 and 1",
                crate::error::Shown(f)
            ))),
            _ => Ok(()),
        };
        fraction("holes", self.holes)?;
        fraction("flying_pixels", self.flying_pixels)?;
        for (name, v) in [("noise", self.noise), ("specular", self.specular)] {
            if let Some(x) = v {
                if !(x.is_finite() && x >= 0.0) {
                    return Err(crate::Error::invalid(format!(
                        "effect {name} is {}; it must be a finite number >= 0",
                        crate::error::Shown(x)
                    )));
                }
            }
        }
        if let Some(q) = self.quantize_disparity {
            if !(q.focal_baseline > 0.0
                && q.focal_baseline.is_finite()
                && q.steps_per_pixel > 0.0
                && q.steps_per_pixel.is_finite())
            {
                return Err(crate::Error::invalid(
                    "effect quantize_disparity needs a positive focal_baseline and steps_per_pixel",
                ));
            }
        }
        Ok(())
    }

    /// True when nothing is simulated.
    pub fn is_exact(&self) -> bool {
        self.noise.is_none()
            && self.quantize_disparity.is_none()
            && self.holes.is_none()
            && self.flying_pixels.is_none()
            && self.specular.is_none()
    }
}

/// A small deterministic generator (xorshift64*), so simulated scenes are
/// reproducible without a dependency.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// Seeded generator (a zero seed is moved off zero).
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x9e37_79b9_7f4a_7c15 | 1)
    }

    /// Uniform in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// Applies the depth effects to a rendered depth map (row-major, 0 = no hit).
pub fn apply_depth(effects: &Effects, width: usize, z: &mut [f32], rng: &mut Rng) {
    if let Some(f) = effects.flying_pixels {
        let original = z.to_vec();
        for i in 0..z.len() {
            let x = i % width;
            if x + 1 < width && original[i] > 0.0 && original[i + 1] > 0.0 {
                let (a, b) = (original[i], original[i + 1]);
                if (a - b).abs() > 0.1 * a.min(b) && rng.uniform() < f {
                    z[i] = a + (b - a) * rng.uniform() as f32;
                }
            }
        }
    }
    if let Some(q) = effects.quantize_disparity {
        for d in z.iter_mut().filter(|d| **d > 0.0) {
            let disparity = q.focal_baseline / f64::from(*d);
            let stepped = (disparity * q.steps_per_pixel).round() / q.steps_per_pixel;
            *d = if stepped > 0.0 {
                (q.focal_baseline / stepped) as f32
            } else {
                0.0
            };
        }
    }
    if let Some(sigma) = effects.noise {
        for d in z.iter_mut().filter(|d| **d > 0.0) {
            *d = (f64::from(*d) + sigma * rng.normal()).max(0.0) as f32;
        }
    }
    if let Some(f) = effects.holes {
        for d in z.iter_mut() {
            if rng.uniform() < f {
                *d = 0.0;
            }
        }
    }
}
