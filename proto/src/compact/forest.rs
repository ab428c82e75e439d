//! The restricted-quadtree forest as a decoder sees it, and its one canonical
//! walk (DESIGN.md "Structure"; DMesh Sec. 3, Fig. 1-3; Lindstrom and
//! Pascucci's top-down refinement).
//!
//! A served mesh is the set of leaf triangles of a walk of the right-triangle
//! bintree: root quads in boustrophedon order, each as the two halves of its
//! diagonal, every triangle split at the midpoint of its hypotenuse into the
//! child on its entry side first (Sierpinski order). The walk asks a
//! [`Decide`] what each triangle is (split, emitted, skipped) unless the
//! dependency rules already say it: a vertex that is split, or the apex
//! opposite a split triangle's (`2m - a`: the other triangle of the split
//! vertex's diamond exists, so its parent split there), is split wherever
//! the walk meets it again. (The dependency closure is transitive; the
//! stream marks one step of it, which every client can do with two stores,
//! and the next step is marked when the walk splits that vertex.) The encoder and the decoder run this
//! same walk, so whatever it does not ask for costs no bits.
//!
//! The geometry of a diamond is [`crate::diamond`]'s, which the engine's grid
//! calls too.

pub use crate::diamond::{Diamond, Pt};

/// Largest number of grid vertices a stream may describe (a 16,384 x 4,096
/// image), so a decoder's work and memory are bounded by its header.
pub const MAX_GRID_VERTICES: u64 = 1 << 26;

/// The forest: `m x n` root quads of side `side` (a power of two, at least 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Forest {
    /// Root quad side.
    pub side: u32,
    /// Root quads across.
    pub m: u32,
    /// Root quads down.
    pub n: u32,
}

/// What a triangle of the walk is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Symbol {
    /// Split at its hypotenuse's midpoint.
    Split,
    /// A leaf of the mesh: drawn.
    Emit,
    /// A leaf left out (segmented, or outside the requesting view).
    Skip,
}

/// A triangle of the walk: hypotenuse `l-r`, apex `a`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Node {
    /// Hypotenuse endpoint the walk enters at.
    pub l: Pt,
    /// Hypotenuse endpoint the walk leaves at.
    pub r: Pt,
    /// Right-angle corner.
    pub a: Pt,
}

impl Node {
    /// True for the finest triangles, half a unit cell: they have no split vertex.
    pub fn is_cell(&self) -> bool {
        self.l.0.abs_diff(self.r.0) == 1 && self.l.1.abs_diff(self.r.1) == 1
    }

    /// The hypotenuse's midpoint (for a cell triangle, the cell's min corner).
    pub fn mid(&self) -> Pt {
        if self.is_cell() {
            (self.l.0.min(self.r.0), self.l.1.min(self.r.1))
        } else {
            ((self.l.0 + self.r.0) / 2, (self.l.1 + self.r.1) / 2)
        }
    }

    /// Which of the two triangles sharing its hypotenuse this is (0 or 1,
    /// as the engine numbers halves).
    pub fn half(&self) -> usize {
        let m = self.mid();
        if self.is_cell() {
            usize::from(self.a.0 != m.0)
        } else {
            usize::from(!(self.a.0 < m.0 || (self.a.0 == m.0 && self.a.1 < m.1)))
        }
    }

    /// The corners as drawn: ordered so that the 2D cross product in image
    /// coordinates is negative, which makes the 3D normal face the camera.
    pub fn oriented(&self) -> [Pt; 3] {
        let (l, r, a) = (self.l, self.r, self.a);
        let cross = (i64::from(r.0) - i64::from(l.0)) * (i64::from(a.1) - i64::from(l.1))
            - (i64::from(r.1) - i64::from(l.1)) * (i64::from(a.0) - i64::from(l.0));
        if cross > 0 {
            [r, l, a]
        } else {
            [l, r, a]
        }
    }
}

