//! Per-vertex normals and the sampling quality rho, DMesh Sec. 4.2.
//!
//! The normal of a sample is the cross product of the central differences of
//! its back-projected neighbours along the row and the column (one-sided where
//! a neighbour is invalid or off the image), turned to face the reference
//! camera. `rho = |n . v|` with `v` the unit direction from the camera to the
//! sample: 1 where the surface faces the camera, 0 where it is seen edge-on.
//! A sample with no usable neighbour gets the normal facing the camera and
//! `rho = 0` (nothing is known of its orientation). Normals travel
//! octahedron-encoded in two bytes, `rho` in one.
//!
//! Interior samples (all four neighbours valid, nine in ten or more) are
//! computed in f32, eight lanes at a time where the CPU has AVX2; the
//! others, and any whose f32 arithmetic would overflow or underflow, in
//! f64. The bytes are those of the f64 computation except where a value
//! lies within f32's rounding of a byte boundary: then a byte may be one
//! step off (about one sample in 10,000 on the Middlebury scenes; the
//! tests bound every interior sample against f64).

use std::ops::Range;
use std::sync::Mutex;

use glam::{DVec3, Vec3};

use super::backproject::BackProject;
use super::grid::Grid;
use crate::camera::Camera;

/// Octahedral encoding of the direction of `n` (any length) into two bytes.
#[inline]
pub fn oct_encode(n: DVec3) -> [u8; 2] {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if !(l1 > 0.0 && l1.is_finite()) {
        return OCT_FACING;
    }
    // `as` saturates, so nothing can wrap.
    oct_scaled(n.to_array(), 1.0 / l1).map(|v| oct_unrounded(v) as u8)
}

/// The octahedral coordinates in `[-1, 1]` of [`oct_encode`] for a
/// non-zero finite direction `(x, y, z)` given `1 / |n|_1`, without
/// branches (the f32 rows' loop stays straight). One statement of the fold
/// for both precisions.
#[inline(always)]
fn oct_scaled<T: Real>([x, y, z]: [T; 3], inv_l1: T) -> [T; 2] {
    let (px, py) = (x * inv_l1, y * inv_l1);
    let lower = z < T::ZERO;
    let fx = if lower { (T::ONE - py.abs()).copysign(px) } else { px };
    let fy = if lower { (T::ONE - px.abs()).copysign(py) } else { py };
    [fx, fy]
}

/// The arithmetic [`oct_scaled`] and the byte mappings need, so the f64
/// encoder and the f32 rows share one statement of each.
trait Real:
    Copy + PartialOrd + std::ops::Add<Output = Self> + std::ops::Sub<Output = Self> + std::ops::Mul<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    /// `v` exactly (the constants used are whole or half numbers).
    fn of(v: f32) -> Self;
    fn abs(self) -> Self;
    fn copysign(self, sign: Self) -> Self;
}

macro_rules! real {
    ($t:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            #[inline(always)]
            fn of(v: f32) -> Self {
                Self::from(v)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn copysign(self, sign: Self) -> Self {
                <$t>::copysign(self, sign)
            }
        }
    };
}
real!(f32);
real!(f64);

/// The encoding of -z, the normal facing the reference camera.
const OCT_FACING: [u8; 2] = [128, 128];

/// Inverse of [`oct_encode`]: a unit vector.
pub fn oct_decode(e: [u8; 2]) -> DVec3 {
    let x = f64::from(e[0]) / 255.0 * 2.0 - 1.0;
    let y = f64::from(e[1]) / 255.0 * 2.0 - 1.0;
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let sign = |v: f64| if v >= 0.0 { 1.0 } else { -1.0 };
    let n = DVec3::new(x - t * sign(x), y - t * sign(y), z);
    n.try_normalize().unwrap_or(DVec3::NEG_Z)
}

/// Quantises `rho` in `[0, 1]` to a byte.
pub fn rho_to_byte(rho: f64) -> u8 {
    rho_unrounded(rho) as u8
}

/// An octahedral coordinate in `[-1, 1]` mapped to `[0.5, 255.5]`, which
/// `as u8` truncates to the nearest of 256 steps.
#[inline(always)]
fn oct_unrounded<T: Real>(v: T) -> T {
    v * T::of(127.5) + T::of(128.0)
}

