//! Analytic objects and their ray intersections (world coordinates, y up).

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// One object of a scene, with its base colour (linear RGB in `[0, 1]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Object {
    /// An infinite plane through `point` with normal `normal`.
    Plane {
        /// A point on the plane.
        point: [f64; 3],
        /// Its normal (any length).
        normal: [f64; 3],
        /// Base colour.
        color: [f64; 3],
    },
    /// An axis-aligned box.
    Box {
        /// Smallest corner.
        min: [f64; 3],
        /// Largest corner.
        max: [f64; 3],
        /// Base colour.
        color: [f64; 3],
    },
    /// A sphere.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius.
        radius: f64,
        /// Base colour.
        color: [f64; 3],
    },
    /// Steps rising along +z from `origin`: step `k` is a box of `width` (x),
    /// height `(k + 1) * rise` (y) and depth `run` (z).
    Staircase {
        /// Front-left-bottom corner.
        origin: [f64; 3],
        /// Number of steps.
        steps: u32,
        /// Width along x.
        width: f64,
        /// Height of one step.
        rise: f64,
        /// Depth of one step.
        run: f64,
        /// Base colour.
        color: [f64; 3],
    },
    /// A vertical cylinder (thin: a pole in front of a wall makes a hard discontinuity).
    Pole {
        /// Centre of its base.
        base: [f64; 3],
        /// Radius.
        radius: f64,
        /// Height.
        height: f64,
        /// Base colour.
        color: [f64; 3],
    },
    /// A height field `y = origin.y + amplitude * sin(x / wavelength) * cos(z / wavelength)`
    /// over `size` (x, z) from `origin`.
    Terrain {
        /// Corner of the field (smallest x and z, base height).
        origin: [f64; 3],
        /// Extent along x and z.
        size: [f64; 2],
        /// Height of the waves.
        amplitude: f64,
        /// Wavelength of the waves.
        wavelength: f64,
        /// Base colour.
        color: [f64; 3],
    },
}

/// The nearest intersection of a ray with an object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter.
    pub t: f64,
    /// Unit surface normal facing the ray's origin.
    pub normal: DVec3,
    /// Base colour of the object hit.
    pub color: DVec3,
}

fn v(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn finite(name: &str, values: &[f64]) -> crate::Result<()> {
    if values.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(crate::Error::invalid(format!(
            "scene {name} has a number that is not finite"
        )))
    }
}

