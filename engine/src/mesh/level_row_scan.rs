//! The depth deviations of every half of one level of half-size 8 and up
//! (DMesh Sec. 4.2; the deviation term is issue 16's, `hierarchy.rs`),
//! read grid row by grid row: issue 27's level-order row sweeps.
//!
//! Scanned half after half, a half of half-size `h` reads a short segment
//! of each of its `h + 1` to `2h + 1` rows, a grid row apart, and the next
//! half the segments beside them: as many streams through memory as rows,
//! more than a core's prefetchers follow once `h` is 16 or more. At 1920 x
//! 1080 on a 2 GHz Zen 1, levels 4 to 6 cost twice as much per sample as
//! at 513 x 513, whose depths stay in cache. The build reads levels 4 and
//! 5 this way (`levels.rs`'s `ROW_SCAN_LEVELS` has the figures).
//!
//! Here the halves of one row of split vertices are set up first (their
//! corners, gradient and rows), then each grid row they span is read once,
//! left to right, a segment per half. Each segment is `deviation_f32.rs`'s
//! row scan with the same interpolant, and the largest of the segments'
//! values is the same in any order: the bits are those of
//! `max_deviation_f32` half by half, which the tests check.

use super::deviation::{gradient, half_row, half_rows, HalfRows};
use super::deviation_f32::{in_f32_range, row_max_deviation_f32, widen};
use super::grid::{Grid, Pt};
use super::level_deviations::half_deviation2;
use super::levels::round_up;
use super::split_order::{split_rows, Bisects, Split};

/// A half's interpolant from its corner `a` (as `max_deviation_f32` has
/// it): depth `za` at `(ax, ay)`, gradient `(gx, gy)`; and its corners'
/// depths, which bound the scan's rounding.
struct Interpolant {
    za: f64,
    ax: f64,
    ay: f64,
    gx: f64,
    gy: f64,
    corners: [f32; 3],
}

/// One half being scanned: where its value goes (the pair's index in the
/// row's output, and the half), how far right of its group's first half
/// it lies, its interpolant, and the largest deviation so far.
struct HalfScan {
    slot: (usize, usize),
    dx: usize,
    plane: Interpolant,
    worst: f32,
}

/// The halves of one row of split vertices that have one shape: the same
/// half of every other vertex (a centre's diagonal turns from one to the
/// next). Their rows are the first one's, `dx` to the right.
#[derive(Default)]
struct Group {
    rows: HalfRows,
    x: u32,
    scans: Vec<HalfScan>,
}

/// The squared deviations, rounded up, of both halves of every split
/// vertex of level `g` (at least 4), appended to `out` in
/// `for_each_split`'s order: 0 where a half does not exist.
#[inline(always)]
pub(super) fn level_row_scan(grid: Grid, z: &[f32], g: u32, out: &mut Vec<[f32; 2]>) {
    debug_assert!(g >= 4, "levels 1 to 3 are swept: small_half_sweep.rs");
    let (gw, gh) = (grid.gw(), grid.gh());
    let h = 1u32 << g;
    // By half and by the parity of the vertex.
    let mut groups: [Group; 4] = Default::default();
    for (bisects, y, xs) in split_rows(grid, g) {
        let first = out.len();
        for (i, x) in xs.enumerate() {
            let s = Split::at(grid, (x, y), h, bisects);
            let mut pair = [0f32; 2];
            for (half, apex) in s.apex.into_iter().enumerate() {
                let Some(c) = apex else { continue };
                let plane = match set_up(z, gw as usize, s, h, c) {
                    Ok(plane) => plane,
                    Err(dev2) => {
                        pair[half] = dev2;
                        continue;
                    }
                };
                let group = &mut groups[2 * half + i % 2];
                if group.scans.is_empty() {
                    group.x = x;
                    group.rows = half_rows(s.v, h, c, bisects == Bisects::Row, bisects == Bisects::Diagonal);
                }
                group.scans.push(HalfScan {
                    slot: (out.len() - first, half),
                    dx: (x - group.x) as usize,
                    plane,
                    worst: 0.0,
                });
            }
            out.push(pair);
        }
        scan_rows(z, gw as usize, y.saturating_sub(h)..(y + h + 1).min(gh), &mut groups);
        for group in &mut groups {
            for scan in group.scans.drain(..) {
                let (i, half) = scan.slot;
                let dev = widen(scan.worst, scan.plane.corners);
                out[first + i][half] = round_up(dev * dev);
            }
        }
    }
}

