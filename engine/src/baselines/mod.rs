//! The thesis's baseline depth-map meshers beside the restricted quadtree:
//! Naik, "3D mesh simplification techniques for enhanced image based
//! rendering" (2017), Ch. 5 (the meshers) and Ch. 6 (the protocol that
//! compares them).
//!
//! Every mesher takes a depth image and its camera and returns indexed
//! triangles over reference-pixel positions and depths ([`TriMesh`]). One
//! knob sets its coarseness ([`Knob`]); [`drive`] finds the setting that
//! meets a requested number of triangles. The reduction rate of Naik Sec. 6.2
//! is the full-resolution mesh's triangles ([`full_mesh`]) over the
//! triangles kept.
//!
//! | mesher | file | Naik |
//! |---|---|---|
//! | every n-th sample, discontinuous edges dropped | `decimate.rs` | Sec. 5.2.1 |
//! | the same on the median of each sample's block | `median_decimate.rs` | Sec. 5.2.1 |
//! | shortest-edge collapse to the midpoint | `remesh.rs` | Sec. 5.2.2 |
//! | quadric error simplification (meshoptimizer) | `qem.rs` | Sec. 5.2.3 |
//! | quadtree of constant blocks | `quadtree_constant.rs` | Sec. 5.2.4 |
//! | quadtree of plane-fit blocks | `quadtree_plane.rs` | Sec. 5.2.5 |
//! | the restricted quadtree, as served and refined at discontinuities | `rqt.rs` | DMesh Sec. 3-5 |

pub mod decimate;
mod drive;
pub mod median_decimate;
#[cfg(feature = "qem")]
pub mod qem;
pub mod quadtree_constant;
pub mod quadtree_plane;
pub mod remesh;
pub mod rqt;

pub use drive::{drive, Driven, FALLBACK_MISS};

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::image::DepthImage;

/// An indexed triangle mesh of one depth image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// `[u, v, z]`: reference pixel (integers are sample centres, not
    /// necessarily integral; from 0 to half a pixel past the last sample)
    /// and depth `z` in metres, finite and positive.
    pub vertices: Vec<[f32; 3]>,
    /// Vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Checks what every mesher promises: finite positive depths, positions
    /// inside the image's pixels, indices in range, no triangle repeating a
    /// vertex.
    pub fn validate(&self, width: u32, height: u32) -> Result<()> {
        // A cut outline ends half a sample past its last sample, at the
        // image border too (`mesh/cut.rs`): the last pixel's far edge.
        let (w, h) = (width as f32 - 0.5, height as f32 - 0.5);
        for (k, &[u, v, z]) in self.vertices.iter().enumerate() {
            let inside = (0.0..=w).contains(&u) && (0.0..=h).contains(&v);
            if !(inside && z.is_finite() && z > 0.0) {
                return Err(Error::invalid(format!("vertex {k} is ({u}, {v}, {z})")));
            }
        }
        let n = self.vertices.len() as u32;
        for (k, t) in self.triangles.iter().enumerate() {
            if t.iter().any(|&i| i >= n) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(Error::invalid(format!("triangle {k} is {t:?} over {n} vertices")));
            }
        }
        Ok(())
    }

    /// Drops vertices no triangle uses, renumbering the triangles.
    pub fn compact(mut self) -> Self {
        let mut map = vec![u32::MAX; self.vertices.len()];
        let mut vertices = Vec::new();
        for t in &mut self.triangles {
            for i in t.iter_mut() {
                let m = &mut map[*i as usize];
                if *m == u32::MAX {
                    *m = vertices.len() as u32;
                    vertices.push(self.vertices[*i as usize]);
                }
                *i = *m;
            }
        }
        self.vertices = vertices;
        self
    }
}