/// `rho` in `[0, 1]` mapped to `[0.5, 255.5]`, which `as u8` rounds.
#[inline(always)]
fn rho_unrounded<T: Real>(rho: T) -> T {
    rho * T::of(255.0) + T::of(0.5)
}

/// The encoded normal (turned to face the camera) and quality byte of a
/// sample with normal direction `n` (any length, possibly zero) seen along
/// `v` (any length): the samples the f32 rows leave.
fn encode(n: DVec3, v: DVec3) -> ([u8; 2], u8) {
    let nn = n.length_squared() * v.length_squared();
    // Two comparisons (NaN fails both) instead of is_finite's bit tests.
    if !(nn > 0.0 && nn < f64::INFINITY) {
        return (oct_encode(-v), 0);
    }
    let flip = if n.dot(v) > 0.0 { -1.0 } else { 1.0 };
    (oct_encode(n * flip), rho_to_byte(n.dot(v).abs() / nn.sqrt()))
}

/// [`encode`] in f32 and without branches, before the conversions to
/// bytes: the two octahedral coordinates and rho, each mapped to `[0.5,
/// 255.5]` (which [`truncate`] takes to the byte), and whether they hold:
/// they do unless `n` or `v` is zero, or so large or small that the f32
/// arithmetic overflows or leaves the normal range. Neither vector needs
/// normalising: the octahedral map divides by the L1 norm, and rho = |n .
/// v| / (|n| |v|) takes one square root; one reciprocal serves both.
#[inline(always)]
fn encode_unrounded(n: Vec3, v: Vec3) -> ([f32; 3], bool) {
    let dot = n.dot(v);
    let nn = n.length_squared() * v.length_squared();
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    let norms = nn.sqrt();
    let r = 1.0 / (l1 * norms);
    let ok = (nn > f32::MIN_POSITIVE) & (nn < f32::INFINITY) & (r > f32::MIN_POSITIVE) & (r < f32::INFINITY);
    // Face the camera: flip n when it points away.
    let flip = if dot > 0.0 { -1.0 } else { 1.0 };
    let [fx, fy] = oct_scaled((n * flip).to_array(), norms * r);
    let rho = dot.abs() * l1 * r;
    ([oct_unrounded(fx), oct_unrounded(fy), rho_unrounded(rho)], ok)
}

/// `t as u8` for `t` in `[0, 256)` (elsewhere some byte), in arithmetic
/// that vectorises where `as` does not: adding 2^23 to a whole number below
/// it leaves that number in the low bits of the sum.
#[inline(always)]
fn truncate(t: f32) -> u8 {
    (t.floor() + 8_388_608.0).to_bits() as u8
}

/// An interior row and its neighbours, in f32: depths of the row, the row
/// above and the row below, the column factors and the row factors of the
/// three rows.
struct Stencil<'a> {
    zrow: &'a [f32],
    zup: &'a [f32],
    zdown: &'a [f32],
    /// The column factors `(a, b)` of `x = a + b z`, as two rows.
    col_a: &'a [f32],
    col_b: &'a [f32],
    rows: [(f32, f32); 3],
}

impl Stencil<'_> {
    /// Whether sample `x` and its four neighbours are valid.
    #[inline(always)]
    fn complete(&self, x: usize) -> bool {
        let (zc, zl, zr, zu, zd) = (
            self.zrow[x],
            self.zrow[x - 1],
            self.zrow[x + 1],
            self.zup[x],
            self.zdown[x],
        );
        (zc > 0.0) & (zl > 0.0) & (zr > 0.0) & (zu > 0.0) & (zd > 0.0)
    }

    /// The central-difference normal (any length) and the point of sample `x`.
    #[inline(always)]
    fn normal(&self, x: usize) -> (Vec3, Vec3) {
        let [(ayu, byu), (ay, by), (ayd, byd)] = self.rows;
        let (zc, zl, zr, zu, zd) = (
            self.zrow[x],
            self.zrow[x - 1],
            self.zrow[x + 1],
            self.zup[x],
            self.zdown[x],
        );
        let (ca, cb) = (self.col_a, self.col_b);
        let ((axl, bxl), (ax, bx), (axr, bxr)) = ((ca[x - 1], cb[x - 1]), (ca[x], cb[x]), (ca[x + 1], cb[x + 1]));
        let p = Vec3::new(ax + bx * zc, ay + by * zc, zc);
        let dx = Vec3::new(axr + bxr * zr - axl - bxl * zl, by * (zr - zl), zr - zl);
        let dy = Vec3::new(bx * (zd - zu), ayd + byd * zd - ayu - byu * zu, zd - zu);
        (dy.cross(dx), p)
    }
}

