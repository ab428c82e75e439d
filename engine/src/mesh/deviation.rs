//! The exact depth deviation of a hierarchy triangle: the largest
//! `|z - z_lin|` over the grid samples inside or on the triangle, where
//! `z_lin` interpolates the three corner depths affinely over the pixel grid.
//!
//! This is what makes the static tolerance a guarantee at every sample
//! (`extract.rs`), beyond DMesh's Eq. 1-2, which measure the distance of the
//! refinement point alone. Every triangle of the 4-8 hierarchy has edges
//! along rows, columns or diagonals, so each row of it is one exact integer
//! interval; a level's triangles tile the grid, so a build scans every
//! sample about twice per level: `O(n log n)` for `n` samples, in a loop
//! the compiler keeps tight. The halves of the two levels just above the
//! finest (nine in ten of those scanned, of 9 to 45 samples) are read at
//! fixed offsets instead ([`small_half_deviation`]), where setting up their
//! few short rows cost more than the samples. The build scans all halves
//! above the finest level in f32 within a stated margin above these exact
//! scans (`deviation_f32.rs`, `small_half_sweep.rs`); these are the oracle
//! in the tests and the fallback for extreme depths.

use super::grid::Pt;

/// Rows `y0 + dy * k` for `k` in `0..rows`, each the interval
/// `[lo0 + dlo * k, hi0 + dhi * k]`: a trapezoid of samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Trapezoid {
    y0: i64,
    dy: i64,
    rows: i64,
    lo0: i64,
    dlo: i64,
    hi0: i64,
    dhi: i64,
}

impl Trapezoid {
    /// Its rows as `(y, x_lo, x_hi)`.
    #[cfg(test)]
    fn rows(self) -> impl Iterator<Item = (u32, u32, u32)> {
        (0..self.rows).map(move |k| {
            (
                (self.y0 + self.dy * k) as u32,
                (self.lo0 + self.dlo * k) as u32,
                (self.hi0 + self.dhi * k) as u32,
            )
        })
    }
}

/// Calls `f(y, x_lo, x_hi)` on each row of a half, in order.
#[inline(always)]
pub(crate) fn for_each_row((spans, count): HalfRows, mut f: impl FnMut(usize, usize, usize)) {
    for t in &spans[..count] {
        let (mut y, mut lo, mut hi) = (t.y0, t.lo0, t.hi0);
        for _ in 0..t.rows {
            f(y as usize, lo as usize, hi as usize);
            y += t.dy;
            lo += t.dlo;
            hi += t.dhi;
        }
    }
}

/// The interval `(x_lo, x_hi)` of a half's samples on grid row `y`, if it
/// has any there ([`for_each_row`]'s, row by row).
#[inline(always)]
pub(crate) fn half_row((spans, count): HalfRows, y: u32) -> Option<(usize, usize)> {
    let y = i64::from(y);
    spans[..count].iter().find_map(|t| {
        // Rows run one apart, up or down.
        debug_assert!(t.dy.abs() == 1 || t.rows == 0);
        let k = (y - t.y0) * t.dy;
        (0..t.rows)
            .contains(&k)
            .then(|| ((t.lo0 + t.dlo * k) as usize, (t.hi0 + t.dhi * k) as usize))
    })
}

/// The samples of one half of a diamond: one or two trapezoids.
pub(crate) type HalfRows = ([Trapezoid; 2], usize);

/// The rows of the half with apex `apex` of the diamond split by `v`, of
/// half-size `h`, bisecting along a row, a column or a diagonal.
#[inline(always)]
pub(crate) fn half_rows(v: Pt, h: u32, apex: Pt, along_row: bool, diagonal: bool) -> HalfRows {
    let h = i64::from(h);
    let (vx, vy) = (i64::from(v.0), i64::from(v.1));
    let (cx, cy) = (i64::from(apex.0), i64::from(apex.1));
    // The slope of an interval end: +1 widening, -1 narrowing, 0 fixed.
    let span = |y0, dy, rows, lo0, dlo, hi0, dhi| Trapezoid {
        y0,
        dy,
        rows,
        lo0,
        dlo,
        hi0,
        dhi,
    };
    let none = span(0, 0, 0, 0, 0, 0, 0);
    if diagonal {
        // The right angle at the apex: rows from vy - h down; the width
        // 2h - |y - cy| shrinks away from the apex row.
        let (w0, dw) = if cy < vy { (2 * h, -1) } else { (0, 1) };
        let t = if cx < vx {
            span(vy - h, 1, 2 * h + 1, cx, 0, cx + w0, dw)
        } else {
            span(vy - h, 1, 2 * h + 1, cx - w0, -dw, cx, 0)
        };
        ([t, none], 1)
    } else if along_row {
        // From the apex row towards the hypotenuse row, widening both ways.
        let dy = if cy < vy { 1 } else { -1 };
        ([span(cy, dy, h + 1, vx, -1, vx, 1), none], 1)
    } else {
        // The hypotenuse column, with a tent of widths 0..h..0 towards the apex.
        let (up, down) = if cx < vx {
            (
                span(vy - h, 1, h + 1, vx, -1, vx, 0),
                span(vy + 1, 1, h, vx - h + 1, 1, vx, 0),
            )
        } else {
            (
                span(vy - h, 1, h + 1, vx, 0, vx, 1),
                span(vy + 1, 1, h, vx, 0, vx + h - 1, -1),
            )
        };
        ([up, down], 2)
    }
}

