//! Connectivity of a restricted-quadtree mesh as split and leaf bits
//! (PROTOCOL.md, "Protocol 7", "Connectivity"; DESIGN.md "The compact stream").
//!
//! The [`Forest::walk`] asks about every triangle whose fate the dependency
//! rules leave open. A triangle larger than a cell answers with a *split
//! bit* (1: split); one that is not split, and every cell triangle, with a
//! *leaf bit* (1: drawn, 0: left out, because it is segmented or outside
//! the requesting view). A triangle whose split vertex the rules force is
//! split without a bit; if the mesh left it out whole, its children are
//! left out one by one, which draws the same triangles. A leaf left out
//! answers with a *cut bit* (1: drawn as a cut triangle, `cut.rs`).
//!
//! The decoder numbers the vertices as the engine does: in order of first
//! use by the drawn triangles, then by the cut triangles' drawn corners,
//! then stably by level, coarse to fine.

use super::cut::CutShape;
use super::forest::{Decide, Forest, Node, Pt, Symbol};
use crate::bits::{BitReader, BitWriter};

/// The three bit fields.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Connectivity {
    /// Split bits, one per asked triangle larger than a cell.
    pub split: Vec<u8>,
    /// Leaf bits, one per triangle that is not split.
    pub leaf: Vec<u8>,
    /// Cut bits, one per leaf left out: 1 when it is drawn as a cut.
    pub cut: Vec<u8>,
}

/// A decoded mesh's shape: vertices coarse to fine, triangles indexing
/// them, and the cut triangles.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Shape {
    /// Grid coordinates of the vertices.
    pub vertices: Vec<Pt>,
    /// Triangles in walk order, corners oriented to face the camera.
    pub triangles: Vec<[u32; 3]>,
    /// Cut triangles in walk order, their depths apart.
    pub cuts: Vec<CutShape>,
}

/// What a walk met: the drawn triangles and the cut leaves, in walk order,
/// corners as [`Node::oriented`] gives them.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Leaves {
    /// Drawn triangles.
    pub drawn: Vec<[Pt; 3]>,
    /// Leaves drawn as cuts.
    pub cut: Vec<[Pt; 3]>,
}

/// What a client holds of another mesh of the same view, as the context a
/// change's bits are coded in (PROTOCOL.md, "Protocol 7", "Changes").
///
/// A triangle the held mesh *reached* (a root's half, or one whose apex,
/// the vertex its parent split at, the held mesh has) has a known fate
/// there: split (the held mesh has its split vertex and does not draw it),
/// drawn, or left out. Its bits travel as differences from that fate, in
/// fields that are nearly all zeros; the bits of triangles the held mesh
/// never reached travel plain, in their own fields.
#[derive(Clone, Debug, Default)]
pub struct Context {
    /// Held vertices, by grid index.
    vertices: Vec<u64>,
    /// Held drawn cell triangles, by cell and half.
    cells: Vec<u64>,
    /// Held drawn larger triangles, by split vertex and half.
    drawn: Vec<u64>,
}

/// A triangle's fate in the held mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Fate {
    split: bool,
    drawn: bool,
}

impl Context {
    /// The context of `held`, a decoded mesh on `forest`.
    pub fn of(forest: &Forest, held: &Shape) -> Result<Self, String> {
        let words = |n: usize| n.div_ceil(64);
        let mut c = Self {
            vertices: vec![0; words(forest.len())],
            cells: vec![0; words(2 * forest.len())],
            drawn: vec![0; words(2 * forest.len())],
        };
        let (gw, gh) = (forest.gw(), forest.gh());
        for &p in &held.vertices {
            if p.0 >= gw || p.1 >= gh {
                return Err(format!("held vertex {p:?} lies outside the {gw} x {gh} grid"));
            }
            set(&mut c.vertices, forest.index(p));
        }
        for t in &held.triangles {
            let corner = |k: u32| {
                held.vertices
                    .get(k as usize)
                    .copied()
                    .ok_or("a held triangle has no vertex")
            };
            let node = node_of(forest, [corner(t[0])?, corner(t[1])?, corner(t[2])?])?;
            let key = 2 * forest.index(node.mid()) + node.half();
            set(if node.is_cell() { &mut c.cells } else { &mut c.drawn }, key);
        }
        Ok(c)
    }