/// How a mesher's coarseness is set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Knob {
    /// The knob is the number of triangles wanted.
    Triangles,
    /// A threshold in `[lo, hi]` (both positive): larger keeps fewer
    /// triangles; [`drive`] searches it.
    Coarser {
        /// Finest setting.
        lo: f64,
        /// Coarsest setting.
        hi: f64,
    },
}

/// A depth-map mesher of the comparison.
pub trait Mesher: Sync {
    /// Its name in tables and plots.
    fn name(&self) -> &'static str;
    /// What its knob is, with the unit.
    fn knob_name(&self) -> String;
    /// What its knob means for `depth`.
    fn knob(&self, depth: &DepthImage) -> Knob;
    /// Meshes `depth`, seen by `camera`, at knob setting `knob`.
    fn mesh(&self, depth: &DepthImage, camera: &Camera, knob: f64) -> Result<TriMesh>;
    /// For a mesher whose work splits into a part done once per depth image
    /// and a part per level of detail (the RQT: hierarchy, then
    /// extraction), the wall-clock milliseconds of the second part at
    /// `knob`; `None` for the others, which redo everything per level.
    fn per_level_ms(&self, _depth: &DepthImage, _camera: &Camera, _knob: f64) -> Result<Option<f64>> {
        Ok(None)
    }
    /// The same mesher with another knob, which [`drive`] tries when this
    /// one misses the count by more than [`FALLBACK_MISS`].
    fn fallback(&self) -> Option<Box<dyn Mesher>> {
        None
    }
}

/// Every mesher of the comparison, the restricted quadtree first (as the
/// service extracts it, keeping outlines; then dropping the coarse
/// triangles a discontinuity crosses as DMesh Sec. 5.3 does; then cutting
/// them along the discontinuity, `mesh/cut.rs`; then as served, but
/// segmented by the baselines' own cut, [`shared_cut`]).
pub fn all() -> Vec<Box<dyn Mesher>> {
    vec![
        Box::new(rqt::Rqt::default()),
        Box::new(rqt::Rqt {
            outlines: crate::mesh::Outlines::Dropped,
            ..rqt::Rqt::default()
        }),
        Box::new(rqt::Rqt {
            outlines: crate::mesh::Outlines::Cut,
            ..rqt::Rqt::default()
        }),
        Box::new(rqt::Rqt {
            segmentation: shared_cut(),
            ..rqt::Rqt::default()
        }),
        Box::new(decimate::Decimate),
        Box::new(median_decimate::MedianDecimate),
        Box::new(remesh::Remesh),
        #[cfg(feature = "qem")]
        Box::new(qem::Qem),
        Box::new(quadtree_constant::QuadtreeConstant),
        Box::new(quadtree_plane::QuadtreePlane),
    ]
}

/// Relative depth jump between two neighbouring samples above which the
/// edge between them crosses a discontinuity and is not meshed, the
/// baselines' cut (Naik Sec. 5.2.1 drops triangles whose disparities
/// differ). A slanted surface changes by a few per cent per pixel; an object
/// before its background by tens.
pub const JUMP: f32 = 0.1;

/// The baselines' cut as the RQT's segmentation: Eq. 11's gate alone at
/// [`JUMP`] (orthogonality at 90 degrees flags every triangle the gate
/// lets through), so a full-resolution triangle is cut exactly when two of
/// its corners are [`discontinuous`].
pub fn shared_cut() -> crate::mesh::Segmentation {
    crate::mesh::Segmentation {
        method: crate::mesh::Method::Orthogonality { omega_deg: 90.0 },
        lambda: f64::from(JUMP),
    }
}

/// True when samples of depths `a` and `b` (both valid) are not one surface.
pub fn discontinuous(a: f32, b: f32) -> bool {
    (a - b).abs() > JUMP * a.min(b)
}

