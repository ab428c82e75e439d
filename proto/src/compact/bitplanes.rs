//! Vertex depths as nested bit planes of residuals from the mesh's coarser
//! levels (PROTOCOL.md, "Protocol 7", "Depths"; Verlani et al. Sec. 4 and
//! Table 2, the mesh's own coarser levels as the proxy; DESIGN.md
//! "Residual bit-depth").
//!
//! Vertices come coarse to fine. A vertex is predicted from coarser vertices
//! of the mesh: the mean of its parent edge's ends `a`, `b` (the edge it
//! bisects, as its error metric; floored on an integer lattice) when both
//! are in the mesh, else the mean of its diamond's apexes when both are,
//! else the first of `a`, `b`, apex 0, apex 1 that is; a vertex with none of
//! them (a root corner, an island) is an *anchor* and travels as an exact
//! `f32`.
//!
//! Residuals are quantised once, at full precision, closed loop: level `L`
//! has a step `step_L` and `P_L` planes, sized from the 99th percentile of
//! its open-loop residuals (so a few vertices beside a depth jump do not
//! coarsen every other one); a vertex whose magnitude `m = round(|r| /
//! step_L)` needs more than `P_L` bits *escapes* and travels exact, like an
//! anchor. Plane `t` (1-based) carries bit `P_L - t` of every other
//! magnitude of a level with `P_L >= t`, then the sign of each vertex that
//! plane made non-zero. A decoder holding the first `b` planes knows
//! `mb = m >> s` (`s = P_L - min(b, P_L)`) and reconstructs `mb * 2^s + 2^(s-1)`
//! steps (0 when `mb = 0`; `m` itself when `s = 0`) from its own prediction.
//! So the first `b` planes *are* the `b`-plane answer, whatever follows, and
//! all planes give the encoder's closed-loop depths: lossless on a lattice
//! (one raw unit a step), within half a step of `f32` rounding otherwise. The
//! encoder runs the decoder at every plane count and states each one's
//! largest error.
//!
//! The side depths of cut triangles' crossings (`cut.rs`) follow the
//! vertices as one more level, the finest: each predicted from the vertex
//! at its side's end of the crossed edge, coded as any vertex is.
//!
//! A reconstruction that is not a finite positive depth (a coarse answer
//! far below a near surface) falls back to the prediction, in encoder and
//! decoder alike, so no plane count ever yields an invalid depth.

mod decode;

use super::forest::{Forest, Pt};
use crate::residual::{on_lattice, RawGrid};

pub use decode::decode;
use decode::decode_with;

/// Largest number of planes a level may have.
pub const MAX_PLANES: u8 = 24;

/// One level's quantisation.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LevelCode {
    /// Residual per unit of magnitude: metres, or raw units on a lattice (1).
    pub step: f32,
    /// Bit length of the level's largest magnitude.
    pub planes: u8,
}

/// A mesh's depths, all planes.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthCode {
    /// The integer lattice the depths lie on, when coding runs in raw units.
    pub lattice: Option<RawGrid>,
    /// Per level, coarse to fine.
    pub levels: Vec<LevelCode>,
    /// One bit per predicted vertex in vertex order: 1 when it escaped.
    pub escapes: Vec<u8>,
    /// Exact depths of the anchors and escaped vertices in vertex order,
    /// little-endian `f32`, byte-shuffled (all first bytes, then all
    /// second bytes, ...).
    pub exact: Vec<u8>,
    /// Plane `t` at index `t - 1`: magnitude bits, then sign bits (the
    /// planes sent).
    pub planes: Vec<Vec<u8>>,
    /// The planes the code has in all (the largest level's).
    pub total: u8,
    /// The planes to send: `min(asked, planes.len())`.
    pub sent: usize,
    /// Largest `|decoded - true|` depth in metres holding the first `sent` planes.
    pub max_error: f32,
}

/// Why depths do not decode.
pub type Error = &'static str;

fn valid(z: f32) -> bool {
    z.is_finite() && z > 0.0
}

/// What a vertex is predicted from: vertex numbers of coarser vertices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pred {
    /// The mean of two.
    Two(u32, u32),
    /// One's value.
    One(u32),
    /// Nothing: an anchor.
    None,
}