    fn has(&self, forest: &Forest, p: Pt) -> bool {
        get(&self.vertices, forest.index(p))
    }

    /// The triangle's fate in the held mesh, `None` where it never reached it.
    fn fate(&self, forest: &Forest, node: &Node) -> Option<Fate> {
        if !(forest.is_root(node) || self.has(forest, node.a)) {
            return None;
        }
        let key = 2 * forest.index(node.mid()) + node.half();
        if node.is_cell() {
            return Some(Fate {
                split: false,
                drawn: get(&self.cells, key),
            });
        }
        let drawn = get(&self.drawn, key);
        Some(Fate {
            split: !drawn && self.has(forest, node.mid()),
            drawn,
        })
    }
}

/// Where a walk's bits go or come from: the plain fields, or, against a
/// held mesh, the difference fields and the fresh ones.
struct Fields<W> {
    split: W,
    leaf: W,
    cut: W,
    fresh_split: W,
    fresh_leaf: W,
}

fn set(bits: &mut [u64], i: usize) -> bool {
    let was = bits[i / 64] >> (i % 64) & 1 == 1;
    bits[i / 64] |= 1 << (i % 64);
    was
}

fn get(bits: &[u64], i: usize) -> bool {
    bits[i / 64] >> (i % 64) & 1 == 1
}

/// The node key of a triangle (its hypotenuse's midpoint and half), or an
/// error when it is no triangle of the forest.
fn node_of(forest: &Forest, t: [Pt; 3]) -> Result<Node, String> {
    let d2 = |p: Pt, q: Pt| {
        let (dx, dy) = (i64::from(p.0) - i64::from(q.0), i64::from(p.1) - i64::from(q.1));
        dx * dx + dy * dy
    };
    let sides = [d2(t[1], t[2]), d2(t[0], t[2]), d2(t[0], t[1])];
    let apex = (0..3).max_by_key(|&k| sides[k]).unwrap_or(0);
    let (l, r, a) = (t[(apex + 1) % 3], t[(apex + 2) % 3], t[apex]);
    let node = Node { l, r, a };
    let bad = || format!("triangle {t:?} is not a triangle of the restricted quadtree");
    if node.is_cell() {
        let c = node.mid();
        let ok = (a.0 == c.0 || a.0 == c.0 + 1) && (a.1 == c.1 || a.1 == c.1 + 1) && {
            // The cell's diagonal runs through its corner with both coordinates odd.
            let odd = |p: Pt| p.0 % 2 == 1 && p.1 % 2 == 1;
            odd(l) || odd(r)
        };
        return if ok { Ok(node) } else { Err(bad()) };
    }
    if (l.0 + r.0) % 2 != 0 || (l.1 + r.1) % 2 != 0 {
        return Err(bad());
    }
    let m = node.mid();
    let d = forest.diamond(m).ok_or_else(bad)?;
    let p = |q: (i64, i64)| (q.0 as u32, q.1 as u32);
    let hyp = (p(d.a) == l && p(d.b) == r) || (p(d.a) == r && p(d.b) == l);
    if !hyp || !d.apex.iter().any(|&q| q.0 >= 0 && q.1 >= 0 && p(q) == a) {
        return Err(bad());
    }
    Ok(node)
}

/// The parent of a triangle: the triangle whose split made it.
fn parent(forest: &Forest, node: &Node) -> Option<Node> {
    let m = node.a;
    let d = forest.diamond(m)?;
    let p = |q: (i64, i64)| (q.0 as u32, q.1 as u32);
    let apex = [node.l, node.r]
        .into_iter()
        .find(|&c| d.apex.iter().any(|&q| q.0 >= 0 && q.1 >= 0 && p(q) == c))?;
    Some(Node {
        l: p(d.a),
        r: p(d.b),
        a: apex,
    })
}