/// The two triangles of the quad `[top-left, top-right, bottom-left,
/// bottom-right]` (vertex indices, depths), each kept when its three samples
/// are valid and no edge crosses a discontinuity.
pub(crate) fn quad(out: &mut Vec<[u32; 3]>, idx: [u32; 4], z: [f32; 4]) {
    let [a, b, c, d] = idx;
    for (t, zs) in [([a, b, d], [z[0], z[1], z[3]]), ([a, d, c], [z[0], z[3], z[2]])] {
        let valid = zs.iter().all(|&z| z > 0.0);
        if valid && !discontinuous(zs[0], zs[1]) && !discontinuous(zs[1], zs[2]) && !discontinuous(zs[0], zs[2]) {
            out.push(t);
        }
    }
}

/// Where the full-resolution depth is not one surface: a grid cell is
/// *broken* when a corner is invalid or one of its sides or its diagonal
/// crosses a discontinuity. Summed-area tables answer whether a block of
/// cells holds a broken cell, or an invalid sample, so the baselines that
/// triangulate blocks larger than a cell (decimation, the plane-fit
/// quadtree) drop the blocks a discontinuity crosses (Naik Sec. 5.2.1 and
/// 5.2.4: "faces with discontinuous edges" are left out).
pub struct Cuts {
    cols: usize,
    /// `(cols + 1) * (rows + 1)` prefix sums of broken cells.
    broken: Vec<u32>,
    /// The same of cells with an invalid corner.
    invalid: Vec<u32>,
}

impl Cuts {
    /// The broken cells of `depth`.
    pub fn new(depth: &DepthImage) -> Self {
        let (w, h) = (depth.width as usize, depth.height as usize);
        let (cols, rows) = (w - 1, h - 1);
        let mut broken = vec![0u32; (cols + 1) * (rows + 1)];
        let mut invalid = broken.clone();
        for y in 0..rows {
            let (mut run_broken, mut run_invalid) = (0, 0);
            for x in 0..cols {
                let z = [
                    depth.z[y * w + x],
                    depth.z[y * w + x + 1],
                    depth.z[(y + 1) * w + x],
                    depth.z[(y + 1) * w + x + 1],
                ];
                let hole = z.iter().any(|&z| z <= 0.0);
                let jump = [(0, 1), (0, 2), (1, 3), (2, 3), (0, 3)]
                    .iter()
                    .any(|&(a, b)| discontinuous(z[a], z[b]));
                run_broken += u32::from(hole || jump);
                run_invalid += u32::from(hole);
                let (at, above) = ((y + 1) * (cols + 1) + x + 1, y * (cols + 1) + x + 1);
                broken[at] = broken[above] + run_broken;
                invalid[at] = invalid[above] + run_invalid;
            }
        }
        Self { cols, broken, invalid }
    }

    fn count(&self, sums: &[u32], x0: u32, y0: u32, x1: u32, y1: u32) -> bool {
        let s = |x: u32, y: u32| sums[y as usize * (self.cols + 1) + x as usize];
        s(x1, y1) + s(x0, y0) == s(x0, y1) + s(x1, y0)
    }