/// Each vertex's predictor (see the module docs).
fn predictors(forest: &Forest, vertices: &[Pt]) -> Vec<Pred> {
    super::forest::with_slot_map(forest.len(), |slot| {
        let preds = vertices
            .iter()
            .enumerate()
            .map(|(k, &v)| {
                let at = |q: (i64, i64)| -> Option<u32> {
                    let (x, y) = (u32::try_from(q.0).ok()?, u32::try_from(q.1).ok()?);
                    (x < forest.gw() && y < forest.gh())
                        .then(|| slot[forest.index((x, y))])
                        .filter(|&s| s != u32::MAX)
                };
                let p = forest.diamond(v).map_or(Pred::None, |d| {
                    let ends = [at(d.a), at(d.b), at(d.apex[0]), at(d.apex[1])];
                    match ends {
                        [Some(a), Some(b), ..] | [_, _, Some(a), Some(b)] => Pred::Two(a, b),
                        _ => ends.iter().flatten().next().map_or(Pred::None, |&a| Pred::One(a)),
                    }
                });
                slot[forest.index(v)] = k as u32;
                p
            })
            .collect();
        (preds, vertices.iter().map(|&v| forest.index(v)).collect())
    })
}

/// Each value's predictor and level: the vertices' ([`predictors`]), then
/// the `sides`', each from the vertex it names, on the level after the
/// finest.
fn predict_all(forest: &Forest, vertices: &[Pt], sides: &[u32]) -> Result<(Vec<Pred>, Vec<usize>), Error> {
    if sides.iter().any(|&v| v as usize >= vertices.len()) {
        return Err("a side depth's vertex is not in the mesh");
    }
    let mut preds = predictors(forest, vertices);
    preds.extend(sides.iter().map(|&v| Pred::One(v)));
    let level = vertices
        .iter()
        .map(|&v| forest.level(v) as usize)
        .chain(sides.iter().map(|_| forest.levels()))
        .collect();
    Ok((preds, level))
}

/// The arithmetic both ends share.
#[derive(Clone, Copy)]
struct Units(Option<RawGrid>);

impl Units {
    fn of(self, z: f32) -> f64 {
        match self.0 {
            None => f64::from(z),
            Some(g) => ((f64::from(z) - g.offset) / g.scale).round(),
        }
    }

    /// The prediction of a vertex from the values `held` of earlier ones.
    fn predict(self, p: Pred, held: &[f64]) -> f64 {
        match p {
            Pred::Two(a, b) => {
                let (a, b) = (held[a as usize], held[b as usize]);
                match self.0 {
                    None => (a + b) * 0.5,
                    // Integers below 2^50: the floor of their mean, exactly,
                    // without a call to `floor`.
                    Some(_) => ((a as i64 + b as i64) >> 1) as f64,
                }
            }
            Pred::One(a) => held[a as usize],
            Pred::None => 0.0,
        }
    }

    /// A value in units as a depth, and as the units its children see.
    fn depth(self, u: f64) -> (f32, f64) {
        match self.0 {
            None => {
                let z = u as f32;
                (z, f64::from(z))
            }
            Some(g) => ((u * g.scale + g.offset) as f32, u),
        }
    }
}

/// The reconstructed magnitude (in steps) from the known top bits `mb` at shift `s`.
fn magnitude(mb: u32, s: u32) -> f64 {
    match (mb, s) {
        (_, 0) => f64::from(mb),
        (0, _) => 0.0,
        _ => f64::from(mb) * f64::from(1u32 << s) + f64::from(1u32 << (s - 1)),
    }
}

/// Reconstructs one coded vertex: prediction, signed magnitude, step; the
/// prediction itself when that is no depth. `None` when neither is.
fn reconstruct(units: Units, pred: f64, negative: bool, mag: f64, step: f64) -> Option<(f32, f64)> {
    let value = if negative { pred - mag * step } else { pred + mag * step };
    let d = units.depth(value);
    if valid(d.0) {
        return Some(d);
    }
    let d = units.depth(pred);
    valid(d.0).then_some(d)
}

/// The share of open-loop residuals a level's planes are sized to reach;
/// the rest escape to exact depths.
const RANGE_QUANTILE: f64 = 0.99;

/// The `q`-quantile of `values` (0 when empty), reordering them.
fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let k = ((values.len() - 1) as f64 * q).round() as usize;
    *values.select_nth_unstable_by(k, f64::total_cmp).1
}

/// Bits needed for `m`.
fn bit_length(m: u64) -> u8 {
    (64 - m.leading_zeros()) as u8
}

/// Bits of the largest depth on the lattice of a view without an integer one.
pub const LATTICE_BITS: i32 = 20;

