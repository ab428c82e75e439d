//! Rubber-sheet segmentation of the full-resolution triangles, DMesh Sec. 5.2.
//!
//! Each finest triangle (two per unit cell) is flagged when
//! - any of its corners is an invalid sample (always), or
//! - the chosen test says it spans a discontinuity **and** its depth range
//!   passes the gate of Eq. 11, `dz / z > lambda` (`z` the nearest corner's depth):
//!   - **orthogonality** (Eq. 10): `|v/|v| . n_t| < cos(90 deg - omega)`, with `v` the
//!     direction from the reference camera to the triangle's centroid (the
//!     optical axis for an orthographic camera), written without division as
//!     `(v . n)^2 < sin^2(omega) |v|^2 |n|^2`;
//!   - **disparity** (Eq. 9): a corner is a discontinuity when
//!     `|(z1 - z2)/z1 - (z2 - z3)/z3| > sigma` along its row or its column;
//!     the triangle is flagged when two or more corners are;
//!   - **connectedness** (Eq. 5-6): for each axis-aligned leg `P1-P2`, the
//!     quadratic through `P1` with the normals' slopes as derivatives,
//!     evaluated at the edge length (Fig. 9b), misses `P2` by
//!     `r = |f(x2) - z2| / x2`; the triangle is flagged when a leg has
//!     `r > kappa`. A normal seen exactly edge-on (infinite slope) counts as
//!     disconnected.
//!
//! Flags are propagated up the hierarchy by `hierarchy.rs` (Sec. 5.3).

use glam::DVec3;

use super::backproject::BackProject;
use super::grid::{Grid, Pt};
use super::normals::oct_decode;
use crate::camera::Camera;
use crate::error::{Error, Result};

/// The discontinuity test applied to full-resolution triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Only triangles touching invalid samples are removed.
    None,
    /// Eq. 10 with threshold angle `omega_deg` in degrees.
    Orthogonality {
        /// Angle between the triangle plane and the view ray below which it is a rubber sheet.
        omega_deg: f64,
    },
    /// Eq. 9 with threshold `sigma`.
    Disparity {
        /// Threshold on the normalised second difference of depth.
        sigma: f64,
    },
    /// Eq. 6 with threshold `kappa` (1.0 flags real surfaces only past about 63 degrees).
    Connectedness {
        /// Threshold on the fitted-curve miss ratio.
        kappa: f64,
    },
}

/// Segmentation settings: a method and the depth-range gate `lambda` of Eq. 11.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segmentation {
    /// The discontinuity test.
    pub method: Method,
    /// Only triangles with `dz / z > lambda` can be removed by the test.
    pub lambda: f64,
}

/// Default orthogonality angle, degrees (DMesh's choice).
pub const OMEGA_DEG: f64 = 5.0;
/// Default disparity threshold (Eq. 9).
pub const SIGMA: f64 = 0.05;
/// Default connectedness threshold (Eq. 6).
pub const KAPPA: f64 = 1.0;
/// Default depth-range gate `dz / z` (Eq. 11).
pub const LAMBDA: f64 = 0.02;

impl Default for Segmentation {
    /// Orthogonality at [`OMEGA_DEG`], gated by [`LAMBDA`].
    fn default() -> Self {
        Self {
            method: Method::Orthogonality { omega_deg: OMEGA_DEG },
            lambda: LAMBDA,
        }
    }
}

impl Segmentation {
    /// Checks the thresholds: finite, `omega` in `[0, 90]`, others `>= 0`.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &str, v: f64, accepted: &str| {
            Err(Error::invalid(format!(
                "segmentation {name} is {}; it must be {accepted}",
                crate::error::Shown(v)
            )))
        };
        if !(self.lambda.is_finite() && self.lambda >= 0.0) {
            return bad("lambda", self.lambda, "a finite number >= 0");
        }
        match self.method {
            Method::Orthogonality { omega_deg } if !(0.0..=90.0).contains(&omega_deg) => {
                bad("omega", omega_deg, "between 0 and 90 degrees")
            }
            Method::Disparity { sigma } if !(sigma.is_finite() && sigma >= 0.0) => {
                bad("sigma", sigma, "a finite number >= 0")
            }
            Method::Connectedness { kappa } if !(kappa.is_finite() && kappa >= 0.0) => {
                bad("kappa", kappa, "a finite number >= 0")
            }
            _ => Ok(()),
        }
    }
}

/// Everything the leaf tests read.
pub(crate) struct Samples<'a> {
    pub grid: &'a Grid,
    pub camera: &'a Camera,
    pub bp: &'a BackProject,
    pub z: &'a [f32],
    pub normals: &'a [[u8; 2]],
}

/// Flags the two finest triangles of every unit cell: bit `h` of the
/// returned byte per cell (indexed like its min corner) is half `h`.
pub(crate) fn leaf_flags(s: &Samples<'_>, seg: &Segmentation) -> Vec<u8> {
    let mut out = vec![0u8; s.grid.len()];
    leaf_flag_rows(s, seg, 0..s.grid.gh(), &mut out);
    out
}

