//! The depth deviation of a hierarchy triangle scanned in f32 and widened
//! by a stated margin into an upper bound of `deviation.rs`'s exact f64
//! scan: never below it, above it by at most `2^-22` of the deviation plus
//! [`MARGIN`] (`2^-20`) times the largest corner depth. Issue 16's decision
//! (a) lets the stored errors move within such a margin; the extraction's
//! guarantee (epsilon at every sample) needs only that they never fall
//! below the exact deviation. This file scans the halves of half-size 16
//! and up, eight samples of a row at a time; `small_half_sweep.rs` those
//! of half-size 2, 4 and 8 a level at a time, within the same margin.
//!
//! Why f32: the f64 scan's interpolant is a running sum (one add's latency
//! per four samples), and f32 lanes are twice as many. Here the interpolant
//! is `base + i * step` for sample `i` of a row, so any lane computes any
//! sample and the result does not depend on the vector width: AVX2 and
//! portable code give the same bits, and `max` is exact in any order.
//!
//! The margin, with `u = 2^-24` (f32's unit roundoff) and `Z` the largest
//! corner depth (which bounds `|z_lin|` on the triangle: an affine function
//! takes its extremes at the corners). For a sample `i` of a row:
//! - `base`, rounded from f64 to f32: at most `u Z` off;
//! - `step` rounded to f32, times `i`: at most `u |step| i <= 2 u Z` (the row
//!   lies in the triangle, so `|step| i` is a difference of two values of
//!   `z_lin` there);
//! - the product rounded: `2 u Z`; the sum rounded: `u Z`;
//!
//! so the f32 interpolant is within `6 u Z` of the exact one (the small
//! halves' form, all in f32, within `10 u Z`: `small_half_sweep.rs`), plus
//! f64's `O(2^-50 Z)` in the gradient and the f64 reference's own rounding,
//! `O(2^-36 Z)` at most. The rounded `|z - z_lin|` is at least `1 - u` of
//! the true one. Hence `d32 (1 + 4u) + 16 u Z` bounds both the exact
//! deviation and the f64 scan's. When the three corners have one depth the
//! interpolant is exact in both (`base = z_a`, `step = 0`) and only the
//! relative factor is added, so a fronto-parallel plane keeps deviation 0.
//! Corner depths outside `[2^-60, 2^60]`, where subnormal or overflowing
//! intermediates could void these bounds, are scanned in f64, except three
//! corners of depth 0 (invalid samples and padding, whose halves the pass
//! ignores): their interpolant is 0, so `|z - z_lin|` is exact in f32.

use super::deviation::{for_each_row, gradient, max_deviation, HalfRows};
use super::grid::Pt;

/// f32's unit roundoff.
const U: f64 = f32::EPSILON as f64 / 2.0;

/// The absolute part of the margin, in units of the largest corner depth.
pub(crate) const MARGIN: f64 = 16.0 * U;

/// The relative part: `d32 * (1 + RELATIVE)`.
pub(crate) const RELATIVE: f64 = 4.0 * U;

/// Largest corner depth scanned in f32 (`2^60`); beyond, f64.
const HIGH: f32 = 1.152_921_5e18;

/// Smallest (`2^-60`).
const LOW: f32 = 8.673_617e-19;

/// Whether a half whose corners have depths `corners` may be scanned in
/// f32: the largest within `[2^-60, 2^60]`, or all three 0 (the halves of
/// invalid regions and of the padding, which in f64 took a fortieth of a
/// build on cones).
#[inline(always)]
pub(crate) fn in_f32_range([za, zb, zc]: [f32; 3]) -> bool {
    let largest = za.abs().max(zb.abs()).max(zc.abs());
    (LOW..=HIGH).contains(&largest) || largest == 0.0
}

/// The f32 scan's largest `|z - z_lin|`, `worst`, of a half with corner
/// depths `corners`, widened by the margin into the bound the module doc
/// states (`corners` [`in_f32_range`]).
#[inline(always)]
pub(crate) fn widen(worst: f32, [za, zb, zc]: [f32; 3]) -> f64 {
    let flat = za == zb && zb == zc;
    let zmax = za.abs().max(zb.abs()).max(zc.abs());
    f64::from(worst) * (1.0 + RELATIVE) + if flat { 0.0 } else { MARGIN * f64::from(zmax) }
}

