//! Blending served strips into a novel view: DMesh Sec. 6.3-6.4 (epsilon-z-buffer,
//! per-view weights times per-vertex quality rho, normalisation) and Verlani
//! Sec. 3 (optional per-pixel `cos^k` of the angle between the reference and
//! novel rays).
//!
//! Pass 1 rasterises every selected view's triangles into one z-buffer
//! (nearest depth). Pass 2 rasterises them again and, for each fragment
//! within `eps_z` (relative) of that depth, accumulates `w_i * rho * colour`
//! and `w_i * rho`; the image is their ratio. Depth, rho and world position
//! are interpolated perspective-correctly (linear in `1/z` over the screen);
//! texture coordinates projectively, through the reference camera, so a
//! large triangle seen obliquely by its reference view still samples the
//! right texel. Seams of at most `fill_gaps` pixels are then filled from
//! their neighbours (`holes.rs`). Pixel `(x, y)` is the sample at integer
//! coordinates, as everywhere in dmesh; coverage follows the top-left rule so
//! a pixel on a shared edge is drawn once.
//!
//! A cut triangle of the compact stream (protocol 7) draws its parts as
//! triangles of their own, with vertices of their own on each side of the
//! cut: nothing spans the depth edge, as nothing spans a segmented cell.

use dmesh_engine::camera::Camera;
use dmesh_engine::mesh::{decode_strips, normals::oct_decode};
use dmesh_proto::StripResponse;
use glam::{DVec2, DVec3};

/// An 8-bit RGB texture (a reference view's colour image).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `3 * width * height` bytes.
    pub rgb: Vec<u8>,
}

impl Texture {
    /// Bilinear sample at pixel coordinates (integers are pixel centres).
    pub fn sample(&self, u: f64, v: f64) -> DVec3 {
        let (w, h) = (f64::from(self.width - 1), f64::from(self.height - 1));
        let (u, v) = (u.clamp(0.0, w), v.clamp(0.0, h));
        let (x0, y0) = (u.floor() as u32, v.floor() as u32);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = (u - f64::from(x0), v - f64::from(y0));
        let at = |x: u32, y: u32| {
            let i = 3 * (y * self.width + x) as usize;
            DVec3::new(
                f64::from(self.rgb[i]),
                f64::from(self.rgb[i + 1]),
                f64::from(self.rgb[i + 2]),
            )
        };
        let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
        let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// One selected view to blend.
#[derive(Clone, Copy)]
pub struct ViewInput<'a> {
    /// Its blending weight (the server's, summing to 1 over the views).
    pub weight: f64,
    /// Its strips.
    pub strips: &'a StripResponse,
    /// Its colour image.
    pub texture: &'a Texture,
}

impl<'a> ViewInput<'a> {
    /// The inputs of decoded responses held as (weight, strips, texture),
    /// in their order.
    pub fn of_responses(views: &'a [(f64, StripResponse, &'a Texture)]) -> Vec<Self> {
        views
            .iter()
            .map(|(weight, strips, texture)| ViewInput {
                weight: *weight,
                strips,
                texture,
            })
            .collect()
    }
}

/// Blending settings.
#[derive(Clone, Copy, Debug)]
pub struct BlendOptions {
    /// Fragments within `eps_z * z` of the nearest depth blend (DMesh's epsilon).
    pub eps_z: f64,
    /// Verlani's per-pixel `cos^k(theta)` weight, when set: `theta` is
    /// the angle at the surface point between the rays to the reference
    /// and to the novel eye.
    pub cos_k: Option<f64>,
    /// Verlani's alternative, `exp(-k theta)` with `theta` in radians, when
    /// set (with `cos_k` too, their product).
    pub exp_k: Option<f64>,
    /// Relighting with the vertex normals: a directional light (world) and
    /// its specular exponent; `None` keeps the textures' own shading.
    pub relight: Option<(DVec3, f64)>,
    /// Seams of at most this many pixels between covered pixels of one
    /// surface are filled from their neighbours ([`crate::holes`]); 0 leaves
    /// every hole.
    pub fill_gaps: u32,
}

/// Relative depth difference per pixel below which the two sides of a seam
/// are one surface (a floor seen at a grazing angle changes by a few per
/// cent per pixel; a pole before a wall by tens).
pub const FILL_DEPTH_TOLERANCE: f64 = 0.05;

