//! Cut triangles in the compact stream (PROTOCOL.md, "Protocol 7", "Cut triangles";
//! DESIGN.md "Outlines as cuts"): a leaf of the walk that a depth
//! discontinuity crosses, drawn as two parts on either side of one
//! straight cut between two crossings on two of its edges.
//!
//! What travels, per cut triangle in walk order (the connectivity's cut
//! bit has named it):
//! - a *case* byte: which corner of the walk's [`super::forest::Node::oriented`]
//!   order is alone on its side, and which side, if any, is void;
//! - per crossing edge not met before in walk order, the crossing's place
//!   in half steps from the edge's first end (the smaller grid index), in
//!   `log2 n + 1` bits on an edge of `n` unit steps. A jump lies between
//!   two samples and has no finer position, so this is exact. The
//!   triangle across the edge reads the same crossing and the same side
//!   depths: both decoders place and lift it on the same bits, and no crack
//!   opens along a shared edge whatever planes a client holds.
//! - per drawn side of each such crossing, its depth: a residual in the
//!   depth planes, predicted from the vertex at that side's end of the edge
//!   ([`super::bitplanes`], the level after the finest).

use rustc_hash::FxHashMap as HashMap;

use serde::{Deserialize, Serialize};

use super::forest::{Forest, Pt};
use crate::bits::{BitReader, BitWriter};

/// A triangle drawn as two parts separated by one straight cut.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CutTriangle {
    /// Grid corners `(i, j)`: the corner alone on its side of the cut,
    /// then the other two, oriented as the mesh's drawn triangles are.
    pub corners: [[u16; 2]; 3],
    /// Where the cut crosses the edges from the lone corner to corner 1
    /// and to corner 2, in half steps from the lone corner: on an edge of
    /// `n` steps, the crossing lies `at / 2n` of the way.
    pub at: [u16; 2],
    /// Depths of the lone corner's part at the lone corner and the two
    /// crossings; `None` when that side is void (invalid samples).
    pub lone: Option<[f32; 3]>,
    /// Depths of the other part at crossing 1, corners 1 and 2, and
    /// crossing 2; `None` when that side is void.
    pub other: Option<[f32; 4]>,
}

/// A point of a part: pixel column, pixel row, depth.
pub type PartPoint = [f64; 3];

impl CutTriangle {
    /// The two crossings in grid coordinates.
    pub fn crossings(&self) -> [[f64; 2]; 2] {
        let c = self.corners.map(|[x, y]| [f64::from(x), f64::from(y)]);
        [1, 2].map(|e| {
            let (dx, dy) = (c[e][0] - c[0][0], c[e][1] - c[0][1]);
            // at / 2n with n a power of two: exact in binary, so both
            // decoders place the crossing on the same bits.
            let t = f64::from(self.at[e - 1]) / (2.0 * dx.abs().max(dy.abs()));
            [c[0][0] + t * dx, c[0][1] + t * dy]
        })
    }

    /// The triangles it draws, oriented as its corners are: the lone
    /// part's (one), then the other part's (two, split along crossing 1 to
    /// corner 2), leaving out those of no area (a crossing on a corner, at
    /// the image border). At most three.
    pub fn parts(&self) -> impl Iterator<Item = [PartPoint; 3]> + '_ {
        self.all_parts().filter(|&t| area2(t) != 0.0)
    }

    /// [`Self::parts`] with those of no area: the lone part's if drawn,
    /// then the other's two if drawn.
    pub fn all_parts(&self) -> impl Iterator<Item = [PartPoint; 3]> + '_ {
        let c = self.corners.map(|[x, y]| [f64::from(x), f64::from(y)]);
        let [a, b] = self.crossings();
        let p = |[x, y]: [f64; 2], z: f32| [x, y, f64::from(z)];
        let lone = self.lone.map(|z| [p(c[0], z[0]), p(a, z[1]), p(b, z[2])]);
        let other = self.other.map(|z| {
            [
                [p(a, z[0]), p(c[1], z[1]), p(c[2], z[2])],
                [p(a, z[0]), p(c[2], z[2]), p(b, z[3])],
            ]
        });
        lone.into_iter().chain(other.into_iter().flatten())
    }

    /// How many triangles it draws (0 to 3).
    pub fn drawn(&self) -> usize {
        self.parts().count()
    }
}