/// The interpolant of the half of `s` with apex `c`, or its squared
/// deviation where no scan by rows is needed (collinear corners: 0) or
/// possible (corners out of f32's range: scanned in f64 at once).
#[inline(always)]
fn set_up(z: &[f32], gw: usize, s: Split, h: u32, c: Pt) -> Result<Interpolant, f32> {
    let at = |p: Pt| z[p.1 as usize * gw + p.0 as usize];
    let corners = [at(s.a), at(s.b), at(c)];
    if !in_f32_range(corners) {
        return Err(half_deviation2(z, gw, s, h, c));
    }
    let Some((gx, gy)) = gradient(z, gw, [s.a, s.b, c]) else {
        return Err(0.0);
    };
    Ok(Interpolant {
        za: f64::from(corners[0]),
        ax: f64::from(s.a.0),
        ay: f64::from(s.a.1),
        gx,
        gy,
        corners,
    })
}

/// Each grid row of `ys`, left to right: every half of every group that
/// has samples on it takes their largest deviation.
#[inline(always)]
fn scan_rows(z: &[f32], gw: usize, ys: std::ops::Range<u32>, groups: &mut [Group; 4]) {
    for y in ys {
        let start = y as usize * gw;
        for group in groups.iter_mut() {
            let Some((lo, hi)) = half_row(group.rows, y).filter(|_| !group.scans.is_empty()) else {
                continue;
            };
            for scan in &mut group.scans {
                let (lo, hi) = (lo + scan.dx, hi + scan.dx);
                let p = &scan.plane;
                let base = (p.za + p.gy * (f64::from(y) - p.ay) + p.gx * (f64::from(lo as u32) - p.ax)) as f32;
                let d = row_max_deviation_f32(&z[start + lo..=start + hi], base, p.gx as f32);
                scan.worst = if d > scan.worst { d } else { scan.worst };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::deviation_f32::tests::rough_depths;
    use super::super::split_order::for_each_split;
    use super::*;
    use proptest::prelude::*;

    /// Half by half, as `coarse_deviations` scans the levels below.
    fn half_by_half(grid: Grid, z: &[f32], g: u32) -> Vec<[f32; 2]> {
        let (gw, h) = (grid.gw() as usize, 1 << g);
        let mut out = Vec::new();
        for_each_split(grid, g..g + 1, |s| {
            out.push(s.apex.map(|apex| apex.map_or(0.0, |c| half_deviation2(z, gw, s, h, c))));
        });
        out
    }

    /// Every level from 4 up gives the bits of the scan half by half.
    fn matches_half_by_half(grid: Grid, z: &[f32]) -> Result<(), TestCaseError> {
        for g in 4..grid.k {
            let mut rows = Vec::new();
            level_row_scan(grid, z, g, &mut rows);
            prop_assert_eq!(rows, half_by_half(grid, z, g), "level {}", g);
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Over ramps with noise, jumps and depths from 1e-25 to 1e25
        /// (beyond f32's range for the scan: those halves in f64), with
        /// invalid samples, on grids padded or not.
        #[test]
        fn rows_give_the_bits_of_the_scan_half_by_half(
            (seed, scale, slope, noise, jump) in super::super::deviation_f32::tests::rough(),
            (a, b, pad) in (1u32..5, 1u32..5, 0u32..3),
            holes in 0u32..4,
        ) {
            // Multiples of 32 (levels 4 at least), padded or not.
            let (w, h) = (32 * a + 1 - pad, 32 * b + 1);
            let grid = Grid::for_image(w, h);
            prop_assert!(grid.k >= 5, "{} x {}: k = {}", w, h, grid.k);
            let (gw, gh) = (grid.gw() as usize, grid.gh() as usize);
            let side = gw.max(gh);
            let square = rough_depths(side, seed, scale, slope, noise, jump);
            let z: Vec<f32> = (0..gw * gh)
                .map(|i| {
                    let (x, y) = (i % gw, i / gw);
                    let invalid = x >= w as usize || y >= h as usize || (holes > 0 && (x * 7 + y * 3) % (29 * holes as usize) == 0);
                    if invalid { 0.0 } else { square[y * side + x] }
                })
                .collect();
            matches_half_by_half(grid, &z)?;
        }
    }

    /// A flat image (collinear corners nowhere, deviation 0 everywhere)
    /// and a plane tilted along rows give the scan's bits too.
    #[test]
    fn planes_give_the_bits_of_the_scan_half_by_half() {
        let grid = Grid::for_image(129, 65);
        let (gw, gh) = (grid.gw() as usize, grid.gh() as usize);
        for tilt in [0.0f32, 0.013] {
            let z: Vec<f32> = (0..gw * gh).map(|i| 3.0 + tilt * (i % gw) as f32).collect();
            matches_half_by_half(grid, &z).unwrap();
        }
    }
}