impl Default for BlendOptions {
    fn default() -> Self {
        Self {
            eps_z: 0.01,
            cos_k: None,
            exp_k: None,
            relight: None,
            fill_gaps: 2,
        }
    }
}

/// A blended novel view.
#[derive(Clone, Debug)]
pub struct Blended {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGB; black where nothing is covered.
    pub rgb: Vec<u8>,
    /// Depth `z` in the novel camera; 0 where nothing is covered.
    pub depth: Vec<f32>,
    /// Bit `i` set where view `i` contributed (views past 31 share bit 31).
    pub coverage: Vec<u32>,
}

/// A triangle mesh of one reference view, in that view's pixels: what
/// [`blend_surfaces`] draws. [`blend`] makes one from each strip response;
/// the report's baselines make them from their own meshes, whose vertices
/// need not lie on the sample grid.
#[derive(Clone)]
pub struct Surface<'a> {
    /// The reference camera.
    pub camera: Camera,
    /// Blending weight of the view.
    pub weight: f64,
    /// Its colour image.
    pub texture: &'a Texture,
    /// Vertices.
    pub points: Vec<SurfacePoint>,
    /// Vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

/// A vertex of a [`Surface`].
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// Reference pixel column (integers are sample centres).
    pub u: f64,
    /// Reference pixel row.
    pub v: f64,
    /// Reference depth `z`.
    pub z: f64,
    /// Sampling quality in `[0, 1]`.
    pub rho: f64,
    /// Unit normal in the reference camera's frame.
    pub normal: DVec3,
}

impl<'a> Surface<'a> {
    /// The surface of a strip response, its cut triangles' parts included.
    pub fn from_strips(view: &ViewInput<'a>) -> anyhow::Result<Self> {
        let s = view.strips;
        let depths = s.decode_depths()?;
        let mut surface = Self {
            camera: Camera::try_from(&s.camera)?,
            weight: view.weight,
            texture: view.texture,
            points: s
                .vertices
                .iter()
                .zip(depths)
                .map(|(v, depth)| SurfacePoint {
                    u: f64::from(v.i),
                    v: f64::from(v.j),
                    z: f64::from(depth),
                    rho: f64::from(v.rho) / 255.0,
                    normal: oct_decode(v.normal),
                })
                .collect(),
            triangles: decode_strips(&s.indices.to_u32()),
        };
        for part in s.cuts.iter().flat_map(|c| c.parts()) {
            surface.push_part(part);
        }
        Ok(surface)
    }

    /// Adds one part of a cut triangle, `(u, v, z)` corners, with its own
    /// vertices: the part's plane's normal, turned to face the reference
    /// camera, and rho from it as `derived_normals` gives a vertex's.
    fn push_part(&mut self, part: [[f64; 3]; 3]) {
        let c = &self.camera;
        let p = part.map(|[u, v, z]| c.back_project(u, v, z));
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let ortho = matches!(c.projection, dmesh_engine::camera::Projection::Orthographic { .. });
        let first = self.points.len() as u32;
        for (k, &[u, v, z]) in part.iter().enumerate() {
            let ray = if ortho { DVec3::Z } else { p[k] };
            let nn = n.length() * ray.length();
            let (normal, rho) = if nn > 0.0 && nn.is_finite() {
                let facing = if n.dot(ray) > 0.0 { -n } else { n };
                (facing.normalize(), n.dot(ray).abs() / nn)
            } else {
                (-ray.normalize_or_zero(), 0.0)
            };
            self.points.push(SurfacePoint { u, v, z, rho, normal });
        }
        self.triangles.push([first, first + 1, first + 2]);
    }
}

struct Vertex {
    /// Screen position in the novel camera.
    s: DVec2,
    /// Novel-camera depth.
    z: f64,
    /// Homogeneous reference pixel `(i z_ref, j z_ref, z_ref)`: affine in
    /// space, so interpolating it and dividing gives the exact reference pixel
    /// of a point on the triangle (projective texturing), however oblique the
    /// reference view.
    uvz: DVec3,
    rho: f64,
    world: DVec3,
    normal: DVec3,
}