/// Twice the signed area of a part in `(u, v)`.
pub fn area2(t: [PartPoint; 3]) -> f64 {
    (t[1][0] - t[0][0]) * (t[2][1] - t[0][1]) - (t[1][1] - t[0][1]) * (t[2][0] - t[0][0])
}

/// The cuts of a mesh past their connectivity bit: cases and crossings.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CutCode {
    /// One byte per cut triangle, in walk order: `3 k + v`, with `k` the
    /// lone corner's place in the walk's corner order and `v` the void
    /// side (0 none, 1 the lone corner's, 2 the other's).
    pub cases: Vec<u8>,
    /// Per crossing edge not met before, in walk order: the crossing's
    /// place in half steps from the edge's first end, less one, in
    /// `log2 n + 1` bits.
    pub crossings: Vec<u8>,
}

/// A cut as the walk and its case place it, its depths to come: what both
/// ends number and predict the same way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CutShape {
    /// Lone corner first, as [`CutTriangle::corners`].
    pub corners: [Pt; 3],
    /// As [`CutTriangle::at`].
    pub at: [u16; 2],
    /// Whether the lone part and the other part are drawn.
    pub drawn: [bool; 2],
    /// Per crossing (to corner 1, to corner 2), the side depths' places in
    /// the side list: the lone corner's side, the other's.
    pub sides: [[u32; 2]; 2],
}

/// A crossing side's depth to code: the edge's end on that side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Side {
    /// The edge's end on this side, the depth's predictor.
    pub end: Pt,
}

/// Absent side depth.
pub const NO_SIDE: u32 = u32::MAX;

/// The crossings met so far, by edge, and the side list they fill.
#[derive(Default)]
struct Crossings {
    by_edge: HashMap<(usize, usize), Met>,
    sides: Vec<Side>,
}

/// A crossing met: half steps from the edge's first end, and its two side
/// depths' places (first end's side, second end's side).
#[derive(Clone, Copy)]
struct Met {
    h: u32,
    sides: [u32; 2],
}

/// Unit steps of the edge `p-q`, a power of two on the forest's lattice.
fn steps(p: Pt, q: Pt) -> u32 {
    p.0.abs_diff(q.0).max(p.1.abs_diff(q.1))
}

impl Crossings {
    /// The crossing of the edge from `p` (the lone corner, on a side
    /// `drawn[0]`) to `q` (`drawn[1]`), `at` half steps from `p`. A new one
    /// is registered with `code(h, n)`'s half steps from the first end
    /// (`h` given when coding, read when decoding); a known one returns its
    /// side places. Fails when the edge's crossing is met again elsewhere
    /// or with other drawn sides.
    fn meet<E>(
        &mut self,
        forest: &Forest,
        (p, q): (Pt, Pt),
        at: Option<u32>,
        drawn: [bool; 2],
        code: impl FnOnce(Option<u32>, u32) -> Result<u32, E>,
    ) -> Result<(u32, [u32; 2]), E>
    where
        E: From<&'static str>,
    {
        let n = steps(p, q);
        let (ip, iq) = (forest.index(p), forest.index(q));
        let forward = ip < iq;
        let key = if forward { (ip, iq) } else { (iq, ip) };
        // Half steps from the first end, and back.
        let flip = |h: u32| if forward { h } else { 2 * n - h };
        // The sides as (first end's, second end's).
        let (first, second) = if forward {
            (drawn[0], drawn[1])
        } else {
            (drawn[1], drawn[0])
        };
        if let Some(m) = self.by_edge.get(&key) {
            if at.is_some_and(|a| flip(a) != m.h) {
                return Err("two cuts cross one edge at different places".into());
            }
            if (m.sides[0] != NO_SIDE) != first || (m.sides[1] != NO_SIDE) != second {
                return Err("two cuts draw different sides of one crossing".into());
            }
            let s = if forward { m.sides } else { [m.sides[1], m.sides[0]] };
            return Ok((flip(m.h), s));
        }
        let h = code(at.map(flip), n)?;
        let mut side = |drawn: bool, end: Pt| {
            if drawn {
                self.sides.push(Side { end });
                (self.sides.len() - 1) as u32
            } else {
                NO_SIDE
            }
        };
        let (a, b) = if forward { (p, q) } else { (q, p) };
        let sides = [side(first, a), side(second, b)];
        self.by_edge.insert(key, Met { h, sides });
        let s = if forward { sides } else { [sides[1], sides[0]] };
        Ok((flip(h), s))
    }
}

