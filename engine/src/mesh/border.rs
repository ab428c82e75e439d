//! The image border of a padded grid (DESIGN.md "Grid"): padding is outside
//! the image, not invalid data in it.
//!
//! An image whose size is not `m * 2^k + 1` is covered by a grid padded with
//! invalid samples on its right and bottom. A coarse triangle that reaches
//! over the last column or row into that padding touches invalid samples, so
//! segmentation drops it (DMesh Sec. 5.3), and without more the mesh would end
//! in a sawtooth a few pixels inside the image at coarse tolerances. So every
//! split vertex with a half that covers part of the image and has a corner
//! in the padding is made always active (its saturated error set to [`FORCED`]), and so are its
//! ancestors (the apexes it depends on, DMesh Fig. 3), which keeps selection
//! monotone and the mesh conforming. Then no emitted triangle straddles the
//! border: each lies inside the image, or in the padding where segmentation
//! drops it, and at every tolerance the triangles cover the image rectangle
//! exactly as at `2^k + 1` sizes. The cost is a band of fine triangles along
//! the padded borders only, `O(width + height)` vertices, and none where a
//! border falls on a coarse grid line.

use super::grid::{Grid, Kind, Pt};

/// The saturated squared error of a vertex that every extraction selects
/// (both selectors treat it as active whatever the tolerance; it is finite,
/// like every error the engine hands out).
pub const FORCED: f32 = f32::MAX;

/// Twice the area of the part of triangle `t` inside the image quadrant
/// `x <= lx, y <= ly` (the triangle clipped by both lines).
fn area2_inside(t: [(f64, f64); 3], lx: f64, ly: f64) -> f64 {
    /// A convex polygon of at most five corners: a triangle clipped by two
    /// lines (each cut adds at most one corner). On the stack: the border
    /// pass clips a few thousand triangles per build.
    struct Poly {
        corners: [(f64, f64); 5],
        len: usize,
    }
    impl Poly {
        fn corners(&self) -> &[(f64, f64)] {
            &self.corners[..self.len]
        }
        fn push(&mut self, p: (f64, f64)) {
            self.corners[self.len] = p;
            self.len += 1;
        }
    }
    fn clip(poly: &[(f64, f64)], inside: impl Fn((f64, f64)) -> f64) -> Poly {
        let mut out = Poly {
            corners: [(0.0, 0.0); 5],
            len: 0,
        };
        for (k, &p) in poly.iter().enumerate() {
            let q = poly[(k + 1) % poly.len()];
            let (dp, dq) = (inside(p), inside(q));
            if dp >= 0.0 {
                out.push(p);
            }
            if (dp >= 0.0) != (dq >= 0.0) {
                let s = dp / (dp - dq);
                out.push((p.0 + s * (q.0 - p.0), p.1 + s * (q.1 - p.1)));
            }
        }
        out
    }
    let poly = clip(&t, |p| lx - p.0);
    let poly = clip(poly.corners(), |p| ly - p.1);
    let poly = poly.corners();
    let n = poly.len();
    (0..n)
        .map(|k| {
            let (p, q) = (poly[k], poly[(k + 1) % n]);
            p.0 * q.1 - q.0 * p.1
        })
        .sum::<f64>()
        .abs()
}

/// Whether a half of the diamond split by `v` straddles the image border:
/// it has a corner in the padding and covers part of the image (a half
/// that only touches the image along an edge lies in the padding).
fn straddles(grid: &Grid, v: Pt) -> bool {
    let Some(d) = grid.diamond(v) else { return false };
    let (lx, ly) = (i64::from(grid.width) - 1, i64::from(grid.height) - 1);
    d.apex.iter().filter(|a| grid.contains(a.0, a.1)).any(|&apex| {
        let t = [d.a, d.b, apex];
        let padding = t.iter().any(|p| p.0 > lx || p.1 > ly);
        padding && area2_inside(t.map(|p| (p.0 as f64, p.1 as f64)), lx as f64, ly as f64) > 0.0
    })
}

/// Marks every split vertex whose diamond straddles the image border, and
/// every vertex it depends on, as always active. Does nothing when the grid
/// fits the image exactly.
pub(crate) fn force_border(grid: &Grid, err2: &mut [f32]) {
    let (gw, gh) = (grid.gw(), grid.gh());
    if gw == grid.width && gh == grid.height {
        return;
    }
    let (lx, ly) = (grid.width - 1, grid.height - 1);
    let mut work: Vec<Pt> = Vec::new();
    // Per level of half-size h, only vertices within h of the last column
    // or row can straddle: a few lattice lines per level.
    let mut h = 1;
    while h < grid.side() {
        let near = |last: u32, extent: u32| {
            let lo = last.saturating_sub(h) / h * h;
            let hi = (last + h).min(extent - 1);
            (lo..=hi).step_by(h as usize)
        };
        let mut visit = |p: Pt| {
            if err2[grid.index(p)] != FORCED {
                let kind = grid.kind(p);
                if matches!(kind, Kind::Centre { h: k } | Kind::Edge { h: k, .. } if k == h) && straddles(grid, p) {
                    err2[grid.index(p)] = FORCED;
                    work.push(p);
                }
            }
        };
        for x in near(lx, gw) {
            for y in (0..gh).step_by(h as usize) {
                visit((x, y));
            }
        }
        for y in near(ly, gh) {
            for x in (0..gw).step_by(h as usize) {
                visit((x, y));
            }
        }
        h *= 2;
    }
    // Ancestors: a vertex is selected only with both apexes of its diamond.
    while let Some(v) = work.pop() {
        let Some(d) = grid.diamond(v) else { continue };
        for (ax, ay) in d.apex {
            if !grid.contains(ax, ay) {
                continue;
            }
            let a = (ax as u32, ay as u32);
            if grid.kind(a) != Kind::Root && err2[grid.index(a)] != FORCED {
                err2[grid.index(a)] = FORCED;
                work.push(a);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_grids_force_nothing_and_padded_ones_only_near_the_border() {
        let exact = Grid::for_image(65, 33);
        let mut e = vec![0f32; exact.len()];
        force_border(&exact, &mut e);
        assert!(e.iter().all(|&v| v == 0.0));

        let g = Grid::for_image(50, 37);
        assert!(g.gw() > 50 || g.gh() > 37, "padded");
        let mut e = vec![0f32; g.len()];
        force_border(&g, &mut e);
        let forced: Vec<Pt> = (0..g.gh())
            .flat_map(|y| (0..g.gw()).map(move |x| (x, y)))
            .filter(|&p| e[g.index(p)] == FORCED)
            .collect();
        assert!(!forced.is_empty());
        // Every forced vertex's ancestors are forced too.
        for &p in &forced {
            for (ax, ay) in g.diamond(p).unwrap().apex {
                if g.contains(ax, ay) && g.kind((ax as u32, ay as u32)) != Kind::Root {
                    assert_eq!(e[g.index((ax as u32, ay as u32))], FORCED, "apex of {p:?}");
                }
            }
        }
        // The finest vertices forced hug the border.
        for &p in forced.iter().filter(|&&p| matches!(g.kind(p), Kind::Edge { h: 1, .. })) {
            assert!(p.0.abs_diff(49) <= 1 || p.1.abs_diff(36) <= 1, "{p:?}");
        }
    }
}