/// What the encoder's walk asks of the mesh at each triangle.
enum Mesh<'a> {
    /// The triangles and cut leaves in walk order, as the engine extracts
    /// them: the next of each is the only one the walk can meet, so every
    /// question is a comparison with it and no map is built.
    InOrder {
        triangles: &'a [[Pt; 3]],
        cuts: &'a [[Pt; 3]],
        /// The next triangle and cut the walk has not met.
        next: (usize, usize),
    },
    /// In any order: bit maps by node.
    Marked(Box<Marked>),
}

/// The mesh as bit maps by node key (split vertex, half; by cell for cells).
struct Marked {
    /// Drawn cell triangles, by cell and half.
    cells: Vec<u64>,
    /// Drawn larger triangles, by split vertex and half.
    drawn: Vec<u64>,
    /// Leaves drawn as cuts, by split vertex (by cell for cells) and
    /// half: larger triangles, then cells.
    cut: [Vec<u64>; 2],
    /// Triangles with a drawn or cut triangle inside, by split vertex and half.
    inside: Vec<u64>,
}

impl Marked {
    /// Marks `triangles` and the cut leaves `cuts`; fails when one is not
    /// a triangle of the forest or appears twice.
    fn of(forest: &Forest, triangles: &[[Pt; 3]], cuts: &[[Pt; 3]]) -> Result<Self, String> {
        let words = (2 * forest.len()).div_ceil(64);
        let mut m = Self {
            cells: vec![0; words],
            drawn: vec![0; words],
            cut: [vec![0; words], vec![0; words]],
            inside: vec![0; words],
        };
        for (k, t) in triangles.iter().chain(cuts).enumerate() {
            let node = node_of(forest, *t)?;
            let key = 2 * forest.index(node.mid()) + node.half();
            let (drawn, cut) = if node.is_cell() {
                (&mut m.cells, &mut m.cut[1])
            } else {
                (&mut m.drawn, &mut m.cut[0])
            };
            let twice = if k >= triangles.len() {
                set(cut, key) || get(drawn, key)
            } else {
                set(drawn, key)
            };
            if twice {
                return Err(format!("triangle {t:?} appears twice"));
            }
            let mut up = parent(forest, &node);
            while let Some(p) = up {
                if set(&mut m.inside, 2 * forest.index(p.mid()) + p.half()) {
                    break;
                }
                up = parent(forest, &p);
            }
        }
        Ok(m)
    }
}

/// Whether every corner of `t` lies in the closed triangle `n`: for
/// triangles of the forest, whether `t` is `n` or lies inside it.
fn within(n: [Pt; 3], t: &[Pt; 3]) -> bool {
    let c = |p: Pt| (i64::from(p.0), i64::from(p.1));
    let [a, b, d] = n.map(c);
    let cross = |p: (i64, i64), q: (i64, i64), r: (i64, i64)| (q.0 - p.0) * (r.1 - p.1) - (q.1 - p.1) * (r.0 - p.0);
    let sign = cross(a, b, d).signum();
    t.iter().all(|&p| {
        let p = c(p);
        cross(a, b, p) * sign >= 0 && cross(b, d, p) * sign >= 0 && cross(d, a, p) * sign >= 0
    })
}

/// Whether `t` has the corners of `n` in some order.
fn same_corners(n: [Pt; 3], t: &[Pt; 3]) -> bool {
    t.iter().all(|p| n.contains(p))
}

impl Mesh<'_> {
    /// Whether `node` (corners `oriented`, key `key`) is drawn, cut, or
    /// has a drawn or cut triangle inside.
    fn ask(&self, forest: &Forest, node: &Node, oriented: [Pt; 3]) -> (bool, bool, bool) {
        match self {
            Self::InOrder {
                triangles,
                cuts,
                next: (t, c),
            } => {
                let (t, c) = (triangles.get(*t), cuts.get(*c));
                let drawn = t.is_some_and(|t| *t == oriented);
                let cut = !drawn && c.is_some_and(|c| same_corners(oriented, c));
                let inside = !drawn
                    && !cut
                    && (t.is_some_and(|t| within(oriented, t)) || c.is_some_and(|c| within(oriented, c)));
                (drawn, cut, inside)
            }
            Self::Marked(m) => {
                let key = 2 * forest.index(node.mid()) + node.half();
                let cell = node.is_cell();
                let drawn = get(if cell { &m.cells } else { &m.drawn }, key);
                let cut = get(&m.cut[usize::from(cell)], key);
                (drawn, cut, !cell && get(&m.inside, key))
            }
        }
    }
}

