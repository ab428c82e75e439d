//! Vertex depths as nested bit planes of parent-edge residuals (PROTOCOL.md,
//! "Protocol 6: depths"; Verlani et al. Sec. 4 and Table 2, the mesh's own
//! coarser levels as the proxy; DESIGN.md "Residual bit-depth").
//!
//! Vertices come coarse to fine. A vertex bisects the edge `a-b` of its
//! diamond; when both ends are earlier vertices of the mesh its depth is
//! predicted as their mean (floored, on an integer lattice) and its residual
//! is coded, otherwise it is an *anchor* and travels as an exact `f32`.
//!
//! Residuals are quantised once, at full precision, closed loop: level `L`
//! has a step `step_L` and a residual its magnitude `m = round(|r| /
//! step_L)` with a sign, `P_L` the bit length of the level's largest `m`.
//! Plane `t` (1-based) carries bit `P_L - t` of every magnitude of a level
//! with `P_L >= t`, then the sign of each vertex that plane made non-zero.
//! A decoder holding the first `b` planes knows `mb = m >> s` (`s = P_L -
//! min(b, P_L)`) and reconstructs `mb * 2^s + 2^(s-1)` steps (0 when `mb =
//! 0`; `m` itself when `s = 0`) from its own prediction. So the first `b`
//! planes *are* the `b`-plane answer, whatever follows, and all planes give
//! the encoder's closed-loop depths: lossless on a lattice (one raw unit a
//! step), within half a step of `f32` rounding otherwise. The encoder runs
//! the decoder at every plane count and states each one's largest error.
//!
//! A reconstruction that is not a finite positive depth (a coarse answer
//! far below a near surface) falls back to the prediction, in encoder and
//! decoder alike, so no plane count ever yields an invalid depth.

use super::forest::{Forest, Pt};
use crate::residual::RawGrid;

/// Largest number of planes a level may have.
pub const MAX_PLANES: u8 = 24;

/// Raw values of lattice depths stay below this, so sums of two are exact
/// in f64 (and in JavaScript numbers).
const MAX_RAW: f64 = (1u64 << 50) as f64;

/// One level's quantisation.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LevelCode {
    /// Residual per unit of magnitude: metres, or raw units on a lattice (1).
    pub step: f64,
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
    /// Exact depths of the anchors in vertex order, little-endian `f32`,
    /// byte-shuffled (all first bytes, then all second bytes, ...).
    pub anchors: Vec<u8>,
    /// Plane `t` at index `t - 1`: magnitude bits, then sign bits.
    pub planes: Vec<Vec<u8>>,
    /// Largest `|decoded - true|` depth in metres holding the first `b`
    /// planes, at index `b` (so one more entry than planes).
    pub max_error: Vec<f32>,
}

/// Why depths do not decode.
pub type Error = &'static str;

fn valid(z: f32) -> bool {
    z.is_finite() && z > 0.0
}