/// Bits of a crossing's place on an edge of `n` steps.
fn width(n: u32) -> u8 {
    n.trailing_zeros() as u8 + 1
}

/// A cut's case byte.
fn case(k: usize, drawn: [bool; 2]) -> Result<u8, &'static str> {
    let v = match drawn {
        [true, true] => 0,
        [false, true] => 1,
        [true, false] => 2,
        [false, false] => return Err("a cut draws neither part"),
    };
    Ok(3 * k as u8 + v)
}

/// What [`encode`] makes.
pub struct Coded {
    /// The fields that travel.
    pub code: CutCode,
    /// Each cut's shape, in walk order.
    pub shapes: Vec<CutShape>,
    /// The side list.
    pub sides: Vec<Side>,
    /// The side depths in its order.
    pub depths: Vec<f32>,
}

/// Codes the `cuts` (engine form, depths included) of the cut leaves
/// `leaves` the walk met (in walk order, corners as the walk orients
/// them). Fails when two cuts disagree on a crossing they share.
pub fn encode(forest: &Forest, leaves: &[[Pt; 3]], cuts: &[CutTriangle]) -> Result<Coded, String> {
    let sorted = |c: &CutTriangle| {
        let mut key = c.corners.map(|[x, y]| (u32::from(x), u32::from(y)));
        key.sort_unstable();
        key
    };
    // The engine's cuts come in walk order: the map is built only for
    // cuts that come in another.
    let mut by_corners: Option<HashMap<[Pt; 3], &CutTriangle>> = None;
    let mut cases = Vec::with_capacity(leaves.len());
    let mut bits = BitWriter::default();
    let mut met = Crossings::default();
    let mut shapes = Vec::with_capacity(leaves.len());
    let mut depths: Vec<Option<f32>> = Vec::new();
    for (n, leaf) in leaves.iter().enumerate() {
        let mut key = *leaf;
        key.sort_unstable();
        let c = match cuts.get(n).filter(|c| sorted(c) == key) {
            Some(c) => c,
            None => by_corners
                .get_or_insert_with(|| cuts.iter().map(|c| (sorted(c), c)).collect())
                .get(&key)
                .copied()
                .ok_or("a cut leaf has no cut")?,
        };
        let corners = c.corners.map(|[x, y]| (u32::from(x), u32::from(y)));
        let k = (0..3)
            .find(|&k| (0..3).all(|e| leaf[(k + e) % 3] == corners[e]))
            .ok_or_else(|| format!("cut {corners:?} is not oriented as the walk's {leaf:?}"))?;
        let drawn = [c.lone.is_some(), c.other.is_some()];
        cases.push(case(k, drawn)?);
        let mut sides = [[NO_SIDE; 2]; 2];
        for e in 0..2 {
            let (at, s) = met.meet(
                forest,
                (corners[0], corners[e + 1]),
                Some(u32::from(c.at[e])),
                drawn,
                |h: Option<u32>, n| -> Result<u32, String> {
                    let h = h.unwrap_or(0);
                    if !(1..2 * n).contains(&h) {
                        return Err(format!("a crossing at {h} half steps lies off an edge of {n} steps"));
                    }
                    bits.field(h - 1, width(n));
                    Ok(h)
                },
            )?;
            debug_assert_eq!(at, u32::from(c.at[e]));
            sides[e] = s;
        }
        // The depths of sides met now for the first time, in side order.
        let zs = [
            (sides[0][0], c.lone.map(|z| z[1])),
            (sides[0][1], c.other.map(|z| z[0])),
            (sides[1][0], c.lone.map(|z| z[2])),
            (sides[1][1], c.other.map(|z| z[3])),
        ];
        depths.resize(met.sides.len(), None);
        for (place, z) in zs {
            if place == NO_SIDE {
                continue;
            }
            let z = z.ok_or("a drawn side has no depth")?;
            let at = &mut depths[place as usize];
            if at.is_some_and(|was| was.to_bits() != z.to_bits()) {
                return Err("two cuts give one crossing side different depths".to_string());
            }
            *at = Some(z);
        }
        shapes.push(CutShape {
            corners,
            at: c.at,
            drawn,
            sides,
        });
    }
    let depths = depths
        .into_iter()
        .collect::<Option<Vec<f32>>>()
        .ok_or("a crossing side has no depth")?;
    Ok(Coded {
        code: CutCode {
            cases,
            crossings: bits.finish(),
        },
        shapes,
        sides: met.sides,
        depths,
    })
}