/// The encoded normal and quality byte of every sample `1..w - 1` of an
/// interior row, in f32 as if all its neighbours were valid; `fast[x]`
/// says where that holds: the five samples are valid and the f32
/// arithmetic stayed in range. Two straight loops, so both vectorise: the
/// arithmetic into the unrounded bytes (`scratch`), then their conversion.
#[inline(always)]
fn interior_row(
    s: &Stencil<'_>,
    ortho: bool,
    nrow: &mut [[u8; 2]],
    rrow: &mut [u8],
    fast: &mut [bool],
    scratch: &mut [Vec<f32>; 3],
) {
    let w = s.zrow.len();
    for x in 1..w - 1 {
        let (n, p) = s.normal(x);
        let (t, ok) = encode_unrounded(n, if ortho { Vec3::Z } else { p });
        (scratch[0][x], scratch[1][x], scratch[2][x]) = (t[0], t[1], t[2]);
        fast[x] = s.complete(x) & ok;
    }
    for x in 1..w - 1 {
        let (a, b, c) = (scratch[0][x], scratch[1][x], scratch[2][x]);
        (nrow[x], rrow[x]) = ([truncate(a), truncate(b)], truncate(c));
    }
}

/// Computes the encoded normal and quality byte of every grid vertex.
pub fn normals_and_quality(grid: &Grid, camera: &Camera, bp: &BackProject, z: &[f32]) -> (Vec<[u8; 2]>, Vec<u8>) {
    let (mut normals, mut rho) = (vec![OCT_FACING; grid.len()], vec![0; grid.len()]);
    normal_rows(grid, camera, bp, z, 0..grid.gh() as usize, &mut normals, &mut rho);
    (normals, rho)
}

/// Grid rows per band of [`NormalBands`]: about 30 bands at 1920 x 1080,
/// so the thread that takes the last one waits little for the other.
const BAND_ROWS: usize = 32;

/// The grid's rows of normals and quality bytes cut into bands of
/// [`BAND_ROWS`], each taken by whichever thread asks first
/// ([`Self::work`]): two threads that come to the normals at different
/// times finish them together. Every band is computed exactly once, and
/// its bytes do not depend on which thread computed it.
pub(crate) struct NormalBands<'a> {
    left: Mutex<Vec<NormalBand<'a>>>,
}

/// One band: its first grid row and its rows of both arrays.
type NormalBand<'a> = (usize, &'a mut [[u8; 2]], &'a mut [u8]);

impl<'a> NormalBands<'a> {
    /// The bands of `normals` and `rho`, one entry per grid vertex.
    pub(crate) fn new(grid: &Grid, normals: &'a mut [[u8; 2]], rho: &'a mut [u8]) -> Self {
        let band = BAND_ROWS * grid.gw() as usize;
        let mut left: Vec<NormalBand<'a>> = normals
            .chunks_mut(band)
            .zip(rho.chunks_mut(band))
            .enumerate()
            .map(|(i, (n, r))| (i * BAND_ROWS, n, r))
            .collect();
        // Taken from the end: the first rows first.
        left.reverse();
        Self { left: Mutex::new(left) }
    }

    /// Computes bands until none is left.
    pub(crate) fn work(&self, grid: &Grid, camera: &Camera, bp: &BackProject, z: &[f32]) {
        let gw = grid.gw() as usize;
        // A band is only ever moved out under the lock, so a panic
        // elsewhere cannot leave one half taken: the queue stays usable.
        let take = || self.left.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).pop();
        while let Some((first, normals, rho)) = take() {
            normals.fill(OCT_FACING);
            rho.fill(0);
            let rows = first..first + normals.len() / gw;
            normal_rows(grid, camera, bp, z, rows, normals, rho);
        }
    }
}