/// Answers the walk's questions: the encoder from a mesh, the decoder from bits.
pub trait Decide {
    /// Why a walk stops.
    type Error;
    /// What `node` is. `implied` is true when the rules force a split: the
    /// answer is then [`Symbol::Split`] and nothing is read or written.
    fn decide(&mut self, node: &Node, implied: bool) -> Result<Symbol, Self::Error>;
    /// A drawn triangle, corners as [`Node::oriented`] gives them.
    fn emit(&mut self, corners: [Pt; 3]) -> Result<(), Self::Error>;
}

impl Forest {
    /// Vertices across.
    pub fn gw(&self) -> u32 {
        self.m * self.side + 1
    }

    /// Vertices down.
    pub fn gh(&self) -> u32 {
        self.n * self.side + 1
    }

    /// Row-major index of a vertex.
    pub fn index(&self, (x, y): Pt) -> usize {
        y as usize * self.gw() as usize + x as usize
    }

    /// Number of grid vertices.
    pub fn len(&self) -> usize {
        self.gw() as usize * self.gh() as usize
    }

    /// Never true.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// A forest a stream may describe: side a power of two in `2..=2^15`, at
    /// least one root, at most [`MAX_GRID_VERTICES`] vertices and 16-bit
    /// coordinates.
    pub fn check(&self) -> Result<(), &'static str> {
        if !(self.side.is_power_of_two() && (2..=1 << 15).contains(&self.side)) {
            return Err("root side must be a power of two in 2..=32768");
        }
        if self.m == 0 || self.n == 0 {
            return Err("the forest needs at least one root quad");
        }
        let (gw, gh) = (
            u64::from(self.m) * u64::from(self.side) + 1,
            u64::from(self.n) * u64::from(self.side) + 1,
        );
        if gw > 65_536 || gh > 65_536 || gw * gh > MAX_GRID_VERTICES {
            return Err("the forest is larger than any image a server stores");
        }
        Ok(())
    }

    fn k(&self) -> u32 {
        self.side.trailing_zeros()
    }

    /// Coarse-to-fine level: 0 for root corners, then centres and edge
    /// midpoints alternate from the root side down (as the engine's grid).
    pub fn level(&self, p: Pt) -> u32 {
        crate::diamond::level(p, self.side)
    }

    /// Number of levels, root corners included.
    pub fn levels(&self) -> usize {
        2 * self.k() as usize + 1
    }

    /// The diamond split by `v`, `None` for root corners.
    #[inline]
    pub fn diamond(&self, v: Pt) -> Option<Diamond> {
        crate::diamond::diamond(v, self.side)
    }

    fn contains(&self, (x, y): (i64, i64)) -> bool {
        x >= 0 && y >= 0 && x < i64::from(self.gw()) && y < i64::from(self.gh())
    }

    /// True for a root quad's half (its hypotenuse is the quad's diagonal).
    pub fn is_root(&self, node: &Node) -> bool {
        node.l.0.abs_diff(node.r.0) == self.side
    }

    /// The two triangles of each root quad, in walk order.
    pub fn roots(&self) -> impl Iterator<Item = Node> + '_ {
        let s = self.side;
        (0..self.n).flat_map(move |qy| {
            (0..self.m).flat_map(move |k| {
                let qx = if qy % 2 == 0 { k } else { self.m - 1 - k };
                let c = (qx * s + s / 2, qy * s + s / 2);
                let d = self.diamond(c).unwrap_or(Diamond {
                    a: (0, 0),
                    b: (0, 0),
                    apex: [(0, 0); 2],
                });
                let p = |q: (i64, i64)| (q.0 as u32, q.1 as u32);
                [
                    Node {
                        l: p(d.a),
                        r: p(d.b),
                        a: p(d.apex[0]),
                    },
                    Node {
                        l: p(d.b),
                        r: p(d.a),
                        a: p(d.apex[1]),
                    },
                ]
            })
        })
    }

    /// Runs the canonical walk, asking `decide` about every triangle whose
    /// fate the rules leave open.
    pub fn walk<D: Decide>(&self, decide: &mut D) -> Result<(), D::Error> {
        let mut split = vec![0u64; self.len().div_ceil(64)];
        let roots: Vec<Node> = self.roots().collect();
        for node in roots {
            self.visit(node, &mut split, decide)?;
        }
        Ok(())
    }

    fn visit<D: Decide>(&self, node: Node, split: &mut [u64], decide: &mut D) -> Result<(), D::Error> {
        if node.is_cell() {
            if decide.decide(&node, false)? == Symbol::Emit {
                decide.emit(node.oriented())?;
            }
            return Ok(());
        }
        let m = node.mid();
        let implied = get(split, self.index(m));
        match decide.decide(&node, implied)? {
            Symbol::Split => {
                self.mark(m, node.a, split);
                self.visit(
                    Node {
                        l: node.l,
                        r: node.a,
                        a: m,
                    },
                    split,
                    decide,
                )?;
                self.visit(
                    Node {
                        l: node.a,
                        r: node.r,
                        a: m,
                    },
                    split,
                    decide,
                )
            }
            Symbol::Emit => decide.emit(node.oriented()),
            Symbol::Skip => Ok(()),
        }
    }

    /// Marks `m` split, and the apex opposite `a` across it.
    fn mark(&self, m: Pt, a: Pt, split: &mut [u64]) {
        let i = self.index(m);
        split[i / 64] |= 1 << (i % 64);
        let (ox, oy) = (2 * i64::from(m.0) - i64::from(a.0), 2 * i64::from(m.1) - i64::from(a.1));
        if self.contains((ox, oy)) {
            let o = self.index((ox as u32, oy as u32));
            split[o / 64] |= 1 << (o % 64);
        }
    }
}