crate::simd::dispatch! {
    /// [`max_deviation_f32`] in a function of its own, with AVX2 where the
    /// CPU has it, for the scans of single halves: inlined into the pass,
    /// its loops were built one way or another depending on what else the
    /// pass held (levels 4 and 5 at 513 x 513 on one thread took 0.35 and
    /// 0.13 ms one way, 0.45 and 0.19 the other), which a call per half
    /// of 289 samples and more does not cost.
    pub(crate) fn half_max_deviation_f32(z: &[f32], gw: usize, corners: [Pt; 3], rows: HalfRows) -> f64 = max_deviation_f32;
}

/// An upper bound of [`max_deviation`] within the margin above, for the
/// samples in `rows` and the corners `(a, b, c)`; every sample in it must
/// be valid, as there.
#[inline(always)]
pub(crate) fn max_deviation_f32(z: &[f32], gw: usize, corners: [Pt; 3], rows: HalfRows) -> f64 {
    let [a, b, c] = corners;
    let at = |p: Pt| z[p.1 as usize * gw + p.0 as usize];
    let (za, zb, zc) = (at(a), at(b), at(c));
    if !in_f32_range([za, zb, zc]) {
        return max_deviation(z, gw, corners, rows);
    }
    // The gradient as the f64 scan has it; the interpolant from corner `a`,
    // so its terms stay within a few `Z` (see the module doc).
    let Some((gx, gy)) = gradient(z, gw, corners) else {
        return 0.0;
    };
    let (za64, ax, ay) = (f64::from(za), f64::from(a.0), f64::from(a.1));
    let step = gx as f32;
    let mut worst = 0f32;
    for_each_row(
        rows,
        #[inline(always)]
        |y, lo, hi| {
            let start = y * gw;
            let base = (za64 + gy * (f64::from(y as u32) - ay) + gx * (f64::from(lo as u32) - ax)) as f32;
            let d = row_max_deviation_f32(&z[start + lo..=start + hi], base, step);
            worst = if d > worst { d } else { worst };
        },
    );
    widen(worst, [za, zb, zc])
}

