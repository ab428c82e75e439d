//! The forest grid and the geometry of its 4-8 (restricted quadtree) hierarchy.
//!
//! DESIGN.md "Grid" and "Structure"; DMesh Sec. 3, Fig. 1-3. The image is
//! covered by `(m * 2^k + 1) x (n * 2^k + 1)` vertices: a forest of `m x n`
//! root quads of side `S = 2^k`, padded with invalid samples. Every vertex that
//! is not a root corner is the *split vertex* of exactly one diamond:
//!
//! - a **centre** (D-type, DMesh Fig. 1b): both coordinates are odd multiples of
//!   `h = 2^g`; it bisects the diagonal of the square of side `2h` around it. The
//!   diagonal runs through the square's corner whose coordinates are both odd
//!   multiples of `2h` (for a non-root square, the centre of its parent square),
//!   which is what makes the hierarchy a conforming 4-8 mesh;
//! - an **edge midpoint** (A-type, Fig. 1c): one coordinate is an odd multiple of
//!   `h = 2^g`, the other a multiple of `2h`; it bisects an axis-aligned edge of
//!   length `2h`, shared by the squares on either side (across root boundaries too).
//!
//! The diamond of a split vertex is the pair of triangles whose hypotenuse it
//! bisects; its *halves* are numbered 0 and 1 by their apex: half 0 has the apex
//! with the smaller x (or, at equal x, the smaller y). The split vertex depends
//! on the two apexes (DMesh Fig. 3), and its children are the midpoints of the
//! legs of both halves. The finest triangles (two per unit cell) have no split
//! vertex; a cell's diagonal runs through its corner with both coordinates odd.

// The geometry of one diamond is the wire's (`dmesh_proto::diamond`), stated
// once for the engine and for clients that decode without it.
pub use dmesh_proto::diamond::{Diamond, Kind, Pt};

/// Layout of the padded grid over a `width x height` image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    /// Image width in samples.
    pub width: u32,
    /// Image height in samples.
    pub height: u32,
    /// Root quad side is `2^k`.
    pub k: u32,
    /// Root quads across.
    pub m: u32,
    /// Root quads down.
    pub n: u32,
}

impl Grid {
    /// Chooses `k` for a `width x height` image (both >= 2): the largest root
    /// side whose padding adds at most 10 % vertices (so coarse meshes stay
    /// coarse), else the `k` with the least padding.
    pub fn for_image(width: u32, height: u32) -> Self {
        let (w, h) = (u64::from(width), u64::from(height));
        let area = w * h;
        let padded = |k: u32| {
            let s = 1u64 << k;
            let gw = (w - 1).div_ceil(s) * s + 1;
            let gh = (h - 1).div_ceil(s) * s + 1;
            gw * gh
        };
        let longest = (w.max(h) - 1).max(1);
        let kmax = (64 - longest.leading_zeros()).clamp(1, 15);
        let chosen = (1..=kmax)
            .rev()
            .find(|&k| padded(k) * 10 <= area * 11)
            .unwrap_or_else(|| (1..=kmax).min_by_key(|&k| (padded(k), u32::MAX - k)).unwrap_or(1));
        let s = 1u32 << chosen;
        Self {
            width,
            height,
            k: chosen,
            m: (width - 1).div_ceil(s),
            n: (height - 1).div_ceil(s),
        }
    }

    /// Root quad side `2^k`.
    pub fn side(&self) -> u32 {
        1 << self.k
    }

    /// Vertices across.
    pub fn gw(&self) -> u32 {
        self.m * self.side() + 1
    }

    /// Vertices down.
    pub fn gh(&self) -> u32 {
        self.n * self.side() + 1
    }

    /// Number of grid vertices, padding included.
    pub fn len(&self) -> usize {
        self.gw() as usize * self.gh() as usize
    }

    /// Never true: a grid has at least 3 x 3 vertices.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Row-major index of a vertex.
    #[inline]
    pub fn index(&self, (x, y): Pt) -> usize {
        y as usize * self.gw() as usize + x as usize
    }

    /// True when the vertex lies inside the image (not padding).
    #[inline]
    pub fn in_image(&self, (x, y): Pt) -> bool {
        x < self.width && y < self.height
    }

    /// True when the vertex lies on the grid.
    #[inline]
    pub fn contains(&self, x: i64, y: i64) -> bool {
        x >= 0 && y >= 0 && x < i64::from(self.gw()) && y < i64::from(self.gh())
    }

    /// Classifies a vertex.
    #[inline]
    pub fn kind(&self, p: Pt) -> Kind {
        dmesh_proto::diamond::kind(p, self.side())
    }

    /// Coarse-to-fine level: 0 for root corners, then centres and edge
    /// midpoints alternate from the root side down to the unit cells.
    #[inline]
    pub fn level(&self, p: Pt) -> u32 {
        dmesh_proto::diamond::level(p, self.side())
    }

    /// The hypotenuse endpoints `(a, b)` and the apexes of halves 0 and 1 of
    /// the diamond split by `v` (an apex outside the grid means that half does
    /// not exist). `None` for root corners.
    #[inline]
    pub fn diamond(&self, v: Pt) -> Option<Diamond> {
        dmesh_proto::diamond::diamond(v, self.side())
    }