/// Whether [`leaf_flag_rows`] of a band of rows reads only the depths (and
/// no marks computed over the whole image, nor normals): whether the rows
/// can be split between threads.
pub(crate) fn rows_split(seg: &Segmentation) -> bool {
    matches!(seg.method, Method::None | Method::Orthogonality { .. })
}

crate::simd::dispatch! {
    /// [`leaf_flags`] of the cells of the grid rows `rows` (the last grid
    /// row has none: 0), into `out`, which holds those rows, zeroed (each
    /// caller's fresh allocation: filled again here, they were written
    /// twice).
    pub(crate) fn leaf_flag_rows(s: &Samples<'_>, seg: &Segmentation, rows: std::ops::Range<u32>, out: &mut [u8]) -> () = leaf_flag_rows_body;
}

#[inline(always)]
fn leaf_flag_rows_body(s: &Samples<'_>, seg: &Segmentation, rows: std::ops::Range<u32>, out: &mut [u8]) {
    let grid = s.grid;
    let gw = grid.gw();
    let disparity_marks = match seg.method {
        Method::Disparity { sigma } => Some(disparity_discontinuities(s, sigma)),
        _ => None,
    };
    let sin2 = match seg.method {
        Method::Orthogonality { omega_deg } => omega_deg.to_radians().sin().powi(2),
        _ => 0.0,
    };
    let (w, lambda) = (gw as usize, seg.lambda);
    let first = grid.index((0, rows.start));
    debug_assert!(out[..rows.len() * w].iter().all(|&c| c == 0), "leaf flags written over");
    // Per row, first the cells whose four corners are valid and span too
    // little depth for Eq. 11 (both triangles unsegmented: most cells), in
    // a branch-free loop over whole rows that vectorises; then the rest.
    let mut quiet = vec![0u8; w - 1];
    for y in rows.start..rows.end.min(grid.gh() - 1) {
        let i0 = grid.index((0, y));
        let (top, bottom) = (&s.z[i0..i0 + w], &s.z[i0 + w..i0 + 2 * w]);
        for ((q, t), b) in quiet.iter_mut().zip(top.windows(2)).zip(bottom.windows(2)) {
            let lo = t[0].min(t[1]).min(b[0].min(b[1]));
            let hi = t[0].max(t[1]).max(b[0].max(b[1]));
            *q = u8::from(lo > 0.0 && f64::from(hi) - f64::from(lo) <= lambda * f64::from(lo));
        }
        // Blocks of quiet cells are passed over whole: an `and` of the
        // block's bytes, without branches, where a test per cell costs
        // about as much as the loop above.
        for (block, cells) in quiet.chunks(BLOCK).enumerate() {
            if cells.iter().fold(1, |all, &q| all & q) == 1 {
                continue;
            }
            for (k, _) in cells.iter().enumerate().filter(|&(_, &q)| q == 0) {
                let x = (block * BLOCK + k) as u32;
                out[grid.index((x, y)) - first] = cell_flags(s, seg, sin2, disparity_marks.as_deref(), (x, y));
            }
        }
    }
}

crate::simd::dispatch! {
    /// The full-resolution triangles of the image that the leaf flags
    /// `cells` ([`leaf_flags`]) segment, one bit each; the padding's cells
    /// are left out. With AVX2 where the CPU has it (without, the bytes'
    /// bit counts are a sequence of shifts each: 2.6 ms at 1920 x 1080 on
    /// a 2 GHz Zen 1).
    pub(crate) fn segmented_count(grid: &Grid, cells: &[u8]) -> usize = segmented_count_body;
}

#[inline(always)]
fn segmented_count_body(grid: &Grid, cells: &[u8]) -> usize {
    let (gw, cells_per_row) = (grid.gw() as usize, grid.width as usize - 1);
    cells
        .chunks(gw)
        .take(grid.height as usize - 1)
        .map(|row| row[..cells_per_row].iter().map(|c| c.count_ones()).sum::<u32>() as usize)
        .sum()
}

/// The leaf flags of `cell`: bit `t` set where its triangle `t` is
/// segmented (`marks`: the disparity discontinuities, for that method).
#[inline(always)]
fn cell_flags(s: &Samples<'_>, seg: &Segmentation, sin2: f64, marks: Option<&[bool]>, cell: Pt) -> u8 {
    let grid = s.grid;
    let mut bits = 0u8;
    for half in 0..2 {
        // Arrays written out, not built by `map`: its closure, left out of
        // line by some partitions of the crate, ran without AVX2 and cost
        // the leaf flags a quarter of their time.
        let corners = grid.cell_triangle(cell, half);
        let at = |i: usize| s.z[grid.index(corners[i])];
        let zs = [at(0), at(1), at(2)];
        // Invalid corners always segment; the cheap gate of Eq. 11 comes
        // before any back-projection, since most triangles fail it.
        let flagged = zs.iter().any(|&zz| zz <= 0.0)
            || (gate(zs, seg.lambda) && {
                let p = |i: usize| s.bp.point(corners[i].0, corners[i].1, zs[i]);
                let pts = [p(0), p(1), p(2)];
                match seg.method {
                    Method::None => false,
                    Method::Orthogonality { .. } => orthogonal(s.camera, pts, sin2),
                    Method::Disparity { .. } => {
                        // Computed by the caller for exactly this method.
                        debug_assert!(marks.is_some(), "disparity marks missing");
                        let marks = marks.unwrap_or_default();
                        corners
                            .iter()
                            .filter(|&&c| marks.get(grid.index(c)).copied().unwrap_or(false))
                            .count()
                            >= 2
                    }
                    Method::Connectedness { kappa } => {
                        // Legs run from the apex (index 2) to each diagonal end.
                        let n = |i: usize| oct_decode(s.normals[grid.index(corners[i])]);
                        disconnected(s.camera, pts[2], pts[0], n(2), n(0), kappa)
                            || disconnected(s.camera, pts[2], pts[1], n(2), n(1), kappa)
                    }
                }
            });
        if flagged {
            bits |= 1 << half;
        }
    }
    bits
}

/// Cells per block of [`leaf_flag_rows`]'s quiet test.
const BLOCK: usize = 16;

/// Eq. 11: the triangle spans enough depth to be a discontinuity at all.
fn gate(z: [f32; 3], lambda: f64) -> bool {
    let lo = f64::from(z[0].min(z[1]).min(z[2]));
    let hi = f64::from(z[0].max(z[1]).max(z[2]));
    hi - lo > lambda * lo
}

/// Eq. 10 without division.
fn orthogonal(camera: &Camera, p: [DVec3; 3], sin2: f64) -> bool {
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let v = if camera.is_orthographic() {
        DVec3::Z
    } else {
        (p[0] + p[1] + p[2]) / 3.0
    };
    let dot = v.dot(n);
    dot * dot < sin2 * v.length_squared() * n.length_squared()
}

/// Eq. 5-6: the frame has its z axis along the ray to `P1` and its x axis
/// across it, towards `P2`; as in Fig. 9b the curve parameter at `P2` is the
/// edge length `x2' = |P2 - P1|` rather than `P2`'s lateral offset, so a
/// rubber sheet (nearly along the ray, with normals nearly across it) overshoots
/// by far, while a real surface at angle `t` to the image plane misses by only
/// `tan(t) (1 - cos(t))`.
fn disconnected(camera: &Camera, p1: DVec3, p2: DVec3, n1: DVec3, n2: DVec3, kappa: f64) -> bool {
    let edge = p2 - p1;
    let len = edge.length();
    if len <= 0.0 || len.is_nan() {
        return false;
    }
    let w = camera.view_direction(p1);
    let dz = edge.dot(w);
    let Some(x) = (edge - dz * w).try_normalize() else {
        // The edge runs exactly along the ray: the two samples occlude each other.
        return true;
    };
    let (d1, d2) = (w.dot(n1), w.dot(n2));
    if d1.abs() < 1e-12 || d2.abs() < 1e-12 {
        return true;
    }
    // First derivatives from the normals (Eq. 5: B = f'(0), and f'(x2)).
    let (b, f2) = (-x.dot(n1) / d1, -x.dot(n2) / d2);
    // f(x2') - z1 = x2' (B + f'(x2')) / 2, so r = |(B + f') / 2 - dz / x2'| (Eq. 6).
    ((b + f2) / 2.0 - dz / len).abs() > kappa
}

/// Eq. 9 at every sample along its row and its column.
fn disparity_discontinuities(s: &Samples<'_>, sigma: f64) -> Vec<bool> {
    let grid = s.grid;
    let z = |x: i64, y: i64| -> Option<f64> {
        if x < 0 || y < 0 || x >= i64::from(grid.width) || y >= i64::from(grid.height) {
            return None;
        }
        let v = s.z[grid.index((x as u32, y as u32))];
        (v > 0.0).then_some(f64::from(v))
    };
    let exceeds = |a: Option<f64>, b: f64, c: Option<f64>| match (a, c) {
        (Some(z1), Some(z3)) => ((z1 - b) / z1 - (b - z3) / z3).abs() > sigma,
        _ => false,
    };
    let mut marks = vec![false; grid.len()];
    for y in 0..i64::from(grid.height) {
        for x in 0..i64::from(grid.width) {
            if let Some(b) = z(x, y) {
                marks[grid.index((x as u32, y as u32))] =
                    exceeds(z(x - 1, y), b, z(x + 1, y)) || exceeds(z(x, y - 1), b, z(x, y + 1));
            }
        }
    }
    marks
}