    /// True when no cell between sample columns `x0..x1` and rows `y0..y1` is broken.
    pub fn clean(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> bool {
        self.count(&self.broken, x0, y0, x1, y1)
    }

    /// True when every sample of columns `x0..=x1` and rows `y0..=y1` is valid.
    pub fn valid(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> bool {
        self.count(&self.invalid, x0, y0, x1, y1)
    }
}

/// The mesh over the samples at columns `xs` and rows `ys` (increasing),
/// with depths from `z(x, y)`: two triangles per quad. A one-cell quad loses
/// the triangles that touch an invalid sample or cross a discontinuity; a
/// larger one is dropped whole when `cuts` finds a broken cell inside.
pub(crate) fn grid_mesh(xs: &[u32], ys: &[u32], cuts: &Cuts, z: impl Fn(u32, u32) -> f32) -> TriMesh {
    let (nx, ny) = (xs.len(), ys.len());
    let mut depths = Vec::with_capacity(nx * ny);
    let mut vertices = Vec::with_capacity(nx * ny);
    for &y in ys {
        for &x in xs {
            let zz = z(x, y);
            depths.push(zz);
            vertices.push([x as f32, y as f32, zz.max(0.0)]);
        }
    }
    let mut triangles = Vec::with_capacity(2 * nx * ny);
    for r in 0..ny.saturating_sub(1) {
        for c in 0..nx.saturating_sub(1) {
            let i = (r * nx + c) as u32;
            let idx = [i, i + 1, i + nx as u32, i + nx as u32 + 1];
            let zs = idx.map(|i| depths[i as usize]);
            let (x0, x1, y0, y1) = (xs[c], xs[c + 1], ys[r], ys[r + 1]);
            if x1 - x0 == 1 && y1 - y0 == 1 {
                quad(&mut triangles, idx, zs);
            } else if cuts.clean(x0, y0, x1, y1) && zs.iter().all(|&z| z > 0.0) {
                triangles.extend([[idx[0], idx[1], idx[3]], [idx[0], idx[3], idx[2]]]);
            }
        }
    }
    TriMesh { vertices, triangles }.compact()
}

/// The full-resolution mesh: every sample, two triangles per grid cell, cut
/// at discontinuities and invalid samples. Remeshing and QEM start from it,
/// and its triangle count is the numerator of the reduction rate.
pub fn full_mesh(depth: &DepthImage) -> TriMesh {
    let xs: Vec<u32> = (0..depth.width).collect();
    let ys: Vec<u32> = (0..depth.height).collect();
    let w = depth.width as usize;
    grid_mesh(&xs, &ys, &Cuts::new(depth), |x, y| depth.z[y as usize * w + x as usize])
}

/// The leaves of a quadtree over the cells of `depth` (Naik Alg. 1): from
/// one square block of a power-of-two size (clipped to the image), a block
/// larger than a cell is kept when all its samples are valid ([`Cuts`]) and
/// `accept(x0, y0, x1, y1)` says so, and is split in four otherwise. Calls
/// `leaf` with the sample bounds of every kept block and every single cell
/// reached.
pub(crate) fn quadtree(
    depth: &DepthImage,
    cuts: &Cuts,
    mut accept: impl FnMut(u32, u32, u32, u32) -> bool,
    mut leaf: impl FnMut(u32, u32, u32, u32),
) {
    let (cols, rows) = (depth.width - 1, depth.height - 1);
    let mut stack = vec![(0u32, 0u32, cols.max(rows).next_power_of_two())];
    while let Some((x0, y0, size)) = stack.pop() {
        if x0 >= cols || y0 >= rows {
            continue;
        }
        let (x1, y1) = ((x0 + size).min(cols), (y0 + size).min(rows));
        if size == 1 || (cuts.valid(x0, y0, x1, y1) && accept(x0, y0, x1, y1)) {
            leaf(x0, y0, x1, y1);
            continue;
        }
        let half = size / 2;
        for (dx, dy) in [(0, 0), (half, 0), (0, half), (half, half)] {
            stack.push((x0 + dx, y0 + dy, half));
        }
    }
}

impl Knob {
    /// A step between kept samples, from 1 (every sample) to the image
    /// size: the two decimations' knob.
    pub(crate) fn step(depth: &DepthImage) -> Self {
        Self::Coarser {
            lo: 1.0,
            hi: f64::from(depth.width.max(depth.height)),
        }
    }

    /// An inverse-depth threshold, 1/m, from a ten-millionth of the largest
    /// minus the smallest inverse depth of the valid samples to all of it
    /// (Naik's thresholds are fractions of the disparity range): the two
    /// quadtrees' knob.
    pub(crate) fn inverse_depth(depth: &DepthImage) -> Self {
        let (lo, hi) = depth
            .z
            .iter()
            .filter(|&&z| z > 0.0)
            .fold((f64::INFINITY, 0f64), |(lo, hi), &z| {
                let d = 1.0 / f64::from(z);
                (lo.min(d), hi.max(d))
            });
        let range = if hi > lo { hi - lo } else { 1.0 };
        Self::Coarser {
            lo: range * 1e-7,
            hi: range,
        }
    }
}

/// `n + 1` increasing sample positions over `0..=last` at spacing `step`
/// (rounded to samples, the last one always included).
pub(crate) fn positions(last: u32, step: f64) -> Vec<u32> {
    let step = step.max(1.0);
    let mut out: Vec<u32> = Vec::new();
    let mut k = 0.0f64;
    loop {
        let p = (k * step).round().min(f64::from(last)) as u32;
        if out.last() != Some(&p) {
            out.push(p);
        }
        if p >= last {
            break;
        }
        k += 1.0;
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The RQT given the baselines' cut segments a full-resolution triangle
    /// exactly when two of its corners are `discontinuous`.
    #[test]
    fn the_shared_cut_is_the_baselines_rule() {
        let (w, h) = (23u32, 17u32);
        let mut s = 7u64;
        let z: Vec<f32> = (0..w * h)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                // Steps of 0-30 % between neighbours, some past the cut.
                1.0 + (s >> 40) as f32 / (1u64 << 24) as f32 * 0.3
            })
            .collect();
        let depth = DepthImage::from_z(w, h, z.clone()).unwrap();
        let camera = Camera::perspective(w, h, 30.0, 30.0, 11.0, 8.0).unwrap();
        let hier = crate::mesh::Hierarchy::build(&depth, &camera, &shared_cut()).unwrap();
        let (mut cut, mut kept) = (0, 0);
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                for half in 0..2 {
                    let zs = hier
                        .grid()
                        .cell_triangle((x, y), half)
                        .map(|(u, v)| z[v as usize * w as usize + u as usize]);
                    let jump = [(0, 1), (1, 2), (0, 2)]
                        .iter()
                        .any(|&(i, j)| discontinuous(zs[i], zs[j]));
                    assert_eq!(
                        hier.cell_segmented((x, y), half),
                        jump,
                        "cell ({x}, {y}) half {half}: {zs:?}"
                    );
                    if jump {
                        cut += 1;
                    } else {
                        kept += 1;
                    }
                }
            }
        }
        assert!(cut > 50 && kept > 50, "{cut} {kept}");
    }

    /// A tilted plane seen by a pinhole camera: `1/z` affine in the pixel.
    pub(crate) fn tilted_plane(width: u32, height: u32) -> (DepthImage, Camera) {
        let camera = Camera::perspective(
            width,
            height,
            80.0,
            80.0,
            f64::from(width) / 2.0,
            f64::from(height) / 2.0,
        )
        .expect("camera");
        let z = (0..height)
            .flat_map(|v| (0..width).map(move |u| 1.0 / (0.4 + 0.002 * f64::from(u) + 0.001 * f64::from(v)) as f32))
            .collect();
        (DepthImage::from_z(width, height, z).expect("depth"), camera)
    }

    /// Boxes before a slanted floor with a hole of invalid samples: planes,
    /// discontinuities and missing data.
    pub(crate) fn boxes(width: u32, height: u32) -> (DepthImage, Camera) {
        let (mut depth, camera) = crate::synthetic::terrain_with_boxes(width, height);
        for y in height / 3..height / 3 + 4 {
            for x in width / 5..width / 5 + 6 {
                depth.z[(y * width + x) as usize] = 0.0;
            }
        }
        (depth, camera)
    }

    /// Area of the mesh's triangles in the image plane.
    pub(crate) fn image_area(m: &TriMesh) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let p = t.map(|i| m.vertices[i as usize]);
                let (ax, ay) = (f64::from(p[1][0] - p[0][0]), f64::from(p[1][1] - p[0][1]));
                let (bx, by) = (f64::from(p[2][0] - p[0][0]), f64::from(p[2][1] - p[0][1]));
                0.5 * (ax * by - ay * bx).abs()
            })
            .sum()
    }

    /// Largest relative error of the vertices' depths against the plane of
    /// [`tilted_plane`] (a flat triangle through three points of a plane
    /// lies on it).
    pub(crate) fn plane_error(m: &TriMesh) -> f64 {
        m.vertices
            .iter()
            .map(|&[u, v, z]| {
                let want = 1.0 / (0.4 + 0.002 * f64::from(u) + 0.001 * f64::from(v));
                (f64::from(z) / want - 1.0).abs()
            })
            .fold(0.0, f64::max)
    }

    /// What every mesher must do: meet `rates` within 10 % on the boxes,
    /// return valid meshes, and be exact over the whole image on the tilted
    /// plane (`planes`: false for a mesher that is exact only on a
    /// fronto-parallel plane).
    pub(crate) fn check_mesher(mesher: &dyn Mesher, planes: bool, rates: &[f64]) {
        let (depth, camera) = boxes(160, 120);
        let full = full_mesh(&depth).triangles.len();
        for &rate in rates {
            let want = (full as f64 / rate).round() as usize;
            let got = drive(mesher, &depth, &camera, want).expect("mesh");
            got.mesh.validate(depth.width, depth.height).expect("valid");
            let n = got.mesh.triangles.len() as f64;
            assert!(
                (n / want as f64 - 1.0).abs() <= 0.1,
                "{} at rate {rate}: {n} triangles for {want}",
                mesher.name()
            );
        }
        let (plane, camera) = tilted_plane(97, 65);
        let flat = DepthImage::from_z(97, 65, vec![2.5; 97 * 65]).expect("flat");
        let area = 96.0 * 64.0;
        for (depth, tilted) in [(&plane, true), (&flat, false)] {
            if tilted && !planes {
                continue;
            }
            let want = full_mesh(depth).triangles.len() / 10;
            let got = drive(mesher, depth, &camera, want).expect("mesh");
            got.mesh.validate(depth.width, depth.height).expect("valid");
            let covered = image_area(&got.mesh);
            assert!(
                (covered - area).abs() < 1e-3 * area,
                "{} covers {covered} of {area} on a plane",
                mesher.name()
            );
            let error = if tilted {
                plane_error(&got.mesh)
            } else {
                got.mesh
                    .vertices
                    .iter()
                    .map(|v| f64::from((v[2] - 2.5).abs()))
                    .fold(0.0, f64::max)
            };
            assert!(error < 1e-5, "{} is {error} off the plane", mesher.name());
        }
    }

    #[test]
    fn the_full_mesh_cuts_discontinuities_and_holes() {
        let z = vec![
            1.0, 1.0, 1.0, 2.0, //
            1.0, 1.0, 1.0, 2.0, //
            1.0, 0.0, 1.0, 2.0,
        ];
        let m = full_mesh(&DepthImage::from_z(4, 3, z).expect("depth"));
        // The right column of cells crosses the 1 -> 2 jump: nothing there.
        m.validate(4, 3).expect("valid");
        for t in &m.triangles {
            let zs = t.map(|i| m.vertices[i as usize][2]);
            assert!(zs.iter().all(|&z| z == 1.0), "{zs:?}");
        }
        // Row 0: 2 + 2 triangles; row 1: both triangles of the first cell
        // touch the hole, the second cell keeps the one that does not.
        assert_eq!(m.triangles.len(), 5);
        assert_eq!(m.vertices.len(), 7);
    }

    #[test]
    fn positions_cover_the_range_at_the_step() {
        assert_eq!(positions(10, 1.0), (0..=10).collect::<Vec<_>>());
        assert_eq!(positions(10, 3.0), vec![0, 3, 6, 9, 10]);
        assert_eq!(positions(10, 2.5), vec![0, 3, 5, 8, 10]);
        assert_eq!(positions(10, 50.0), vec![0, 10]);
    }
}