    /// The unit cell with min corner `c`: its diagonal endpoints and the apexes
    /// of its halves 0 (apex at x = c.x) and 1 (apex at x = c.x + 1).
    pub fn cell(&self, c: Pt) -> Diamond {
        let (x, y) = (i64::from(c.0), i64::from(c.1));
        let px = if x % 2 == 1 { x } else { x + 1 };
        let py = if y % 2 == 1 { y } else { y + 1 };
        let (qx, qy) = (2 * x + 1 - px, 2 * y + 1 - py);
        let (c1, c2) = ((px, qy), (qx, py));
        let apex = if c1.0 < c2.0 { [c1, c2] } else { [c2, c1] };
        Diamond {
            a: (px, py),
            b: (qx, qy),
            apex,
        }
    }

    /// The corners of half `half` of the unit cell with min corner `c`: a
    /// full-resolution triangle, diagonal ends first.
    #[inline]
    pub fn cell_triangle(&self, c: Pt, half: usize) -> [Pt; 3] {
        let d = self.cell(c);
        // Written out, not by `map` (see `segmentation::cell_flags`).
        let pt = |(x, y): (_, _)| (x as u32, y as u32);
        [pt(d.a), pt(d.b), pt(d.apex[half])]
    }
}

/// Which half of the diamond split by `m` has apex `apex`.
#[inline]
pub fn half_of(m: Pt, apex: Pt) -> usize {
    usize::from(!(apex.0 < m.0 || (apex.0 == m.0 && apex.1 < m.1)))
}

/// Which half of the unit cell with min corner `cell` has apex `apex`.
#[inline]
pub fn cell_half(cell: Pt, apex: Pt) -> usize {
    usize::from(apex.0 != cell.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_sizes_pad_little() {
        let g = Grid::for_image(513, 513);
        assert_eq!((g.k, g.m, g.n, g.gw(), g.gh()), (9, 1, 1, 513, 513));
        let g = Grid::for_image(640, 480);
        assert_eq!((g.gw(), g.gh()), (641, 481 + 32));
        let g = Grid::for_image(2, 2);
        assert_eq!((g.gw(), g.gh()), (3, 3));
        for (w, h) in [(3, 7), (1390, 1110), (1920, 1080), (2, 1000)] {
            let g = Grid::for_image(w, h);
            assert!(g.gw() >= w && g.gh() >= h, "{g:?}");
        }
    }

    #[test]
    fn every_vertex_but_roots_splits_a_diamond_whose_hypotenuse_it_bisects() {
        let g = Grid::for_image(17, 9);
        for y in 0..g.gh() {
            for x in 0..g.gw() {
                match g.diamond((x, y)) {
                    None => assert_eq!(g.kind((x, y)), Kind::Root),
                    Some(d) => {
                        assert_eq!(d.a.0 + d.b.0, 2 * i64::from(x));
                        assert_eq!(d.a.1 + d.b.1, 2 * i64::from(y));
                        assert!(g.contains(d.a.0, d.a.1) && g.contains(d.b.0, d.b.1));
                        assert!(d.apex[0] < d.apex[1]);
                    }
                }
            }
        }
    }

    #[test]
    fn the_wire_parent_edge_is_the_diamond_hypotenuse() {
        for (w, h) in [(17, 9), (33, 33), (40, 7)] {
            let g = Grid::for_image(w, h);
            for y in 0..g.gh() {
                for x in 0..g.gw() {
                    let wire = dmesh_proto::residual::parent_edge((x, y), g.side());
                    let engine = g.diamond((x, y)).map(|d| {
                        let p = |q: (i64, i64)| (q.0 as u32, q.1 as u32);
                        (p(d.a), p(d.b))
                    });
                    let sorted = |e: Option<((u32, u32), (u32, u32))>| e.map(|(a, b)| (a.min(b), a.max(b)));
                    assert_eq!(sorted(wire), sorted(engine), "({x}, {y}) in {w}x{h}");
                }
            }
        }
    }

    #[test]
    fn the_compact_stream_forest_is_this_grid() {
        for (w, h) in [(17, 9), (33, 33), (40, 7), (2, 2)] {
            let g = Grid::for_image(w, h);
            let f = crate::wire_compact::forest(&g);
            assert_eq!((f.gw(), f.gh(), f.levels()), (g.gw(), g.gh(), 2 * g.k as usize + 1));
            for y in 0..g.gh() {
                for x in 0..g.gw() {
                    let d = f.diamond((x, y)).map(|d| (d.a, d.b, d.apex));
                    assert_eq!(d, g.diamond((x, y)).map(|d| (d.a, d.b, d.apex)), "({x}, {y})");
                    assert_eq!(f.level((x, y)), g.level((x, y)));
                }
            }
        }
    }

    #[test]
    fn sub_square_diagonals_run_through_the_parent_centre() {
        let g = Grid::for_image(9, 9);
        // Square of side 2 around (1, 1) lies in the root square centred (4, 4)?
        // No: its parent is the side-4 square centred at (2, 2).
        let d = g.diamond((1, 1)).unwrap();
        assert!(d.a == (2, 2) || d.b == (2, 2), "{d:?}");
        let d = g.diamond((3, 5)).unwrap();
        assert!(d.a == (2, 6) || d.b == (2, 6), "{d:?}");
    }
}