fn aabb(o: DVec3, d: DVec3, min: DVec3, max: DVec3, tmin: f64) -> Option<(f64, DVec3)> {
    let (mut t0, mut t1) = (tmin, f64::INFINITY);
    let mut axis = 0;
    for k in 0..3 {
        if d[k].abs() < 1e-300 {
            if o[k] < min[k] || o[k] > max[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((min[k] - o[k]) / d[k], (max[k] - o[k]) / d[k]);
        let (near, far) = if a < b { (a, b) } else { (b, a) };
        if near > t0 {
            t0 = near;
            axis = k;
        }
        t1 = t1.min(far);
        if t0 > t1 {
            return None;
        }
    }
    let mut n = DVec3::ZERO;
    n[axis] = -d[axis].signum();
    (t0 > tmin).then_some((t0, n))
}

impl Object {
    /// The object translated by `by` (a plane stays: it is the background a
    /// moving scene's objects move in front of).
    pub fn moved(&self, by: [f64; 3]) -> Self {
        let add = |p: [f64; 3]| [p[0] + by[0], p[1] + by[1], p[2] + by[2]];
        let mut o = self.clone();
        match &mut o {
            Self::Plane { .. } => {}
            Self::Box { min, max, .. } => (*min, *max) = (add(*min), add(*max)),
            Self::Sphere { center, .. } => *center = add(*center),
            Self::Staircase { origin, .. } | Self::Terrain { origin, .. } => *origin = add(*origin),
            Self::Pole { base, .. } => *base = add(*base),
        }
        o
    }

    /// Checks every number.
    pub fn validate(&self) -> crate::Result<()> {
        match self {
            Self::Plane { point, normal, color } => {
                finite("plane", &[point.as_slice(), normal, color].concat())?;
                if v(*normal).length() == 0.0 {
                    return Err(crate::Error::invalid("scene plane has a zero normal"));
                }
            }
            Self::Box { min, max, color } => {
                finite("box", &[min.as_slice(), max, color].concat())?;
                if (0..3).any(|k| min[k] >= max[k]) {
                    return Err(crate::Error::invalid("scene box must have min < max on every axis"));
                }
            }
            Self::Sphere { center, radius, color } => {
                finite("sphere", &[center.as_slice(), color, &[*radius]].concat())?;
                if *radius <= 0.0 {
                    return Err(crate::Error::invalid("scene sphere radius must be positive"));
                }
            }
            Self::Staircase {
                origin,
                width,
                rise,
                run,
                color,
                steps,
            } => {
                finite(
                    "staircase",
                    &[origin.as_slice(), color, &[*width, *rise, *run]].concat(),
                )?;
                if *width <= 0.0 || *rise <= 0.0 || *run <= 0.0 || *steps == 0 || *steps > 1000 {
                    return Err(crate::Error::invalid(
                        "scene staircase needs 1-1000 steps of positive size",
                    ));
                }
            }
            Self::Pole {
                base,
                radius,
                height,
                color,
            } => {
                finite("pole", &[base.as_slice(), color, &[*radius, *height]].concat())?;
                if *radius <= 0.0 || *height <= 0.0 {
                    return Err(crate::Error::invalid("scene pole needs a positive radius and height"));
                }
            }
            Self::Terrain {
                origin,
                size,
                amplitude,
                wavelength,
                color,
            } => {
                finite(
                    "terrain",
                    &[origin.as_slice(), size, color, &[*amplitude, *wavelength]].concat(),
                )?;
                if size[0] <= 0.0 || size[1] <= 0.0 || *wavelength <= 0.0 {
                    return Err(crate::Error::invalid(
                        "scene terrain needs a positive size and wavelength",
                    ));
                }
            }
        }
        Ok(())
    }

    fn color(&self) -> DVec3 {
        match self {
            Self::Plane { color, .. }
            | Self::Box { color, .. }
            | Self::Sphere { color, .. }
            | Self::Staircase { color, .. }
            | Self::Pole { color, .. }
            | Self::Terrain { color, .. } => v(*color),
        }
    }

    /// The nearest hit with `t > tmin` of the ray `o + t d`.
    pub fn intersect(&self, o: DVec3, d: DVec3, tmin: f64) -> Option<Hit> {
        let facing = |n: DVec3| if n.dot(d) > 0.0 { -n } else { n };
        let (t, n) = match self {
            Self::Plane { point, normal, .. } => {
                let n = v(*normal).normalize();
                let den = n.dot(d);
                if den.abs() < 1e-300 {
                    return None;
                }
                let t = n.dot(v(*point) - o) / den;
                (t > tmin).then_some((t, n))?
            }
            Self::Box { min, max, .. } => aabb(o, d, v(*min), v(*max), tmin)?,
            Self::Sphere { center, radius, .. } => {
                let oc = o - v(*center);
                let (a, b, c) = (d.dot(d), oc.dot(d), oc.dot(oc) - radius * radius);
                let disc = b * b - a * c;
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                let t = [(-b - s) / a, (-b + s) / a].into_iter().find(|&t| t > tmin)?;
                (t, (o + t * d - v(*center)) / *radius)
            }
            Self::Staircase {
                origin,
                steps,
                width,
                rise,
                run,
                ..
            } => (0..*steps)
                .filter_map(|k| {
                    let k = f64::from(k);
                    let min = v(*origin) + DVec3::new(0.0, 0.0, k * run);
                    let max = min + DVec3::new(*width, (k + 1.0) * rise, *run);
                    aabb(o, d, min, max, tmin)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))?,
            Self::Pole {
                base, radius, height, ..
            } => {
                let b = v(*base);
                let (ox, oz) = (o.x - b.x, o.z - b.z);
                let a = d.x * d.x + d.z * d.z;
                if a < 1e-300 {
                    return None;
                }
                let (bb, c) = (ox * d.x + oz * d.z, ox * ox + oz * oz - radius * radius);
                let disc = bb * bb - a * c;
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                let t = [(-bb - s) / a, (-bb + s) / a]
                    .into_iter()
                    .find(|&t| t > tmin && (0.0..=*height).contains(&(o.y + t * d.y - b.y)))?;
                let p = o + t * d;
                (t, DVec3::new(p.x - b.x, 0.0, p.z - b.z) / *radius)
            }
            Self::Terrain {
                origin,
                size,
                amplitude,
                wavelength,
                ..
            } => {
                let org = v(*origin);
                let h = |p: DVec3| org.y + amplitude * (p.x / wavelength).sin() * (p.z / wavelength).cos();
                let inside =
                    |p: DVec3| p.x >= org.x && p.x <= org.x + size[0] && p.z >= org.z && p.z <= org.z + size[1];
                // March in steps of a tenth of the wavelength, then bisect.
                let (lo_box, hi_box) = (
                    DVec3::new(org.x, org.y - amplitude.abs(), org.z),
                    DVec3::new(org.x + size[0], org.y + amplitude.abs(), org.z + size[1]),
                );
                let (t_in, _) = aabb(o, d, lo_box, hi_box, tmin).or_else(|| {
                    let inside_now = (0..3).all(|k| o[k] >= lo_box[k] && o[k] <= hi_box[k]);
                    inside_now.then_some((tmin, DVec3::Y))
                })?;
                let step = wavelength * 0.1 / d.length();
                let mut t = t_in;
                let mut prev = t;
                let above = |t: f64| {
                    let p = o + t * d;
                    p.y - h(p)
                };
                let start = above(t);
                for _ in 0..100_000 {
                    let p = o + t * d;
                    if !inside(p) && t > t_in + step {
                        return None;
                    }
                    if above(t).signum() != start.signum() {
                        let (mut a, mut b) = (prev, t);
                        for _ in 0..60 {
                            let m = 0.5 * (a + b);
                            if above(m).signum() == start.signum() {
                                a = m;
                            } else {
                                b = m;
                            }
                        }
                        let p = o + b * d;
                        let (gx, gz) = (
                            amplitude / wavelength * (p.x / wavelength).cos() * (p.z / wavelength).cos(),
                            -amplitude / wavelength * (p.x / wavelength).sin() * (p.z / wavelength).sin(),
                        );
                        return Some(Hit {
                            t: b,
                            normal: facing(DVec3::new(-gx, 1.0, -gz).normalize()),
                            color: self.color(),
                        });
                    }
                    prev = t;
                    t += step;
                }
                return None;
            }
        };
        Some(Hit {
            t,
            normal: facing(n.normalize_or(DVec3::Y)),
            color: self.color(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analytic_hits() {
        let s = Object::Sphere {
            center: [0.0, 0.0, 5.0],
            radius: 1.0,
            color: [1.0; 3],
        };
        let h = s.intersect(DVec3::ZERO, DVec3::Z, 0.0).unwrap();
        assert!((h.t - 4.0).abs() < 1e-12 && (h.normal - DVec3::NEG_Z).length() < 1e-12);
        let b = Object::Box {
            min: [-1.0, -1.0, 2.0],
            max: [1.0, 1.0, 3.0],
            color: [1.0; 3],
        };
        assert!((b.intersect(DVec3::ZERO, DVec3::Z, 0.0).unwrap().t - 2.0).abs() < 1e-12);
        assert!(b.intersect(DVec3::ZERO, DVec3::X, 0.0).is_none());
        let p = Object::Pole {
            base: [0.0, -1.0, 3.0],
            radius: 0.5,
            height: 2.0,
            color: [1.0; 3],
        };
        assert!((p.intersect(DVec3::ZERO, DVec3::Z, 0.0).unwrap().t - 2.5).abs() < 1e-12);
        let ground = Object::Plane {
            point: [0.0, -1.0, 0.0],
            normal: [0.0, 1.0, 0.0],
            color: [1.0; 3],
        };
        assert!(
            (ground
                .intersect(DVec3::ZERO, DVec3::new(0.0, -1.0, 1.0), 0.0)
                .unwrap()
                .t
                - 1.0)
                .abs()
                < 1e-12
        );
        let t = Object::Terrain {
            origin: [-10.0, -2.0, -10.0],
            size: [20.0, 20.0],
            amplitude: 0.1,
            wavelength: 1.0,
            color: [1.0; 3],
        };
        let hit = t.intersect(DVec3::ZERO, DVec3::new(0.0, -1.0, 0.3), 0.0).unwrap();
        let p = hit.t * DVec3::new(0.0, -1.0, 0.3);
        assert!((p.y - (-2.0 + 0.1 * (p.x).sin() * (p.z).cos())).abs() < 1e-9);
    }
}