/// The gradient `(d/dx, d/dy)` over the grid of the affine interpolation of
/// the depths at `corners`, in f64; `None` for collinear corners.
#[inline(always)]
pub(crate) fn gradient(z: &[f32], gw: usize, [a, b, c]: [Pt; 3]) -> Option<(f64, f64)> {
    let at = |p: Pt| f64::from(z[p.1 as usize * gw + p.0 as usize]);
    let (za, zb, zc) = (at(a), at(b), at(c));
    let (ax, ay) = (f64::from(a.0), f64::from(a.1));
    let (ux, uy) = (f64::from(b.0) - ax, f64::from(b.1) - ay);
    let (vx, vy) = (f64::from(c.0) - ax, f64::from(c.1) - ay);
    let det = ux * vy - uy * vx;
    if det == 0.0 {
        return None;
    }
    let gx = ((zb - za) * vy - uy * (zc - za)) / det;
    let gy = (ux * (zc - za) - (zb - za) * vx) / det;
    Some((gx, gy))
}

/// Largest deviation of the samples in `rows` from the affine interpolation
/// of the corners `(a, b, c)`. All samples in it must be valid. Inlined
/// into the build's pass (about 6 % fewer instructions there).
#[inline(always)]
pub(crate) fn max_deviation(z: &[f32], gw: usize, corners: [Pt; 3], rows: HalfRows) -> f64 {
    let a = corners[0];
    let za = f64::from(z[a.1 as usize * gw + a.0 as usize]);
    let Some((gx, gy)) = gradient(z, gw, corners) else {
        return 0.0;
    };
    // The interpolant's value at (0, 0).
    let origin = za - gy * f64::from(a.1) - gx * f64::from(a.0);
    let mut worst = 0f64;
    for_each_row(
        rows,
        #[inline(always)]
        |y, lo, hi| {
            let start = y * gw;
            let base = origin + gy * f64::from(y as u32) + gx * f64::from(lo as u32);
            let d = row_max_deviation(&z[start + lo..=start + hi], base, gx);
            worst = if d > worst { d } else { worst };
        },
    );
    worst
}

/// The exact deviation of a half of the levels just above the finest, whose
/// half-size `H` (2 or 4) is a constant, so its 9 to 45 samples are read
/// at fixed offsets in straight code: the general scan spends more on
/// setting up its few short rows than on the samples. Every half is a
/// right isosceles triangle with its right angle at the apex `c`.
///
/// An edge midpoint's half (`along`: the flat-index step along the edge
/// `a-b`, `across`: the step from `v` towards `c`) has rows `r = 0..=H`
/// from the edge, each `k = -(H - r)..=H - r` samples along it, where the
/// interpolant is `(z_a + z_b) / 2 + k (z_b - z_a) / 2H + r (z_c - (z_a +
/// z_b) / 2) / H`. A centre's half has legs along the axes, from `c` to
/// `p1` on its row (step `su`) and to `p2` on its column (step `sw`), and
/// samples `c + u su + w sw` with `u + w <= 2H`, where the interpolant is
/// `z_c + u (z_p1 - z_c) / 2H + w (z_p2 - z_c) / 2H`. The divisions are by
/// powers of two, so the interpolant is as exact as the general scan's.
/// The build scans these halves in f32 (`small_half_sweep.rs`); this is
/// its oracle in the tests and its fallback for extreme depths.
#[inline(always)]
pub(crate) fn small_half_deviation<const H: isize>(z: &[f32], shape: SmallHalf) -> f64 {
    let at = |i: isize| f64::from(z[i as usize]);
    let mut worst = 0f64;
    let mut visit = |i: isize, lin: f64| {
        let d = (at(i) - lin).abs();
        worst = if d > worst { d } else { worst };
    };
    match shape {
        SmallHalf::Edge { v, along, across, apex } => {
            let (za, zb, zc) = (at(v - H * along), at(v + H * along), at(apex));
            let mid = 0.5 * (za + zb);
            let g = (zb - za) / (2 * H) as f64;
            let rise = (zc - mid) / H as f64;
            for r in 0..H + 1 {
                let row = v + r * across;
                let base = mid + r as f64 * rise;
                for k in r - H..H - r + 1 {
                    visit(row + k * along, base + k as f64 * g);
                }
            }
        }
        SmallHalf::Centre { apex, su, sw } => {
            let (zc, z1, z2) = (at(apex), at(apex + 2 * H * su), at(apex + 2 * H * sw));
            let (gu, gw) = ((z1 - zc) / (2 * H) as f64, (z2 - zc) / (2 * H) as f64);
            for w in 0..2 * H + 1 {
                let row = apex + w * sw;
                let base = zc + w as f64 * gw;
                for u in 0..2 * H - w + 1 {
                    visit(row + u * su, base + u as f64 * gu);
                }
            }
        }
    }
    worst
}

