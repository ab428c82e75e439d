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

/// The rows of one half of a diamond, as `(y, x_lo, x_hi)`.
pub(crate) struct HalfRows {
    shape: Shape,
    h: i64,
    v: (i64, i64),
    apex: (i64, i64),
    k: i64,
    count: i64,
}

#[derive(Clone, Copy)]
enum Shape {
    /// Centre: the half of the square around `v` with its right angle at the apex.
    Diagonal,
    /// Edge midpoint on a row: rows from the apex to the hypotenuse.
    Row,
    /// Edge midpoint on a column: rows of the hypotenuse column.
    Column,
}

/// The rows of the half with apex `apex` of the diamond split by `v`, of
/// half-size `h`, bisecting along a row, a column or a diagonal.
pub(crate) fn half_rows(v: Pt, h: u32, apex: Pt, along_row: bool, diagonal: bool) -> HalfRows {
    let shape = if diagonal {
        Shape::Diagonal
    } else if along_row {
        Shape::Row
    } else {
        Shape::Column
    };
    let h = i64::from(h);
    let count = if matches!(shape, Shape::Row) { h + 1 } else { 2 * h + 1 };
    HalfRows {
        shape,
        h,
        v: (i64::from(v.0), i64::from(v.1)),
        apex: (i64::from(apex.0), i64::from(apex.1)),
        k: 0,
        count,
    }
}

impl Iterator for HalfRows {
    type Item = (u32, u32, u32);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if self.k >= self.count {
            return None;
        }
        let (k, h, (vx, vy), (cx, cy)) = (self.k, self.h, self.v, self.apex);
        self.k += 1;
        let (y, lo, hi) = match self.shape {
            Shape::Diagonal => {
                let y = vy - h + k;
                let w = 2 * h - (y - cy).abs();
                if cx < vx {
                    (y, cx, cx + w)
                } else {
                    (y, cx - w, cx)
                }
            }
            Shape::Row => (if cy < vy { cy + k } else { cy - k }, vx - k, vx + k),
            Shape::Column => {
                let y = vy - h + k;
                let w = h - (y - vy).abs();
                if cx < vx {
                    (y, vx - w, vx)
                } else {
                    (y, vx, vx + w)
                }
            }
        };
        Some((y as u32, lo as u32, hi as u32))
    }
}

/// Largest deviation of the samples in `rows` from the affine interpolation
/// of the corners `(a, b, c)`. All samples in it must be valid.
pub(crate) fn max_deviation(
    z: &[f32],
    gw: usize,
    [a, b, c]: [Pt; 3],
    rows: impl Iterator<Item = (u32, u32, u32)>,
) -> f64 {
    let at = |p: Pt| f64::from(z[p.1 as usize * gw + p.0 as usize]);
    let (za, zb, zc) = (at(a), at(b), at(c));
    let (ax, ay) = (f64::from(a.0), f64::from(a.1));
    let (ux, uy) = (f64::from(b.0) - ax, f64::from(b.1) - ay);
    let (vx, vy) = (f64::from(c.0) - ax, f64::from(c.1) - ay);
    let det = ux * vy - uy * vx;
    if det == 0.0 {
        return 0.0;
    }
    // Gradient of the interpolant over the grid.
    let gx = ((zb - za) * vy - uy * (zc - za)) / det;
    let gy = (ux * (zc - za) - (zb - za) * vx) / det;
    let mut worst = 0f64;
    for (y, lo, hi) in rows {
        let start = y as usize * gw;
        let base = za + gy * (f64::from(y) - ay) + gx * (f64::from(lo) - ax);
        worst = worst.max(row_max_deviation(
            &z[start + lo as usize..=start + hi as usize],
            base,
            gx,
        ));
    }
    worst
}

/// Largest `|row[i] - (base + i * step)|`, with four independent running
/// maxima so the loop pipelines (and vectorises where the target allows).
#[inline]
fn row_max_deviation(row: &[f32], base: f64, step: f64) -> f64 {
    if row.len() < 8 {
        let mut worst = 0f64;
        for (i, &s) in row.iter().enumerate() {
            let d = (f64::from(s) - (base + step * i as f64)).abs();
            worst = if d > worst { d } else { worst };
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
        let n = |it: HalfRows| it.map(|(_, lo, hi)| hi - lo + 1).sum::<u32>();
        assert_eq!(n(half_rows((4, 4), 4, (0, 8), false, true)), 45);
        assert_eq!(n(half_rows((4, 4), 4, (4, 0), true, false)), 25);
        assert_eq!(n(half_rows((4, 4), 4, (8, 4), false, false)), 25);
        let rows: Vec<_> = half_rows((4, 4), 4, (0, 4), false, false).collect();
        assert_eq!(rows[0], (0, 4, 4));
        assert_eq!(rows[4], (4, 0, 4));
    }
}