/// Largest `|row[i] - (base + i * step)|` in f32: eight samples at a time
/// into two running maxima, the last eight overlapping the ones before
/// (`max` does not mind seeing a sample twice), rows under eight one by one.
#[inline(always)]
pub(super) fn row_max_deviation_f32(row: &[f32], base: f32, step: f32) -> f32 {
    // Sample indices as f32 (a row is under 2^24 samples: exact), within
    // a group of eight.
    const LANE: [f32; 8] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
    let n = row.len();
    if n < 8 {
        let mut worst = 0f32;
        for (&s, &i) in row.iter().zip(&LANE) {
            let d = (s - (base + i * step)).abs();
            worst = if d > worst { d } else { worst };
        }
        return worst;
    }
    // The deviations of samples `i..i + 8`, folded into `acc`.
    #[inline(always)]
    fn fold(acc: &mut [f32; 8], row: &[f32], i: usize, base: f32, step: f32) {
        let Some(chunk) = row.get(i..i + 8) else { return };
        let first = i as u32 as f32;
        for ((m, &s), &k) in acc.iter_mut().zip(chunk).zip(&LANE) {
            let d = (s - (base + (first + k) * step)).abs();
            *m = if d > *m { d } else { *m };
        }
    }
    let (mut even, mut odd) = ([0f32; 8], [0f32; 8]);
    let mut i = 0;
    while i + 16 <= n {
        fold(&mut even, row, i, base, step);
        fold(&mut odd, row, i + 8, base, step);
        i += 16;
    }
    if i + 8 <= n {
        fold(&mut even, row, i, base, step);
        i += 8;
    }
    if i < n {
        fold(&mut odd, row, n - 8, base, step);
    }
    even.iter().chain(&odd).fold(0f32, |w, &d| if d > w { d } else { w })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::super::deviation::half_rows;
    use super::super::deviation::tests::halves_around;
    use super::*;
    use proptest::prelude::*;

    /// A `gw x gw` grid of depths around `10^scale`: a ramp of `slope`
    /// percent across, uniform noise of `noise` times the depth, and a step
    /// of `jump` times the depth across a slanted line.
    pub(crate) fn rough_depths(gw: usize, seed: u64, scale: i32, slope: f64, noise: f64, jump: f64) -> Vec<f32> {
        let depth = 10f64.powi(scale);
        let mut s = seed;
        (0..gw * gw)
            .map(|i| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let r = (s >> 11) as f64 / (1u64 << 53) as f64;
                let (x, y) = ((i % gw) as f64, (i / gw) as f64);
                let step = if x + 0.7 * y > gw as f64 { jump } else { 0.0 };
                (depth * (1.0 + 0.01 * slope * (x - 0.5 * y) / gw as f64 + noise * r + step)) as f32
            })
            .collect()
    }

    /// The bound the module doc states, in f64: what the f32 scan may
    /// add to the f64 scan's deviation `exact` of corners up to `zmax`.
    fn allowed(exact: f64, zmax: f64) -> f64 {
        exact * (1.0 + 2.0 * RELATIVE) + 2.0 * MARGIN * zmax
    }

    /// Every half of level `h` of a `gw x gw` grid around its centre.
    fn halves(gw: u32, h: u32) -> Vec<([Pt; 3], HalfRows)> {
        let v = (gw / 2, gw / 2);
        (halves_around(v, h).into_iter())
            .map(|(corners, along_row, diagonal)| (corners, half_rows(v, h, corners[2], along_row, diagonal)))
            .collect()
    }

    /// Parameters for [`rough_depths`]: seed, scale, slope, noise, jump.
    pub(crate) fn rough() -> impl Strategy<Value = (u64, i32, f64, f64, f64)> {
        (
            any::<u64>(),
            -25i32..25,
            -3.0f64..3.0,
            prop::sample::select(vec![0.0f64, 1e-7, 1e-3, 0.3]),
            prop::sample::select(vec![0.0f64, 0.5, 100.0]),
        )
    }

    #[test]
    fn a_level_plane_keeps_deviation_zero_and_a_bump_is_found() {
        let gw = 33usize;
        let mut z = vec![7.25f32; gw * gw];
        for (corners, rows) in halves(33, 16) {
            assert_eq!(max_deviation_f32(&z, gw, corners, rows), 0.0);
        }
        z[16 * gw + 16] += 0.5;
        for (corners, rows) in halves(33, 16) {
            let d = max_deviation_f32(&z, gw, corners, rows);
            assert!((0.5..0.5 * (1.0 + 2.0 * RELATIVE)).contains(&d), "{d}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Never below the f64 scan, and above it by no more than the
        /// margin, for smooth surfaces with noise, ramps, jumps and depths
        /// from 1e-25 to 1e25 (beyond `[2^-60, 2^60]` the f64 scan itself);
        /// with `zero_corners`, every corner invalid (depth 0) around valid
        /// samples, which the f32 scan takes too.
        #[test]
        fn the_f32_scan_bounds_the_f64_scan_within_its_margin(
            (seed, scale, slope, noise, jump) in rough(),
            h in prop::sample::select(vec![8u32, 16, 32]),
            zero_corners in any::<bool>(),
        ) {
            let gw = 4 * h as usize + 1;
            let mut z = rough_depths(gw, seed, scale, slope, noise, jump);
            if zero_corners {
                // The halves' corners lie on multiples of h.
                let h = h as usize;
                for (i, z) in z.iter_mut().enumerate() {
                    if (i % gw) % h == 0 && (i / gw) % h == 0 {
                        *z = 0.0;
                    }
                }
            }
            for (corners, rows) in halves(gw as u32, h) {
                let exact = max_deviation(&z, gw, corners, rows);
                let fast = max_deviation_f32(&z, gw, corners, rows);
                let zmax = corners.iter().map(|p| z[p.1 as usize * gw + p.0 as usize]).fold(0f32, f32::max);
                prop_assert!(fast.is_finite());
                prop_assert!(fast >= exact, "{fast} below {exact}");
                prop_assert!(fast <= allowed(exact, f64::from(zmax)), "{fast} against {exact}");
            }
        }
    }
}