fn vertices(novel: &Camera, s: &Surface<'_>) -> Vec<Option<Vertex>> {
    let reference = &s.camera;
    s.points
        .iter()
        .map(|p| {
            let world = reference.to_world(reference.back_project(p.u, p.v, p.z));
            let (x, y, z) = novel.project(novel.to_camera(world))?;
            (z > 1e-9).then(|| Vertex {
                s: DVec2::new(x, y),
                z,
                uvz: DVec3::new(p.u, p.v, 1.0) * p.z,
                rho: p.rho,
                world,
                normal: reference.rotation * p.normal,
            })
        })
        .collect()
}

/// Calls `f(pixel index, perspective-correct barycentrics, depth)` for every
/// covered pixel of the triangle, top-left rule.
fn raster(w: u32, h: u32, t: [&Vertex; 3], mut f: impl FnMut(usize, [f64; 3], f64)) {
    let [mut a, mut b, c] = t;
    let edge = |p: DVec2, q: DVec2, r: DVec2| (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
    let mut area = edge(a.s, b.s, c.s);
    if area.abs() < 1e-12 || !area.is_finite() {
        return;
    }
    // Work counter-clockwise; hand the barycentrics back in the caller's order.
    let swapped = area < 0.0;
    if swapped {
        std::mem::swap(&mut a, &mut b);
        area = -area;
    }
    let (lo, hi) = (a.s.min(b.s).min(c.s), a.s.max(b.s).max(c.s));
    let (x0, y0) = (lo.x.ceil().max(0.0), lo.y.ceil().max(0.0));
    let (x1, y1) = (
        hi.x.floor().min(f64::from(w) - 1.0),
        hi.y.floor().min(f64::from(h) - 1.0),
    );
    if x0 > x1 || y0 > y1 {
        return;
    }
    // Top-left rule (y down, counter-clockwise after the swap): a pixel on an
    // edge belongs to the triangle only for top and left edges.
    let owns = |p: DVec2, q: DVec2| {
        let d = q - p;
        (d.y == 0.0 && d.x < 0.0) || d.y > 0.0
    };
    let verts = [a, b, c];
    for y in y0 as u32..=y1 as u32 {
        for x in x0 as u32..=x1 as u32 {
            let p = DVec2::new(f64::from(x), f64::from(y));
            let e = [edge(b.s, c.s, p), edge(c.s, a.s, p), edge(a.s, b.s, p)];
            let inside = e
                .iter()
                .zip([(b.s, c.s), (c.s, a.s), (a.s, b.s)])
                .all(|(&e, (p, q))| e > 0.0 || (e == 0.0 && owns(p, q)));
            if !inside {
                continue;
            }
            // Screen barycentrics, then perspective-correct ones.
            let l = [e[0] / area, e[1] / area, e[2] / area];
            let inv = [l[0] / verts[0].z, l[1] / verts[1].z, l[2] / verts[2].z];
            let sum = inv[0] + inv[1] + inv[2];
            if !(sum > 0.0 && sum.is_finite()) {
                continue;
            }
            let l = [inv[0] / sum, inv[1] / sum, inv[2] / sum];
            let l = if swapped { [l[1], l[0], l[2]] } else { l };
            f((y * w + x) as usize, l, 1.0 / sum);
        }
    }
}

/// Blends `views` into the `novel` camera's image.
pub fn blend(novel: &Camera, views: &[ViewInput<'_>], options: &BlendOptions) -> anyhow::Result<Blended> {
    let surfaces = views
        .iter()
        .map(Surface::from_strips)
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(blend_surfaces(novel, &surfaces, options))
}

/// Blends `surfaces` into the `novel` camera's image (what [`blend`] does
/// with strip responses).
pub fn blend_surfaces(novel: &Camera, surfaces: &[Surface<'_>], options: &BlendOptions) -> Blended {
    let (w, h) = (novel.width, novel.height);
    let n = (w * h) as usize;
    // Per view: vertices in the novel view.
    let prepared: Vec<Vec<Option<Vertex>>> = surfaces.iter().map(|s| vertices(novel, s)).collect();
    // Pass 1: nearest depth.
    let mut zbuf = vec![f64::INFINITY; n];
    for (verts, surface) in prepared.iter().zip(surfaces) {
        for t in &surface.triangles {
            let (Some(a), Some(b), Some(c)) = (&verts[t[0] as usize], &verts[t[1] as usize], &verts[t[2] as usize])
            else {
                continue;
            };
            raster(w, h, [a, b, c], |i, _, z| zbuf[i] = zbuf[i].min(z));
        }
    }
    // Pass 2: accumulate within epsilon of it.
    let mut color = vec![DVec3::ZERO; n];
    let mut weight = vec![0f64; n];
    let mut coverage = vec![0u32; n];
    let eye = novel.translation;
    for (k, (verts, view)) in prepared.iter().zip(surfaces).enumerate() {
        let reference = &view.camera;
        for t in &view.triangles {
            let (Some(a), Some(b), Some(c)) = (&verts[t[0] as usize], &verts[t[1] as usize], &verts[t[2] as usize])
            else {
                continue;
            };
            raster(w, h, [a, b, c], |i, l, z| {
                if z > zbuf[i] * (1.0 + options.eps_z) {
                    return;
                }
                let mix = |f: &dyn Fn(&Vertex) -> f64| l[0] * f(a) + l[1] * f(b) + l[2] * f(c);
                let h = a.uvz * l[0] + b.uvz * l[1] + c.uvz * l[2];
                let (u, v) = (h.x / h.z, h.y / h.z);
                let rho = mix(&|p| p.rho).max(1e-3);
                let mut wgt = view.weight * rho;
                let world = a.world * l[0] + b.world * l[1] + c.world * l[2];
                if options.cos_k.is_some() || options.exp_k.is_some() {
                    let to_ref = (reference.translation - world).normalize_or_zero();
                    let to_novel = (eye - world).normalize_or_zero();
                    let cos = to_ref.dot(to_novel).clamp(-1.0, 1.0);
                    if let Some(k) = options.cos_k {
                        wgt *= cos.max(0.0).powf(k);
                    }
                    if let Some(k) = options.exp_k {
                        wgt *= (-k * cos.acos()).exp();
                    }
                }
                let mut c3 = view.texture.sample(u, v);
                if let Some((light, shininess)) = options.relight {
                    let nrm = (a.normal * l[0] + b.normal * l[1] + c.normal * l[2]).normalize_or_zero();
                    let to_novel = (eye - world).normalize_or_zero();
                    let diffuse = nrm.dot(light).max(0.0);
                    let r = 2.0 * nrm.dot(light) * nrm - light;
                    // No highlight from a light behind the surface.
                    let specular = if nrm.dot(light) > 0.0 {
                        r.dot(to_novel).max(0.0).powf(shininess)
                    } else {
                        0.0
                    };
                    c3 = c3 * (0.3 + 0.7 * diffuse) + DVec3::splat(255.0 * 0.3 * specular);
                }
                color[i] += c3 * wgt;
                weight[i] += wgt;
                coverage[i] |= 1 << k.min(31);
            });
        }
    }
    let mut rgb = vec![0u8; 3 * n];
    let mut depth = vec![0f32; n];
    for i in 0..n {
        if weight[i] > 0.0 {
            let c = color[i] / weight[i];
            for (k, ch) in [c.x, c.y, c.z].into_iter().enumerate() {
                rgb[3 * i + k] = (ch.clamp(0.0, 255.0) + 0.5) as u8;
            }
            depth[i] = zbuf[i] as f32;
        }
    }
    crate::holes::fill_small_holes(w, h, &mut rgb, &mut depth, options.fill_gaps, FILL_DEPTH_TOLERANCE);
    Blended {
        width: w,
        height: h,
        rgb,
        depth,
        coverage,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dmesh_proto::{Lod, WireVertex};

    /// A fronto-parallel square at depth `z` filling a 16 x 16 reference
    /// view: two triangles over its corners.
    fn square(z: f32) -> StripResponse {
        let cam = Camera::perspective(16, 16, 16.0, 16.0, 7.5, 7.5).unwrap();
        let corner = |i: u16, j: u16| WireVertex {
            i,
            j,
            normal: [128, 128],
            rho: 255,
        };
        StripResponse {
            version: dmesh_proto::PROTOCOL_VERSION,
            scene: "s".into(),
            view: "v".into(),
            lod: Lod::Epsilon(0.0),
            camera: (&cam).into(),
            vertices: vec![corner(0, 0), corner(15, 0), corner(0, 15), corner(15, 15)],
            depths: dmesh_proto::Depths::Exact(vec![z; 4]),
            indices: dmesh_proto::Indices::U16(vec![0, 1, 2, 3]),
            triangles: 2,
            extract_ms: 0.0,
            reach: None,
            cuts: Vec::new(),
        }
    }

    /// The tests' 16 x 16 camera (f = 16 px) at a pose.
    fn camera(rotation: glam::DQuat, eye: DVec3) -> Camera {
        let p = dmesh_engine::camera::Projection::Perspective {
            fx: 16.0,
            fy: 16.0,
            cx: 7.5,
            cy: 7.5,
        };
        Camera::new(16, 16, p, rotation, eye).unwrap()
    }

    fn flat(value: u8) -> Texture {
        Texture {
            width: 16,
            height: 16,
            rgb: vec![value; 16 * 16 * 3],
        }
    }

    #[test]
    fn weights_normalise_per_pixel() {
        let novel = Camera::perspective(16, 16, 16.0, 16.0, 7.5, 7.5).unwrap();
        let (s, dark, light) = (square(2.0), flat(40), flat(200));
        let views = [
            ViewInput {
                weight: 0.25,
                strips: &s,
                texture: &dark,
            },
            ViewInput {
                weight: 0.75,
                strips: &s,
                texture: &light,
            },
        ];
        let b = blend(&novel, &views, &BlendOptions::default()).unwrap();
        let centre = 3 * (8 * 16 + 8);
        assert_eq!(b.rgb[centre], (0.25f64 * 40.0 + 0.75 * 200.0).round() as u8);
        assert_eq!(b.coverage[8 * 16 + 8], 0b11);
        assert!((f64::from(b.depth[8 * 16 + 8]) - 2.0).abs() < 1e-4);
        // Scaling every weight changes nothing: only ratios matter.
        let scaled = [
            ViewInput {
                weight: 2.5,
                ..views[0]
            },
            ViewInput {
                weight: 7.5,
                ..views[1]
            },
        ];
        assert_eq!(blend(&novel, &scaled, &BlendOptions::default()).unwrap().rgb, b.rgb);
    }

    /// The centre pixel's value of a blend of two views of the square at
    /// depth 2 whose strips are `a` and `b`, textures 40 and 200, equal
    /// weights.
    fn centre_of(a: &StripResponse, b: &StripResponse, options: &BlendOptions) -> f64 {
        let novel = Camera::perspective(16, 16, 16.0, 16.0, 7.5, 7.5).unwrap();
        let (dark, light) = (flat(40), flat(200));
        let views = [
            ViewInput {
                weight: 0.5,
                strips: a,
                texture: &dark,
            },
            ViewInput {
                weight: 0.5,
                strips: b,
                texture: &light,
            },
        ];
        f64::from(blend(&novel, &views, options).unwrap().rgb[3 * (8 * 16 + 8)])
    }

    /// DMesh Sec. 4.2: a sample's quality rho scales its view's weight, so a
    /// view that sees the surface edge-on counts less.
    #[test]
    fn quality_rho_scales_each_views_weight() {
        let mut oblique = square(2.0);
        for v in &mut oblique.vertices {
            v.rho = 64;
        }
        let got = centre_of(&square(2.0), &oblique, &BlendOptions::default());
        let rho = (1.0, 64.0 / 255.0);
        let want = (rho.0 * 40.0 + rho.1 * 200.0) / (rho.0 + rho.1);
        assert!((got - want).abs() <= 0.5, "{got} against {want}");
    }

    /// Verlani's per-pixel weight: a reference whose ray to the surface
    /// point makes the angle theta with the novel ray weighs cos^k(theta).
    #[test]
    fn cos_k_weighs_a_reference_by_its_angle_to_the_novel_ray() {
        // The plane z = 2 seen by a reference half a metre to the side: its
        // square still covers the novel view's centre.
        let side = camera(glam::DQuat::IDENTITY, DVec3::new(0.5, 0.0, 0.0));
        let mut shifted = square(2.0);
        shifted.camera = (&side).into();
        for (k, cos_k) in [(0.0, None), (4.0, Some(4.0)), (16.0, Some(16.0))] {
            let got = centre_of(
                &square(2.0),
                &shifted,
                &BlendOptions {
                    cos_k,
                    ..Default::default()
                },
            );
            // The centre pixel sees about (0.0625, 0.0625, 2): from the side
            // reference the ray turns by about atan(1 / 4).
            let p = DVec3::new(0.5 / 16.0 * 2.0, 0.5 / 16.0 * 2.0, 2.0);
            let cos = (side.translation - p).normalize().dot((DVec3::ZERO - p).normalize());
            let w = cos.powf(k);
            let want = (40.0 + w * 200.0) / (1.0 + w);
            assert!((got - want).abs() <= 1.0, "k {k}: {got} against {want}");
        }
    }

    /// Verlani's other weight, exp(-k theta), on the same two references.
    #[test]
    fn exp_k_weighs_a_reference_by_its_angle_to_the_novel_ray() {
        let side = camera(glam::DQuat::IDENTITY, DVec3::new(0.5, 0.0, 0.0));
        let mut shifted = square(2.0);
        shifted.camera = (&side).into();
        let p = DVec3::new(0.5 / 16.0 * 2.0, 0.5 / 16.0 * 2.0, 2.0);
        let theta = (side.translation - p)
            .normalize()
            .dot((DVec3::ZERO - p).normalize())
            .acos();
        for k in [0.0, 4.0, 16.0] {
            let got = centre_of(
                &square(2.0),
                &shifted,
                &BlendOptions {
                    exp_k: Some(k),
                    ..Default::default()
                },
            );
            let w = (-k * theta).exp();
            let want = (40.0 + w * 200.0) / (1.0 + w);
            assert!((got - want).abs() <= 1.0, "k {k}: {got} against {want}");
        }
    }

    /// Relighting with the vertex normals: lit head-on a surface keeps its
    /// texture, lit from behind it keeps the ambient 30 %.
    #[test]
    fn relighting_follows_the_normal_and_the_light() {
        let s = square(2.0);
        let lit = |light: DVec3| {
            let novel = Camera::perspective(16, 16, 16.0, 16.0, 7.5, 7.5).unwrap();
            let t = flat(200);
            let views = [ViewInput {
                weight: 1.0,
                strips: &s,
                texture: &t,
            }];
            let options = BlendOptions {
                relight: Some((light, 16.0)),
                ..Default::default()
            };
            f64::from(blend(&novel, &views, &options).unwrap().rgb[3 * (8 * 16 + 8)])
        };
        // A light along the square's normal lights it fully, one from the
        // opposite side not at all.
        let n = oct_decode([128, 128]);
        let (front, back) = (lit(n), lit(-n));
        assert!((back - 0.3 * 200.0).abs() <= 1.0, "from behind: {back}");
        assert!(front >= 200.0 - 1.0, "head-on: {front}");
    }

    #[test]
    fn epsilon_z_keeps_occluded_surfaces_out() {
        let novel = Camera::perspective(16, 16, 16.0, 16.0, 7.5, 7.5).unwrap();
        let (near, far) = (square(2.0), square(3.0));
        let (red, blue) = (flat(10), flat(250));
        let views = [
            ViewInput {
                weight: 0.1,
                strips: &near,
                texture: &red,
            },
            ViewInput {
                weight: 0.9,
                strips: &far,
                texture: &blue,
            },
        ];
        let b = blend(&novel, &views, &BlendOptions::default()).unwrap();
        // The far surface is hidden however heavy its view: only the near colour remains.
        assert_eq!(b.rgb[3 * (8 * 16 + 8)], 10);
        assert_eq!(b.coverage[8 * 16 + 8], 0b01);
        // With a tolerance wider than the gap both blend.
        let loose = blend(
            &novel,
            &views,
            &BlendOptions {
                eps_z: 1.0,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(loose.coverage[8 * 16 + 8], 0b11);
    }

    #[test]
    fn a_view_behind_the_camera_draws_nothing() {
        let novel = camera(glam::DQuat::from_rotation_y(std::f64::consts::PI), DVec3::ZERO);
        let (s, t) = (square(2.0), flat(99));
        let b = blend(
            &novel,
            &[ViewInput {
                weight: 1.0,
                strips: &s,
                texture: &t,
            }],
            &BlendOptions::default(),
        )
        .unwrap();
        assert!(b.coverage.iter().all(|&c| c == 0));
    }
}