/// Reads the shapes of the cut leaves `leaves` from `code`, with the side
/// list their depths follow.
pub fn decode(forest: &Forest, leaves: &[[Pt; 3]], code: &CutCode) -> Result<(Vec<CutShape>, Vec<Side>), &'static str> {
    if code.cases.len() != leaves.len() {
        return Err("cut cases do not match the cut triangles");
    }
    let mut bits = BitReader::new(&code.crossings, "crossing bits end early or run on");
    let mut met = Crossings::default();
    let mut shapes = Vec::with_capacity(leaves.len());
    for (leaf, &case) in leaves.iter().zip(&code.cases) {
        if case >= 9 {
            return Err("a cut's case is not one of the nine");
        }
        let (k, v) = (usize::from(case / 3), case % 3);
        let drawn = [v != 1, v != 2];
        let corners = [leaf[k], leaf[(k + 1) % 3], leaf[(k + 2) % 3]];
        let mut at = [0u16; 2];
        let mut sides = [[NO_SIDE; 2]; 2];
        for e in 0..2 {
            let (a, s) = met.meet(forest, (corners[0], corners[e + 1]), None, drawn, |_, n| {
                let h = bits.field(width(n))? + 1;
                if h >= 2 * n {
                    return Err("a crossing lies on an edge's end");
                }
                Ok(h)
            })?;
            at[e] = u16::try_from(a).map_err(|_| "a crossing lies past the grid")?;
            sides[e] = s;
        }
        shapes.push(CutShape {
            corners,
            at,
            drawn,
            sides,
        });
    }
    bits.end()?;
    Ok((shapes, met.sides))
}

impl CutShape {
    /// The cut triangle with its corners' depths (`corner(p)`: the vertex
    /// depth at `p`) and the decoded side depths `sides`.
    pub fn with_depths(&self, corner: impl Fn(Pt) -> Option<f32>, sides: &[f32]) -> Option<CutTriangle> {
        let side = |s: u32| sides.get(s as usize).copied();
        let [p0, p1, p2] = self.corners;
        let lone = if self.drawn[0] {
            Some([corner(p0)?, side(self.sides[0][0])?, side(self.sides[1][0])?])
        } else {
            None
        };
        let other = if self.drawn[1] {
            Some([
                side(self.sides[0][1])?,
                corner(p1)?,
                corner(p2)?,
                side(self.sides[1][1])?,
            ])
        } else {
            None
        };
        Some(CutTriangle {
            corners: self.corners.map(|(x, y)| [x as u16, y as u16]),
            at: self.at,
            lone,
            other,
        })
    }

    /// The corners that are vertices of the mesh: those of a drawn part.
    pub fn vertices(&self) -> impl Iterator<Item = Pt> + '_ {
        let [p0, p1, p2] = self.corners;
        let lone = self.drawn[0].then_some(p0);
        let other = self.drawn[1].then_some([p1, p2]);
        lone.into_iter().chain(other.into_iter().flatten())
    }
}