/// For each vertex, its parent edge's ends when both are earlier vertices.
fn parents(forest: &Forest, vertices: &[Pt]) -> Vec<Option<(u32, u32)>> {
    let mut slot = vec![u32::MAX; forest.len()];
    vertices
        .iter()
        .enumerate()
        .map(|(k, &v)| {
            let at = |q: (i64, i64)| -> Option<u32> {
                let (x, y) = (u32::try_from(q.0).ok()?, u32::try_from(q.1).ok()?);
                (x < forest.gw() && y < forest.gh())
                    .then(|| slot[forest.index((x, y))])
                    .filter(|&s| s != u32::MAX)
            };
            let p = forest.diamond(v).and_then(|d| Some((at(d.a)?, at(d.b)?)));
            slot[forest.index(v)] = k as u32;
            p
        })
        .collect()
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

    fn predict(self, a: f64, b: f64) -> f64 {
        match self.0 {
            None => (a + b) * 0.5,
            Some(_) => ((a + b) * 0.5).floor(),
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

fn lattice_ok(depths: &[f32], g: RawGrid) -> bool {
    g.scale != 0.0
        && g.scale.is_finite()
        && g.offset.is_finite()
        && depths.iter().all(|&z| {
            let r = ((f64::from(z) - g.offset) / g.scale).round();
            r.abs() < MAX_RAW && (r * g.scale + g.offset) as f32 == z
        })
}

/// Codes `depths` (finite, positive) of `vertices` (coarse to fine, as the
/// connectivity decoder numbers them). `raw` is used as the lattice when
/// every depth lies on it.
pub fn encode(forest: &Forest, vertices: &[Pt], depths: &[f32], raw: Option<RawGrid>) -> Result<DepthCode, String> {
    if vertices.len() != depths.len() {
        return Err(format!("{} depths for {} vertices", depths.len(), vertices.len()));
    }
    if let Some(z) = depths.iter().find(|z| !valid(**z)) {
        return Err(format!("depth {z} is not finite and positive"));
    }
    let units = Units(raw.filter(|g| lattice_ok(depths, *g)));
    let parents = parents(forest, vertices);
    let level: Vec<usize> = vertices.iter().map(|&v| forest.level(v) as usize).collect();
    let truth: Vec<f64> = depths.iter().map(|&z| units.of(z)).collect();
    // Steps from the open-loop residuals: 2^16 steps reach the largest, but
    // no step is finer than a quarter of the f32 spacing of its level's depths.
    let mut range = vec![0f64; forest.levels()];
    let mut spacing = vec![0f64; forest.levels()];
    for (k, p) in parents.iter().enumerate() {
        if let Some((a, b)) = *p {
            let r = (truth[k] - units.predict(truth[a as usize], truth[b as usize])).abs();
            range[level[k]] = range[level[k]].max(r);
            let z = depths[k];
            spacing[level[k]] = spacing[level[k]].max(f64::from(z.next_up()) - f64::from(z));
        }
    }
    let mut levels: Vec<LevelCode> = range
        .iter()
        .zip(&spacing)
        .map(|(&r, &ulp)| LevelCode {
            step: match units.0 {
                Some(_) => 1.0,
                None => (r / 65536.0).max(ulp / 4.0).max(f64::MIN_POSITIVE),
            },
            planes: 0,
        })
        .collect();
    // Closed loop at full precision.
    let mut held = vec![0f64; vertices.len()];
    let mut mags = vec![(0u32, false); vertices.len()];
    let mut anchors: Vec<f32> = Vec::new();
    let cap = (1u64 << MAX_PLANES) - 1;
    for k in 0..vertices.len() {
        match parents[k] {
            None => {
                anchors.push(depths[k]);
                held[k] = truth[k];
            }
            Some((a, b)) => {
                let pred = units.predict(held[a as usize], held[b as usize]);
                let step = levels[level[k]].step;
                let r = truth[k] - pred;
                let m = ((r.abs() / step).round() as u64).min(cap) as u32;
                let negative = r < 0.0 && m > 0;
                mags[k] = (m, negative);
                let planes = &mut levels[level[k]].planes;
                *planes = (*planes).max((32 - m.leading_zeros()) as u8);
                let d = reconstruct(units, pred, negative, f64::from(m), step)
                    .ok_or("a prediction from valid depths is no depth")?;
                held[k] = d.1;
            }
        }
    }
    let total = levels.iter().map(|l| l.planes).max().unwrap_or(0);
    let mut planes = Vec::with_capacity(usize::from(total));
    for t in 1..=total {
        let mut w = super::bits::BitWriter::default();
        let coded = || (0..vertices.len()).filter(|&k| parents[k].is_some() && levels[level[k]].planes >= t);
        for k in coded() {
            let shift = u32::from(levels[level[k]].planes - t);
            w.bit(mags[k].0 >> shift & 1 == 1);
        }
        for k in coded() {
            let shift = u32::from(levels[level[k]].planes - t);
            if mags[k].0 >> shift == 1 {
                w.bit(mags[k].1);
            }
        }
        planes.push(w.finish());
    }
    let mut code = DepthCode {
        lattice: units.0,
        levels,
        anchors: shuffle(&anchors),
        planes,
        max_error: Vec::new(),
    };
    for b in 0..=usize::from(total) {
        let got =
            decode_with(&parents, &level, &code, b).map_err(|e| format!("the encoder's own decode failed: {e}"))?;
        let err = got.iter().zip(depths).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
        code.max_error.push(err);
    }
    Ok(code)
}

/// Decodes the depths of `vertices` from the first `held` planes of `code`
/// (the planes past `held` may be absent).
pub fn decode(forest: &Forest, vertices: &[Pt], code: &DepthCode, held: usize) -> Result<Vec<f32>, Error> {
    if code.levels.len() != forest.levels() {
        return Err("depth levels do not match the forest");
    }
    if held > code.planes.len() {
        return Err("fewer depth planes than stated");
    }
    if code.levels.iter().any(|l| l.planes > MAX_PLANES) {
        return Err("a level has more than 24 planes");
    }
    match code.lattice {
        Some(g) => {
            if !(g.scale.is_finite() && g.scale != 0.0 && g.offset.is_finite()) {
                return Err("lattice scale must be finite and non-zero, offset finite");
            }
            if code.levels.iter().any(|l| l.step != 1.0) {
                return Err("a lattice's step is one raw unit");
            }
        }
        None => {
            if code.levels.iter().any(|l| !(l.step.is_finite() && l.step > 0.0)) {
                return Err("steps must be finite and positive");
            }
        }
    }
    let parents = parents(forest, vertices);
    let level: Vec<usize> = vertices.iter().map(|&v| forest.level(v) as usize).collect();
    decode_with(&parents, &level, code, held)
}

/// [`decode`] with each vertex's parents and level.
fn decode_with(
    parents: &[Option<(u32, u32)>],
    level: &[usize],
    code: &DepthCode,
    held: usize,
) -> Result<Vec<f32>, Error> {
    let units = Units(code.lattice);
    let vertices = parents;
    let anchor_count = parents.iter().filter(|p| p.is_none()).count();
    let anchors = unshuffle(&code.anchors, anchor_count)?;
    let mut mb = vec![0u32; vertices.len()];
    let mut negative = vec![false; vertices.len()];
    for (t, plane) in code.planes[..held].iter().enumerate() {
        let t = t as u8 + 1;
        let mut r = super::bits::BitReader::new(plane, "a depth plane ends early or runs on");
        let coded = || (0..vertices.len()).filter(|&k| parents[k].is_some() && code.levels[level[k]].planes >= t);
        for k in coded() {
            mb[k] = mb[k] << 1 | u32::from(r.bit()?);
        }
        for k in coded() {
            if mb[k] == 1 {
                negative[k] = r.bit()?;
            }
        }
        r.end()?;
    }
    let mut held_units = vec![0f64; vertices.len()];
    let mut out = vec![0f32; vertices.len()];
    let mut next_anchor = anchors.iter();
    for k in 0..vertices.len() {
        let (z, u) = match parents[k] {
            None => {
                let z = *next_anchor.next().ok_or("anchors end early")?;
                if !valid(z) {
                    return Err("an anchor depth is not finite and positive");
                }
                let u = units.of(z);
                if code.lattice.is_some() && u.abs() >= MAX_RAW {
                    return Err("an anchor lies off the lattice's range");
                }
                (z, u)
            }
            Some((a, b)) => {
                let lc = code.levels[level[k]];
                let s = u32::from(lc.planes - lc.planes.min(held as u8));
                let pred = units.predict(held_units[a as usize], held_units[b as usize]);
                let d = reconstruct(units, pred, negative[k], magnitude(mb[k], s), lc.step)
                    .ok_or("depths decode to no valid depth")?;
                if code.lattice.is_some() && d.1.abs() >= MAX_RAW {
                    return Err("depths leave the lattice's range");
                }
                d
            }
        };
        out[k] = z;
        held_units[k] = u;
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

fn unshuffle(bytes: &[u8], n: usize) -> Result<Vec<f32>, Error> {
    if bytes.len() != 4 * n {
        return Err("anchor bytes do not match the anchors");
    }
    Ok((0..n)
        .map(|k| f32::from_le_bytes([bytes[k], bytes[n + k], bytes[2 * n + k], bytes[3 * n + k]]))
        .collect())
}