/// Runs `f` with a map from grid vertices to `u32`, all `u32::MAX`, of at
/// least `len` entries; `f` returns the entries it set, which are reset.
/// The map is kept per thread between calls: allocating and filling a
/// grid-sized map per request costs more than a small mesh's coding.
pub fn with_slot_map<R>(len: usize, f: impl FnOnce(&mut [u32]) -> (R, Vec<usize>)) -> R {
    thread_local! {
        static MAP: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
    }
    MAP.with(|cell| {
        let mut map = cell.take();
        if map.len() < len {
            map = vec![u32::MAX; len];
        }
        let (out, touched) = f(&mut map[..len]);
        for i in touched {
            map[i] = u32::MAX;
        }
        cell.replace(map);
        out
    })
}

#[inline]
fn get(bits: &[u64], i: usize) -> bool {
    bits.get(i / 64).is_some_and(|w| w >> (i % 64) & 1 == 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    struct All(usize);
    impl Decide for All {
        type Error = ();
        fn decide(&mut self, node: &Node, _: bool) -> Result<Symbol, ()> {
            Ok(if node.is_cell() { Symbol::Emit } else { Symbol::Split })
        }
        fn emit(&mut self, _: [Pt; 3]) -> Result<(), ()> {
            self.0 += 1;
            Ok(())
        }
    }

    #[test]
    fn a_full_walk_draws_two_triangles_per_cell() {
        for f in [Forest { side: 2, m: 1, n: 1 }, Forest { side: 8, m: 3, n: 2 }] {
            let mut all = All(0);
            f.walk(&mut all).unwrap();
            assert_eq!(all.0, 2 * (f.gw() as usize - 1) * (f.gh() as usize - 1));
        }
    }

    #[test]
    fn forests_beyond_the_limits_are_refused() {
        assert!(Forest { side: 3, m: 1, n: 1 }.check().is_err());
        assert!(Forest { side: 4, m: 0, n: 1 }.check().is_err());
        assert!(Forest {
            side: 1 << 15,
            m: 3,
            n: 1
        }
        .check()
        .is_err());
        assert!(Forest { side: 512, m: 2, n: 1 }.check().is_ok());
    }
}