struct Encoder<'a> {
    forest: &'a Forest,
    mesh: Mesh<'a>,
    bits: Fields<BitWriter>,
    /// What the walk met, as the decoder will see it.
    leaves: Leaves,
    /// A held mesh the bits are coded against.
    held: Option<&'a Context>,
}

impl Decide for Encoder<'_> {
    type Error = String;

    fn decide(&mut self, node: &Node, implied: bool) -> Result<Symbol, String> {
        let fate = self.held.and_then(|c| c.fate(self.forest, node));
        let fresh = self.held.is_some() && fate.is_none();
        let oriented = node.oriented();
        let (drawn, cut, inside) = self.mesh.ask(self.forest, node, oriented);
        let bits = &mut self.bits;
        let mut leaf = |drawn: bool| match (fate, fresh) {
            (Some(f), _) => bits.leaf.bit(drawn != f.drawn),
            (None, true) => bits.fresh_leaf.bit(drawn),
            (None, false) => bits.leaf.bit(drawn),
        };
        if node.is_cell() {
            leaf(drawn);
            return Ok(self.leaf_left_out(oriented, drawn, cut));
        }
        if implied {
            if drawn || cut {
                return Err(format!(
                    "triangle {node:?} is drawn but its split vertex is forced: the mesh does not conform"
                ));
            }
            return Ok(Symbol::Split);
        }
        let split = !drawn && inside;
        match (fate, fresh) {
            (Some(f), _) => self.bits.split.bit(split != f.split),
            (None, true) => self.bits.fresh_split.bit(split),
            (None, false) => self.bits.split.bit(split),
        }
        if split {
            return Ok(Symbol::Split);
        }
        match (fate, fresh) {
            (Some(f), _) => self.bits.leaf.bit(drawn != f.drawn),
            (None, true) => self.bits.fresh_leaf.bit(drawn),
            (None, false) => self.bits.leaf.bit(drawn),
        }
        Ok(self.leaf_left_out(oriented, drawn, cut))
    }

    fn emit(&mut self, corners: [Pt; 3]) -> Result<(), String> {
        if let Mesh::InOrder { next, .. } = &mut self.mesh {
            next.0 += 1;
        }
        self.leaves.drawn.push(corners);
        Ok(())
    }
}

impl Encoder<'_> {
    /// A leaf's symbol; a leaf left out answers its cut bit.
    fn leaf_left_out(&mut self, oriented: [Pt; 3], drawn: bool, cut: bool) -> Symbol {
        if drawn {
            return Symbol::Emit;
        }
        self.bits.cut.bit(cut);
        if cut {
            if let Mesh::InOrder { next, .. } = &mut self.mesh {
                next.1 += 1;
            }
            self.leaves.cut.push(oriented);
        }
        Symbol::Skip
    }

    fn new<'a>(forest: &'a Forest, mesh: Mesh<'a>, held: Option<&'a Context>, counts: (usize, usize)) -> Encoder<'a> {
        Encoder {
            forest,
            mesh,
            bits: Fields {
                split: BitWriter::default(),
                leaf: BitWriter::default(),
                cut: BitWriter::default(),
                fresh_split: BitWriter::default(),
                fresh_leaf: BitWriter::default(),
            },
            leaves: Leaves {
                drawn: Vec::with_capacity(counts.0),
                cut: Vec::with_capacity(counts.1),
            },
            held,
        }
    }
}