/// The lattice a mesh's depths are coded on: `raw` when every depth lies on
/// it, else the finest power-of-two lattice on which the largest depth
/// needs at most [`LATTICE_BITS`] bits (so a depth rounds by at most
/// 2^-21 of the mesh's largest depth: 4 micrometres at 8 m). A depth's value on it,
/// and so every all-plane answer, depends on the depth alone, not on the
/// mesh: what lets a client holding one mesh take another's depths
/// ([`super::MeshChange`]).
pub fn lattice_for(depths: &[f32], raw: Option<RawGrid>) -> RawGrid {
    if let Some(g) = raw.filter(|g| on_lattice(depths, *g)) {
        return g;
    }
    let top = depths
        .iter()
        .copied()
        .filter(|z| valid(*z))
        .fold(f32::MIN_POSITIVE, f32::max);
    // 2^e > top: the scale is 2^(e - LATTICE_BITS).
    let e = f64::from(top).log2().floor() as i32 + 1;
    RawGrid {
        scale: 2f64.powi(e - LATTICE_BITS),
        offset: 0.0,
    }
}

/// `z` on the lattice `g` (`z` itself when it lies on it).
pub fn on(g: RawGrid, z: f32) -> f32 {
    (((f64::from(z) - g.offset) / g.scale).round() * g.scale + g.offset) as f32
}

/// Codes `depths` (finite, positive) of `vertices` (coarse to fine, as the
/// connectivity decoder numbers them) and then of the cut sides predicted
/// from the vertices `sides` names, on [`lattice_for`] `raw` (of the
/// vertices' depths), to be sent with `planes` planes (`None`: all). The
/// values `known` marks are the client's already, on the same lattice:
/// they predict, but cost nothing.
pub fn encode(
    forest: &Forest,
    vertices: &[Pt],
    sides: &[u32],
    depths: &[f32],
    raw: Option<RawGrid>,
    planes: Option<u8>,
    known: Option<&[bool]>,
) -> Result<DepthCode, String> {
    if vertices.len() + sides.len() != depths.len() {
        return Err(format!(
            "{} depths for {} vertices and {} sides",
            depths.len(),
            vertices.len(),
            sides.len()
        ));
    }
    if known.is_some_and(|k| k.len() != depths.len()) {
        return Err("the known mask does not match the vertices".to_string());
    }
    if let Some(z) = depths.iter().find(|z| !valid(**z)) {
        return Err(format!("depth {z} is not finite and positive"));
    }
    let g = lattice_for(&depths[..vertices.len()], raw);
    let units = Units(Some(g));
    let is_known = |k: usize| known.is_some_and(|m| m[k]);
    // The depths as coded: on the lattice.
    let coded_depths: Vec<f32> = depths.iter().map(|&z| on(g, z)).collect();
    let (preds, level) = predict_all(forest, vertices, sides)?;
    let truth: Vec<f64> = coded_depths.iter().map(|&z| units.of(z)).collect();
    // Per level: the open-loop residuals; and each prediction from the
    // true values, which the closed loop reuses while it holds them.
    let mut residuals = vec![Vec::new(); forest.levels() + 1];
    let mut open = vec![0f64; preds.len()];
    for (k, &p) in preds.iter().enumerate() {
        if p != Pred::None && !is_known(k) {
            open[k] = units.predict(p, &truth);
            residuals[level[k]].push((truth[k] - open[k]).abs());
        }
    }
    let levels: Vec<LevelCode> = residuals
        .iter_mut()
        .map(|r| {
            let range = quantile(r, RANGE_QUANTILE);
            let planes = bit_length(range.round() as u64).min(MAX_PLANES);
            LevelCode { step: 1.0, planes }
        })
        .collect();
    // Closed loop at full precision.
    let n = depths.len();
    let mut held = vec![0f64; n];
    let mut mags = vec![(0u32, false); n];
    let mut coded = vec![false; n];
    let mut exact: Vec<f32> = Vec::new();
    let mut escapes = crate::bits::BitWriter::default();
    // Every value so far reconstructs to its true value (a vertex is
    // predicted from earlier ones only), so the prediction is the open
    // loop's: until a reconstruction falls back to its prediction.
    let mut held_truth = true;
    for k in 0..n {
        let p = preds[k];
        if is_known(k) {
            held[k] = truth[k];
            continue;
        }
        if p == Pred::None {
            exact.push(coded_depths[k]);
            held[k] = truth[k];
            continue;
        }
        let lc = levels[level[k]];
        let pred = if held_truth { open[k] } else { units.predict(p, &held) };
        let r = truth[k] - pred;
        // On the lattice (step 1) the residual is a whole number already.
        let m = if lc.step == 1.0 {
            r.abs()
        } else {
            (r.abs() / f64::from(lc.step)).round()
        };
        let negative = r < 0.0 && m >= 1.0;
        let fits = m < f64::from(1u32 << lc.planes);
        let d = fits
            .then(|| reconstruct(units, pred, negative, m, f64::from(lc.step)))
            .flatten();
        escapes.bit(d.is_none());
        match d {
            Some(d) => {
                mags[k] = (m as u32, negative);
                coded[k] = true;
                held[k] = d.1;
                held_truth &= d.1 == truth[k];
            }
            None => {
                exact.push(coded_depths[k]);
                held[k] = truth[k];
            }
        }
    }
    let total = levels.iter().map(|l| l.planes).max().unwrap_or(0);
    let sent = planes.map_or(total, |p| p.min(total));
    let planes = plane_bits(&levels, &level, &coded, &mags, sent)?;
    let mut code = DepthCode {
        lattice: units.0,
        levels,
        escapes: escapes.finish(),
        exact: shuffle(&exact),
        planes,
        total,
        sent: usize::from(sent),
        max_error: 0.0,
    };
    // The error of the planes sent, from the magnitudes themselves: what
    // `decode_with` computes from the planes, without parsing them again.
    let mut values = vec![0f64; n];
    {
        let b = sent;
        let mut err = 0f32;
        for k in 0..n {
            let (z, u) = if coded[k] {
                let lc = code.levels[level[k]];
                let s = u32::from(lc.planes - lc.planes.min(b));
                let pred = units.predict(preds[k], &values);
                reconstruct(units, pred, mags[k].1, magnitude(mags[k].0 >> s, s), f64::from(lc.step))
                    .ok_or("a prediction from valid depths is no depth")?
            } else {
                (coded_depths[k], truth[k])
            };
            values[k] = u;
            err = err.max((z - depths[k]).abs());
        }
        code.max_error = err;
    }
    debug_assert!({
        let given: Option<Vec<Option<f32>>> =
            known.map(|m| m.iter().zip(&coded_depths).map(|(&k, &z)| k.then_some(z)).collect());
        let got = decode_with(&preds, &level, &code, code.sent, given.as_deref()).unwrap_or_default();
        got.iter().zip(depths).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max) == code.max_error
    });
    Ok(code)
}

