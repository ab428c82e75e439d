//! The 4-8 hierarchy's diamonds: which edge a grid vertex bisects, and the
//! two triangles that share that edge (DESIGN.md "Grid"; DMesh Sec. 3,
//! Fig. 1-3).
//!
//! The grid is a forest of root quads of side `S` (a power of two). Every
//! vertex that is not a root corner is the split vertex of exactly one
//! diamond:
//!
//! - a **centre** (D-type, DMesh Fig. 1b): both coordinates are odd multiples
//!   of `h`; it bisects the diagonal of the square of side `2h` around it,
//!   the one through the corner whose coordinates are both odd multiples of
//!   `2h`;
//! - an **edge midpoint** (A-type, Fig. 1c): one coordinate is an odd multiple
//!   of `h`, the other a multiple of `2h`; it bisects the axis-aligned edge of
//!   length `2h` along its odd coordinate.
//!
//! The halves of a diamond are numbered by their apex: half 0 has the apex
//! with the smaller x (or, at equal x, the smaller y).
//!
//! This is the one statement of that geometry. The engine's grid, the
//! compact stream's forest and the residual depths' predictor all call it,
//! because a client decodes without the engine.

/// A grid vertex `(x, y)`: column and row.
pub type Pt = (u32, u32);

/// The kind of a grid vertex in the hierarchy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A corner of a root quad: in every mesh.
    Root,
    /// Centre of a square of side `2 * h` (bisects a diagonal).
    Centre {
        /// Half the square's side.
        h: u32,
    },
    /// Midpoint of an axis-aligned edge of length `2 * h`.
    Edge {
        /// Half the edge's length.
        h: u32,
        /// True when the edge is horizontal (runs along x).
        horizontal: bool,
    },
}

/// The hypotenuse `a-b` a split vertex bisects and the apexes of the two
/// triangles that share it (signed: an apex off the grid means that half
/// does not exist).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Diamond {
    /// One hypotenuse endpoint.
    pub a: (i64, i64),
    /// The other.
    pub b: (i64, i64),
    /// Apexes of halves 0 and 1 (half 0 has the smaller x, then y).
    pub apex: [(i64, i64); 2],
}

/// Classifies `(x, y)` in a forest of root quads of side `root_side` (a
/// power of two, at least 2, which callers check where it comes from
/// outside).
#[inline]
pub fn kind((x, y): Pt, root_side: u32) -> Kind {
    if x % root_side == 0 && y % root_side == 0 {
        return Kind::Root;
    }
    // Zero is a multiple of every power of two: cap at the root's.
    let k = root_side.trailing_zeros();
    let tz = |c: u32| if c == 0 { k } else { c.trailing_zeros().min(k) };
    let (tx, ty) = (tz(x), tz(y));
    let h = 1 << tx.min(ty);
    if tx == ty {
        Kind::Centre { h }
    } else {
        Kind::Edge { h, horizontal: tx < ty }
    }
}

/// Coarse-to-fine level: 0 for root corners, then centres and edge
/// midpoints alternate from the root side down to the unit cells.
#[inline]
pub fn level(p: Pt, root_side: u32) -> u32 {
    let k = root_side.trailing_zeros();
    match kind(p, root_side) {
        Kind::Root => 0,
        Kind::Centre { h } => 2 * (k - 1 - h.trailing_zeros()) + 1,
        Kind::Edge { h, .. } => 2 * (k - 1 - h.trailing_zeros()) + 2,
    }
}

/// The diamond split by `v` in a forest of root quads of side `root_side`,
/// `None` for root corners.
#[inline]
pub fn diamond(v: Pt, root_side: u32) -> Option<Diamond> {
    let (x, y) = (i64::from(v.0), i64::from(v.1));
    Some(match kind(v, root_side) {
        Kind::Root => return None,
        Kind::Edge { h, horizontal: true } => {
            let h = i64::from(h);
            Diamond {
                a: (x - h, y),
                b: (x + h, y),
                apex: [(x, y - h), (x, y + h)],
            }
        }
        Kind::Edge { h, horizontal: false } => {
            let h = i64::from(h);
            Diamond {
                a: (x, y - h),
                b: (x, y + h),
                apex: [(x - h, y), (x + h, y)],
            }
        }
        Kind::Centre { h } => {
            // Of c - h and c + h, the odd multiple of 2h (h a power of two,
            // c >= h): a shift, not a division.
            let shift = h.trailing_zeros() + 1;
            let h = i64::from(h);
            let odd = |c: i64| if ((c - h) >> shift) & 1 == 1 { c - h } else { c + h };
            let (px, py) = (odd(x), odd(y));
            let (qx, qy) = (2 * x - px, 2 * y - py);
            // The apexes are the square's other two corners.
            let (c1, c2) = ((px, qy), (qx, py));
            Diamond {
                a: (px, py),
                b: (qx, qy),
                apex: if c1.0 < c2.0 { [c1, c2] } else { [c2, c1] },
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The midpoint of every diamond's hypotenuse is its split vertex, the
    /// apexes are the hypotenuse turned by a right angle about it, and the
    /// hypotenuse's ends are coarser than the vertex.
    #[test]
    fn every_vertex_but_the_roots_bisects_a_coarser_hypotenuse() {
        for side in [2, 4, 8, 16] {
            for y in 0..=2 * side {
                for x in 0..=3 * side {
                    let Some(d) = diamond((x, y), side) else {
                        assert_eq!((x % side, y % side), (0, 0));
                        continue;
                    };
                    let (vx, vy) = (i64::from(x), i64::from(y));
                    assert_eq!((d.a.0 + d.b.0, d.a.1 + d.b.1), (2 * vx, 2 * vy), "({x}, {y})");
                    let (hx, hy) = ((d.b.0 - d.a.0) / 2, (d.b.1 - d.a.1) / 2);
                    let mut turned = [(vx - hy, vy + hx), (vx + hy, vy - hx)];
                    turned.sort();
                    assert_eq!(d.apex, turned, "({x}, {y})");
                    for end in [d.a, d.b] {
                        if end.0 >= 0 && end.1 >= 0 {
                            let e = (end.0 as u32, end.1 as u32);
                            assert!(level(e, side) < level((x, y), side), "({x}, {y}) <- {e:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn a_centre_bisects_the_diagonal_through_its_parents_centre() {
        // In a root of side 8, (2, 2) is the centre of the square [0, 4]^2,
        // whose corner (4, 4) is the root's centre.
        let d = diamond((2, 2), 8).unwrap();
        assert_eq!((d.a, d.b), ((4, 4), (0, 0)));
        assert_eq!(d.apex, [(0, 4), (4, 0)]);
        assert_eq!(kind((4, 4), 8), Kind::Centre { h: 4 });
        assert_eq!(kind((4, 0), 8), Kind::Edge { h: 4, horizontal: true });
        assert_eq!(
            kind((0, 4), 8),
            Kind::Edge {
                h: 4,
                horizontal: false
            }
        );
        assert_eq!((level((4, 4), 8), level((4, 0), 8), level((2, 2), 8)), (1, 2, 3));
    }
}