/// Codes the triangles `triangles` (grid coordinates of their corners) and
/// the cut leaves `cuts` of a mesh on `forest`, with what the decoder's walk
/// will meet: the bits, the fresh bits, the leaves. Without `held` every
/// bit is plain and the fresh bits are empty; against `held`, the split
/// and leaf bits of triangles the held mesh reached are differences from
/// their fate there, and the others' are the fresh bits (cut bits are
/// always plain). Fails when a triangle is not one of the forest's, or the
/// triangles are not the leaves of one conforming walk.
///
/// Triangles and cuts in walk order, corners as [`Node::oriented`] gives
/// them (the engine's), are coded in one walk that compares each triangle
/// it meets with the next of each list. When the walk does not meet them
/// all so, they came in another order (or do not conform), and they are
/// coded again from bit maps of the forest's nodes: the same bits, or the
/// error.
pub fn encode(
    forest: &Forest,
    triangles: &[[Pt; 3]],
    cuts: &[[Pt; 3]],
    held: Option<&Context>,
) -> Result<(Connectivity, Connectivity, Leaves), String> {
    forest.check()?;
    let (gw, gh) = (forest.gw(), forest.gh());
    if let Some(t) = triangles
        .iter()
        .chain(cuts)
        .find(|t| t.iter().any(|p| p.0 >= gw || p.1 >= gh))
    {
        return Err(format!("triangle {t:?} lies outside the {gw} x {gh} grid"));
    }
    let counts = (triangles.len(), cuts.len());
    let in_order = Mesh::InOrder {
        triangles,
        cuts,
        next: (0, 0),
    };
    let mut enc = Encoder::new(forest, in_order, held, counts);
    let walked = forest.walk(&mut enc);
    let met = matches!(enc.mesh, Mesh::InOrder { next, .. } if next == counts);
    if !(walked.is_ok() && met) {
        let marked = Mesh::Marked(Box::new(Marked::of(forest, triangles, cuts)?));
        enc = Encoder::new(forest, marked, held, counts);
        forest.walk(&mut enc)?;
    }
    let met = enc.leaves.drawn.len() + enc.leaves.cut.len();
    if met != triangles.len() + cuts.len() {
        return Err(format!(
            "{} of {} triangles lie under triangles the walk drew or left out: the mesh does not conform",
            triangles.len() + cuts.len() - met,
            triangles.len() + cuts.len()
        ));
    }
    let Fields {
        split,
        leaf,
        cut,
        fresh_split,
        fresh_leaf,
    } = enc.bits;
    Ok((
        Connectivity {
            split: split.finish(),
            leaf: leaf.finish(),
            cut: cut.finish(),
        },
        Connectivity {
            split: fresh_split.finish(),
            leaf: fresh_leaf.finish(),
            cut: Vec::new(),
        },
        enc.leaves,
    ))
}

struct Decoder<'a> {
    forest: &'a Forest,
    held: Option<&'a Context>,
    bits: Fields<BitReader<'a>>,
    leaves: Leaves,
    /// At most this many triangles and cuts (from the header).
    limit: (usize, usize),
}

impl Decide for Decoder<'_> {
    type Error = &'static str;

    fn decide(&mut self, node: &Node, implied: bool) -> Result<Symbol, &'static str> {
        if implied {
            return Ok(Symbol::Split);
        }
        let fate = self.held.and_then(|c| c.fate(self.forest, node));
        let fresh = self.held.is_some() && fate.is_none();
        let b = &mut self.bits;
        if !node.is_cell() {
            let split = match (fate, fresh) {
                (Some(f), _) => b.split.bit()? != f.split,
                (None, true) => b.fresh_split.bit()?,
                (None, false) => b.split.bit()?,
            };
            if split {
                return Ok(Symbol::Split);
            }
        }
        let drawn = match (fate, fresh) {
            (Some(f), _) => b.leaf.bit()? != f.drawn,
            (None, true) => b.fresh_leaf.bit()?,
            (None, false) => b.leaf.bit()?,
        };
        if drawn {
            return Ok(Symbol::Emit);
        }
        if b.cut.bit()? {
            if self.leaves.cut.len() >= self.limit.1 {
                return Err("connectivity cuts more triangles than the header says");
            }
            self.leaves.cut.push(node.oriented());
        }
        Ok(Symbol::Skip)
    }

    fn emit(&mut self, corners: [Pt; 3]) -> Result<(), &'static str> {
        if self.leaves.drawn.len() >= self.limit.0 {
            return Err("connectivity draws more triangles than the header says");
        }
        self.leaves.drawn.push(corners);
        Ok(())
    }
}

