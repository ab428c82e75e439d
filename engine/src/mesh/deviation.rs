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
//! the compiler keeps tight.

use super::grid::Pt;

/// Rows `y0 + dy * k` for `k` in `0..rows`, each the interval
/// `[lo0 + dlo * k, hi0 + dhi * k]`: a trapezoid of samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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

/// Largest deviation of the samples in `rows` from the affine interpolation
/// of the corners `(a, b, c)`. All samples in it must be valid. Inlined
/// into the build's pass (about 6 % fewer instructions there).
#[inline(always)]
pub(crate) fn max_deviation(z: &[f32], gw: usize, [a, b, c]: [Pt; 3], (spans, count): HalfRows) -> f64 {
    let at = |p: Pt| f64::from(z[p.1 as usize * gw + p.0 as usize]);
    let (za, zb, zc) = (at(a), at(b), at(c));
    let (ax, ay) = (f64::from(a.0), f64::from(a.1));
    let (ux, uy) = (f64::from(b.0) - ax, f64::from(b.1) - ay);
    let (vx, vy) = (f64::from(c.0) - ax, f64::from(c.1) - ay);
    let det = ux * vy - uy * vx;
    if det == 0.0 {
        return 0.0;
    }
    // Gradient of the interpolant over the grid, and its value at (0, 0).
    let gx = ((zb - za) * vy - uy * (zc - za)) / det;
    let gy = (ux * (zc - za) - (zb - za) * vx) / det;
    let origin = za - gy * ay - gx * ax;
    let mut worst = 0f64;
    for t in &spans[..count] {
        let (mut y, mut lo, mut hi) = (t.y0, t.lo0, t.hi0);
        for _ in 0..t.rows {
            let start = y as usize * gw;
            let base = origin + gy * y as f64 + gx * lo as f64;
            let d = row_max_deviation(&z[start + lo as usize..=start + hi as usize], base, gx);
            worst = if d > worst { d } else { worst };
            y += t.dy;
            lo += t.dlo;
            hi += t.dhi;
        }
    }
    worst
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
mod tests {
    use super::*;

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