/// Where a half of the levels just above the finest lies, as flat indices
/// and steps (see [`small_half_deviation`]).
#[derive(Clone, Copy, Debug)]
pub(crate) enum SmallHalf {
    /// The half of an edge midpoint `v`.
    Edge {
        /// The split vertex.
        v: isize,
        /// Step along the bisected edge.
        along: isize,
        /// Step from `v` towards the apex.
        across: isize,
        /// The apex.
        apex: isize,
    },
    /// The half of a centre.
    Centre {
        /// The apex (the right angle).
        apex: isize,
        /// Step along the apex's row towards the other corner on it.
        su: isize,
        /// Step along the apex's column towards the other corner on it.
        sw: isize,
    },
}

/// Largest `|row[i] - (base + i * step)|`: a plain loop for the short rows
/// of fine levels, four independent running maxima for long rows so the
/// loop pipelines (and vectorises where the target allows).
#[inline]
fn row_max_deviation(row: &[f32], base: f64, step: f64) -> f64 {
    if row.len() < 16 {
        let mut worst = 0f64;
        let mut lin = base;
        for &s in row {
            let d = (f64::from(s) - lin).abs();
            worst = if d > worst { d } else { worst };
            lin += step;
        }
        return worst;
    }
    let mut acc = [0f64; 4];
    let mut lin = [base, base + step, base + 2.0 * step, base + 3.0 * step];
    let stride = 4.0 * step;
    let chunks = row.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..4 {
            let d = (f64::from(c[k]) - lin[k]).abs();
            acc[k] = if d > acc[k] { d } else { acc[k] };
            lin[k] += stride;
        }
    }
    for (k, &s) in rest.iter().enumerate() {
        let d = (f64::from(s) - lin[k]).abs();
        acc[k] = if d > acc[k] { d } else { acc[k] };
    }
    acc[0].max(acc[1]).max(acc[2].max(acc[3]))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The eight halves of half-size `h` around a split vertex at `v`: its
    /// corners `[a, b, apex]`, whether the bisected edge runs along a row,
    /// and whether it is a diagonal (a centre's).
    pub(crate) fn halves_around(v: Pt, h: u32) -> Vec<([Pt; 3], bool, bool)> {
        let mut out = Vec::new();
        for c in [(v.0, v.1 - h), (v.0, v.1 + h)] {
            out.push(([(v.0 - h, v.1), (v.0 + h, v.1), c], true, false));
        }
        for c in [(v.0 - h, v.1), (v.0 + h, v.1)] {
            out.push(([(v.0, v.1 - h), (v.0, v.1 + h), c], false, false));
        }
        for (p, q) in [
            ((v.0 - h, v.1 - h), (v.0 + h, v.1 + h)),
            ((v.0 + h, v.1 - h), (v.0 - h, v.1 + h)),
        ] {
            for c in [(p.0, q.1), (q.0, p.1)] {
                out.push(([p, q, c], false, true));
            }
        }
        out
    }

    #[test]
    fn a_plane_has_no_deviation_and_a_bump_is_found() {
        let gw = 9;
        let mut z: Vec<f32> = (0..81)
            .map(|i| 1.0 + (i % 9) as f32 * 0.5 + (i / 9) as f32 * 0.25)
            .collect();
        // Lower-left half of the square (0,0)-(8,8): apex (0, 8).
        let lower_left = || half_rows((4, 4), 4, (0, 8), false, true);
        let upper_right = || half_rows((4, 4), 4, (8, 0), false, true);
        assert!(max_deviation(&z, gw, [(0, 0), (8, 8), (0, 8)], lower_left()) < 1e-9);
        z[6 * 9 + 2] += 3.0; // inside that half
        z[9 + 6] += 7.0; // in the other half
        assert!((max_deviation(&z, gw, [(0, 0), (8, 8), (0, 8)], lower_left()) - 3.0).abs() < 1e-9);
        assert!((max_deviation(&z, gw, [(0, 0), (8, 8), (8, 0)], upper_right()) - 7.0).abs() < 1e-9);
    }

    /// The straight code of the two levels just above the finest scans the
    /// same samples against the same interpolant as the general rows.
    #[test]
    fn small_halves_match_the_general_scan() {
        let gw = 17usize;
        let mut s = 99u64;
        let z: Vec<f32> = (0..gw * gw)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                1.0 + (s >> 40) as f32 / (1u64 << 24) as f32
            })
            .collect();
        let at = |p: Pt| p.1 as isize * gw as isize + p.0 as isize;
        let sign = |from: u32, to: u32| if to < from { -1 } else { 1 };
        let mut checked = 0;
        for h in [2u32, 4] {
            let v = (8u32, 8u32);
            for ([a, b, c], along_row, diagonal) in halves_around(v, h) {
                let reference = max_deviation(&z, gw, [a, b, c], half_rows(v, h, c, along_row, diagonal));
                let shape = if diagonal {
                    let (p1, p2) = if a.1 == c.1 { (a, b) } else { (b, a) };
                    SmallHalf::Centre {
                        apex: at(c),
                        su: sign(c.0, p1.0),
                        sw: sign(c.1, p2.1) * gw as isize,
                    }
                } else if along_row {
                    SmallHalf::Edge {
                        v: at(v),
                        along: 1,
                        across: sign(v.1, c.1) * gw as isize,
                        apex: at(c),
                    }
                } else {
                    SmallHalf::Edge {
                        v: at(v),
                        along: gw as isize,
                        across: sign(v.0, c.0),
                        apex: at(c),
                    }
                };
                let fast = match h {
                    2 => small_half_deviation::<2>(&z, shape),
                    _ => small_half_deviation::<4>(&z, shape),
                };
                assert!(reference > 0.01, "the samples are rough");
                assert!(
                    (fast - reference).abs() <= 1e-12,
                    "h {h} apex {c:?}: {fast} against {reference}"
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 16);
    }

    #[test]
    fn half_rows_cover_exactly_the_half() {
        // Count samples: a half of side 2h holds (2h + 1)(2h + 2) / 2 samples,
        // an edge-midpoint half (h + 1)^2.
        let all = |(t, n): HalfRows| t.into_iter().take(n).flat_map(Trapezoid::rows).collect::<Vec<_>>();
        let n = |r: HalfRows| all(r).iter().map(|&(_, lo, hi)| hi - lo + 1).sum::<u32>();
        assert_eq!(n(half_rows((4, 4), 4, (0, 8), false, true)), 45);
        assert_eq!(n(half_rows((4, 4), 4, (4, 0), true, false)), 25);
        assert_eq!(n(half_rows((4, 4), 4, (8, 4), false, false)), 25);
        let rows = all(half_rows((4, 4), 4, (0, 4), false, false));
        assert_eq!(rows[0], (0, 4, 4));
        assert_eq!(rows[4], (4, 0, 4));
    }

    #[test]
    fn half_rows_are_exactly_the_samples_of_the_triangle() {
        let cross = |o: (i64, i64), p: (i64, i64), q: (i64, i64)| (p.0 - o.0) * (q.1 - o.1) - (p.1 - o.1) * (q.0 - o.0);
        for h in 1..=6i64 {
            let (vx, vy) = (8i64, 8i64);
            let mut cases = Vec::new();
            for (cx, cy) in [(vx - h, vy - h), (vx + h, vy - h), (vx - h, vy + h), (vx + h, vy + h)] {
                cases.push((true, false, (cx, cy), (cx, 2 * vy - cy), (2 * vx - cx, cy)));
            }
            for cy in [vy - h, vy + h] {
                cases.push((false, true, (vx, cy), (vx - h, vy), (vx + h, vy)));
            }
            for cx in [vx - h, vx + h] {
                cases.push((false, false, (cx, vy), (vx, vy - h), (vx, vy + h)));
            }
            for (diagonal, along_row, c, a, b) in cases {
                let pt = |p: (i64, i64)| (p.0 as u32, p.1 as u32);
                let (spans, n) = half_rows(pt((vx, vy)), h as u32, pt(c), along_row, diagonal);
                let mut got: Vec<(i64, i64)> = spans[..n]
                    .iter()
                    .flat_map(|t| t.rows())
                    .flat_map(|(y, lo, hi)| (lo..=hi).map(move |x| (i64::from(x), i64::from(y))))
                    .collect();
                got.sort_unstable();
                let mut want = Vec::new();
                for y in 0..=16 {
                    for x in 0..=16 {
                        let s = [cross(a, b, (x, y)), cross(b, c, (x, y)), cross(c, a, (x, y))];
                        if s.iter().all(|&d| d >= 0) || s.iter().all(|&d| d <= 0) {
                            want.push((x, y));
                        }
                    }
                }
                want.sort_unstable();
                assert_eq!(got, want, "h {h} apex {c:?} diagonal {diagonal} row {along_row}");
            }
        }
    }
}