/// The first `sent` planes of the coded vertices' magnitudes `mags`
/// (`coded` marks them; `level` is each vertex's level, non-decreasing, as
/// the connectivity decoder numbers vertices). A plane's vertices are those
/// of the levels with that many planes, in vertex order: whole level blocks.
fn plane_bits(
    levels: &[LevelCode],
    level: &[usize],
    coded: &[bool],
    mags: &[(u32, bool)],
    sent: u8,
) -> Result<Vec<Vec<u8>>, String> {
    if level.windows(2).any(|w| w[0] > w[1]) {
        return Err("vertices must come coarse to fine".to_string());
    }
    // Per level: its coded vertices' magnitudes and signs, in vertex order.
    let mut blocks: Vec<Vec<(u32, bool)>> = vec![Vec::new(); levels.len()];
    for k in (0..mags.len()).filter(|&k| coded[k]) {
        blocks[level[k]].push(mags[k]);
    }
    let mut out = Vec::with_capacity(usize::from(sent));
    for t in 1..=sent {
        let mut w = crate::bits::BitWriter::default();
        let mut signs = crate::bits::BitWriter::default();
        for (lc, block) in levels.iter().zip(&blocks).filter(|(lc, _)| lc.planes >= t) {
            let shift = u32::from(lc.planes - t);
            // 64 bits to a word; a sign where a magnitude's top bit is met.
            for chunk in block.chunks(64) {
                let mut word = 0u64;
                for (i, &(m, negative)) in chunk.iter().enumerate() {
                    let top = m >> shift;
                    word |= u64::from(top & 1) << i;
                    if top == 1 {
                        signs.bit(negative);
                    }
                }
                w.bits(word, chunk.len() as u32);
            }
        }
        w.append(signs);
        out.push(w.finish());
    }
    Ok(out)
}

fn shuffle(values: &[f32]) -> Vec<u8> {
    let n = values.len();
    let mut out = vec![0u8; 4 * n];
    for (k, v) in values.iter().enumerate() {
        for (b, byte) in v.to_le_bytes().into_iter().enumerate() {
            out[b * n + k] = byte;
        }
    }
    out
}