crate::simd::dispatch! {
    /// The encoded normals and quality bytes of grid rows `rows`, into
    /// `normals` and `rho`, which hold those rows (from `rows.start`) and
    /// are set to the camera-facing normal and 0 beforehand (with AVX2
    /// where the CPU has it: [`crate::simd`]). Rows past the image are
    /// left as they are.
    fn normal_rows(grid: &Grid, camera: &Camera, bp: &BackProject, z: &[f32], rows: Range<usize>, normals: &mut [[u8; 2]], rho: &mut [u8]) -> () = normal_rows_body;
}

/// Samples per block of [`normal_rows`]'s pass over the fast ones.
const FAST_BLOCK: usize = 32;

#[inline(always)]
fn normal_rows_body(
    grid: &Grid,
    camera: &Camera,
    bp: &BackProject,
    z: &[f32],
    rows: Range<usize>,
    normals: &mut [[u8; 2]],
    rho: &mut [u8],
) {
    let gw = grid.gw() as usize;
    let (w, h) = (grid.width as usize, grid.height as usize);
    let facing = OCT_FACING;
    let offset = rows.start * gw;
    let ortho = camera.is_orthographic();
    let view = |p: DVec3| if ortho { DVec3::Z } else { p };
    let mut fast = vec![false; w];
    let mut scratch = [vec![0f32; w], vec![0f32; w], vec![0f32; w]];
    let (col_a, col_b) = bp.cols();
    let [col_a, col_b] = [col_a, col_b].map(|c| c[..w].iter().map(|&v| v as f32).collect::<Vec<_>>());
    // Any sample: differences across it along the row and the column,
    // one-sided where a neighbour is invalid (depth 0) or off the image.
    let general = |x: usize, y: usize| {
        let diff = |c: DVec3, lo: Option<DVec3>, hi: Option<DVec3>| match (lo, hi) {
            (Some(l), Some(h)) => Some(h - l),
            (None, Some(h)) => Some(h - c),
            (Some(l), None) => Some(c - l),
            (None, None) => None,
        };
        let at = |xx: usize, yy: usize| {
            let d = z[yy * gw + xx];
            (d > 0.0).then(|| bp.point(xx as u32, yy as u32, d))
        };
        let p = bp.point(x as u32, y as u32, z[y * gw + x]);
        let left = if x > 0 { at(x - 1, y) } else { None };
        let right = if x + 1 < w { at(x + 1, y) } else { None };
        let up = if y > 0 { at(x, y - 1) } else { None };
        let down = if y + 1 < h { at(x, y + 1) } else { None };
        let n = match (diff(p, left, right), diff(p, up, down)) {
            (Some(dx), Some(dy)) => dy.cross(dx),
            _ => DVec3::ZERO,
        };
        encode(n, view(p))
    };
    for y in rows.start..rows.end.min(h) {
        let row = y * gw;
        let out = row - offset..row - offset + w;
        let (nrow, rrow) = (&mut normals[out.clone()], &mut rho[out]);
        let zrow = &z[row..row + w];
        if y == 0 || y + 1 == h || w < 3 {
            for x in (0..w).filter(|&x| zrow[x] > 0.0) {
                (nrow[x], rrow[x]) = general(x, y);
            }
            continue;
        }
        // Interior rows: central differences where all four neighbours are
        // valid, computed for the whole row without branches (so the loop
        // vectorises); the samples where that does not apply are redone one
        // by one.
        let (zup, zdown) = (&z[row - gw..row - gw + w], &z[row + gw..row + gw + w]);
        let rows = [bp.row(y - 1), bp.row(y), bp.row(y + 1)].map(|(a, b)| (a as f32, b as f32));
        let stencil = Stencil {
            zrow,
            zup,
            zdown,
            col_a: &col_a,
            col_b: &col_b,
            rows,
        };
        interior_row(&stencil, ortho, nrow, rrow, &mut fast, &mut scratch);
        // Blocks of fast samples are passed over whole: an `and` of the
        // block's bytes, without branches (a branch per sample cost a
        // tenth of the stage, more where the code's layout fell badly).
        for (block, fast) in fast[1..w - 1].chunks(FAST_BLOCK).enumerate() {
            if fast.iter().fold(true, |all, &f| all & f) {
                continue;
            }
            for (k, _) in fast.iter().enumerate().filter(|&(_, &f)| !f) {
                let x = 1 + block * FAST_BLOCK + k;
                (nrow[x], rrow[x]) = if zrow[x] > 0.0 { general(x, y) } else { (facing, 0) };
            }
        }
        for x in [0, w - 1] {
            if zrow[x] > 0.0 {
                (nrow[x], rrow[x]) = general(x, y);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn oct_round_trip_is_within_two_degrees(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
            let n = DVec3::new(x, y, z);
            prop_assume!(n.length() > 1e-3);
            let n = n.normalize();
            let back = oct_decode(oct_encode(n));
            prop_assert!(back.dot(n) > 2f64.to_radians().cos(), "{n} -> {back}");
        }
    }

    /// DMesh Sec. 4.2: rho is the cosine of the angle between the surface
    /// normal and the viewing ray. An orthographic camera sees a plane
    /// tilted by theta along parallel rays, so every interior sample's rho
    /// is cos(theta), within the byte's rounding.
    #[test]
    fn rho_on_a_slanted_plane_is_the_cosine_of_its_tilt() {
        for deg in [0.0f64, 30.0, 45.0, 60.0, 80.0] {
            let cam = Camera::orthographic(9, 9, 0.01, 0.01, 4.0, 4.0).unwrap();
            let grid = Grid::for_image(9, 9);
            let bp = BackProject::new(&cam, grid.gw(), grid.gh());
            let mut z = vec![0f32; grid.len()];
            for y in 0..9u32 {
                for x in 0..9u32 {
                    // Tilted about the x axis: depth grows with y.
                    z[grid.index((x, y))] = (2.0 + f64::from(y) * 0.01 * deg.to_radians().tan()) as f32;
                }
            }
            let (_, rho) = normals_and_quality(&grid, &cam, &bp, &z);
            let want = f64::from(rho_to_byte(deg.to_radians().cos()));
            for y in 1..8 {
                for x in 1..8 {
                    let got = f64::from(rho[grid.index((x, y))]);
                    assert!(
                        (got - want).abs() <= 1.0,
                        "{deg} degrees at ({x}, {y}): rho {got}, want {want}"
                    );
                }
            }
        }
    }

    /// Depths far outside f32's comfortable range (the f32 rows' products
    /// overflow or vanish) are computed in f64, which holds them.
    #[test]
    fn a_fronto_parallel_plane_has_full_quality_at_the_centre() {
        for depth in [2.0f32, 1e-20, 1e20, 1e30] {
            let cam = Camera::perspective(5, 5, 100.0, 100.0, 2.0, 2.0).unwrap();
            let grid = Grid::for_image(5, 5);
            let bp = BackProject::new(&cam, grid.gw(), grid.gh());
            let z = vec![depth; grid.len()];
            let (n, rho) = normals_and_quality(&grid, &cam, &bp, &z);
            let centre = grid.index((2, 2));
            assert_eq!(rho[centre], 255, "depth {depth}");
            assert!(oct_decode(n[centre]).dot(DVec3::NEG_Z) > 0.999, "depth {depth}");
        }
    }

    /// Bands taken by two threads at once give the bytes of one pass over
    /// the whole grid, on an image whose rows are no multiple of a band
    /// (the last band short, padding rows below the image) and with holes.
    #[test]
    fn bands_on_two_threads_give_the_bytes_of_one_pass() {
        let (w, h) = (150, 3 * BAND_ROWS as u32 + 5);
        let cam = Camera::perspective(w, h, 120.0, 120.0, 75.0, 50.0).unwrap();
        let grid = Grid::for_image(w, h);
        assert!(grid.gh() > h, "the grid has padding rows");
        let bp = BackProject::new(&cam, grid.gw(), grid.gh());
        let z: Vec<f32> = (0..grid.len())
            .map(|i| {
                let (x, y) = (i % grid.gw() as usize, i / grid.gw() as usize);
                if (x * 7 + y * 13) % 29 == 0 {
                    0.0
                } else {
                    2.0 + ((x * x + 3 * y) % 17) as f32 * 0.01
                }
            })
            .collect();
        let whole = normals_and_quality(&grid, &cam, &bp, &z);
        let (mut normals, mut rho) = (vec![[0u8; 2]; grid.len()], vec![0u8; grid.len()]);
        let bands = NormalBands::new(&grid, &mut normals, &mut rho);
        std::thread::scope(|scope| {
            scope.spawn(|| bands.work(&grid, &cam, &bp, &z));
            bands.work(&grid, &cam, &bp, &z);
        });
        drop(bands);
        assert!(whole.1.iter().any(|&r| r > 0) && whole.1.contains(&0));
        assert_eq!((normals, rho), whole);
    }

    /// The f64 reference of a sample with four valid neighbours: the
    /// central differences of the back-projected points, encoded in f64.
    fn reference(bp: &BackProject, z: impl Fn(u32, u32) -> f32, ortho: bool, (x, y): (u32, u32)) -> ([u8; 2], u8) {
        let p = |x, y| bp.point(x, y, z(x, y));
        let n = (p(x, y + 1) - p(x, y - 1)).cross(p(x + 1, y) - p(x - 1, y));
        encode(n, if ortho { DVec3::Z } else { p(x, y) })
    }

    proptest! {
        /// The interior samples, computed in f32, against f64: the same
        /// direction within one step of the octahedral encoding (the
        /// decoded normals within 1.5 degrees; bytes may differ more across
        /// the encoding's seam, where both sides mean the same direction)
        /// and rho within one step, on random depths with holes and jumps
        /// of up to a hundred times the depth (steep, nearly edge-on
        /// stencils), through perspective and orthographic cameras with
        /// focal lengths from 20 to 100,000 pixels.
        #[test]
        fn interior_samples_in_f32_are_within_a_step_of_f64(
            w in 3u32..24,
            h in 3u32..24,
            focal in 20.0f64..100000.0,
            base in 0.05f32..500.0,
            relief in 0.0f32..100.0,
            ortho in any::<bool>(),
            seed in any::<u64>(),
        ) {
            let cam = if ortho {
                Camera::orthographic(w, h, 1.0 / focal, 1.0 / focal, f64::from(w) / 3.0, f64::from(h) / 2.0)
            } else {
                Camera::perspective(w, h, focal, focal * 1.1, f64::from(w) / 3.0, f64::from(h) / 2.0)
            }
            .unwrap();
            let grid = Grid::for_image(w, h);
            let bp = BackProject::new(&cam, grid.gw(), grid.gh());
            let mut state = seed | 1;
            let mut z = vec![0f32; grid.len()];
            for y in 0..h {
                for x in 0..w {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    let r = (state >> 40) as f32 / (1u64 << 24) as f32;
                    // One sample in twenty invalid, the rest a tilted plane
                    // with random relief.
                    z[grid.index((x, y))] = if r < 0.05 {
                        0.0
                    } else {
                        base * (1.0 + 0.01 * x as f32 + 0.02 * y as f32 + relief * r)
                    };
                }
            }
            let (normals, rho) = normals_and_quality(&grid, &cam, &bp, &z);
            let depth = |x: u32, y: u32| z[grid.index((x, y))];
            let step = 1.5f64.to_radians().cos();
            for y in 1..h - 1 {
                for x in 1..w - 1 {
                    let near = [(x, y), (x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)];
                    if near.iter().any(|&(x, y)| depth(x, y) <= 0.0) {
                        continue;
                    }
                    let (want_n, want_rho) = reference(&bp, depth, ortho, (x, y));
                    let i = grid.index((x, y));
                    let cos = oct_decode(normals[i]).dot(oct_decode(want_n));
                    prop_assert!(cos >= step, "({x}, {y}): normal {:?} against {:?}", normals[i], want_n);
                    prop_assert!(rho[i].abs_diff(want_rho) <= 1, "({x}, {y}): rho {} against {want_rho}", rho[i]);
                }
            }
        }
    }
}