/// Walks the mesh that [`encode`] coded (against `held`, with its fresh
/// bits `fresh`), expecting `triangles` drawn and `cuts` cut.
pub fn decode(
    forest: &Forest,
    bits: &Connectivity,
    fresh: &Connectivity,
    (triangles, cuts): (usize, usize),
    held: Option<&Context>,
) -> Result<Leaves, &'static str> {
    forest.check()?;
    let cells = 2 * (forest.gw() as usize - 1) * (forest.gh() as usize - 1);
    if triangles > cells || cuts > cells {
        return Err("more triangles than the forest holds");
    }
    let mut dec = Decoder {
        forest,
        held,
        bits: Fields {
            split: BitReader::new(&bits.split, "split bits end early or run on"),
            leaf: BitReader::new(&bits.leaf, "leaf bits end early or run on"),
            cut: BitReader::new(&bits.cut, "cut bits end early or run on"),
            fresh_split: BitReader::new(&fresh.split, "fresh split bits end early or run on"),
            fresh_leaf: BitReader::new(&fresh.leaf, "fresh leaf bits end early or run on"),
        },
        leaves: Leaves {
            drawn: Vec::with_capacity(triangles.min(1 << 24)),
            cut: Vec::with_capacity(cuts.min(1 << 24)),
        },
        limit: (triangles, cuts),
    };
    forest.walk(&mut dec)?;
    dec.bits.split.end()?;
    dec.bits.leaf.end()?;
    dec.bits.cut.end()?;
    dec.bits.fresh_split.end()?;
    dec.bits.fresh_leaf.end()?;
    if !fresh.cut.is_empty() {
        return Err("fresh cut bits are not part of a change");
    }
    if dec.leaves.drawn.len() != triangles {
        return Err("connectivity draws fewer triangles than the header says");
    }
    if dec.leaves.cut.len() != cuts {
        return Err("connectivity cuts fewer triangles than the header says");
    }
    Ok(dec.leaves)
}

/// [`assemble_with`] of drawn triangles alone.
pub fn assemble(forest: &Forest, corners: &[[Pt; 3]]) -> Shape {
    assemble_with(forest, corners, &[])
}

/// Numbers the vertices of `corners` by first use, then the cuts' drawn
/// corners by first use, then stably by level, and indexes the triangles
/// by that numbering.
pub fn assemble_with(forest: &Forest, corners: &[[Pt; 3]], cuts: &[CutShape]) -> Shape {
    super::forest::with_slot_map(forest.len(), |slot| {
        let mut used: Vec<(Pt, usize)> = Vec::with_capacity(corners.len() / 2 + 8);
        let mut per_level = vec![0u32; forest.levels() + 1];
        for p in corners
            .iter()
            .flatten()
            .copied()
            .chain(cuts.iter().flat_map(CutShape::vertices))
        {
            let i = forest.index(p);
            if slot[i] == u32::MAX {
                slot[i] = 0;
                let level = forest.level(p) as usize;
                per_level[level + 1] += 1;
                used.push((p, level));
            }
        }
        for l in 1..per_level.len() {
            per_level[l] += per_level[l - 1];
        }
        let mut vertices = vec![(0, 0); used.len()];
        for &(p, level) in &used {
            let at = &mut per_level[level];
            vertices[*at as usize] = p;
            slot[forest.index(p)] = *at;
            *at += 1;
        }
        let triangles = corners.iter().map(|t| t.map(|p| slot[forest.index(p)])).collect();
        let touched = vertices.iter().map(|&p| forest.index(p)).collect();
        let shape = Shape {
            vertices,
            triangles,
            cuts: cuts.to_vec(),
        };
        (shape, touched)
    })
}
