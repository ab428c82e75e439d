//! The bit-plane decoder: depths from the first planes a client holds,
//! every validation of outside bytes before any arithmetic. The encoder
//! runs it at every plane count (closed loop), so it is the one decoder.

use super::{magnitude, predict_all, reconstruct, valid, DepthCode, Error, Pred, Units, MAX_PLANES};
use crate::bits::BitReader;
use crate::compact::forest::{Forest, Pt};
use crate::residual::MAX_RAW;

/// Decodes the depths of `vertices`, then of the cut sides predicted from
/// the vertices `sides` names, from the first `held` planes of `code` (the
/// planes past `held` may be absent); `known` gives the depths the client
/// already has, which the code skips.
pub fn decode(
    forest: &Forest,
    vertices: &[Pt],
    sides: &[u32],
    code: &DepthCode,
    held: usize,
    known: Option<&[Option<f32>]>,
) -> Result<Vec<f32>, Error> {
    if known.is_some_and(|k| k.len() != vertices.len() + sides.len()) {
        return Err("the known depths do not match the vertices");
    }
    if code.levels.len() != forest.levels() + 1 {
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
    let (preds, level) = predict_all(forest, vertices, sides)?;
    decode_with(&preds, &level, code, held, known)
}

/// [`decode`] with each vertex's predictor and level.
pub(super) fn decode_with(
    preds: &[Pred],
    level: &[usize],
    code: &DepthCode,
    held: usize,
    known: Option<&[Option<f32>]>,
) -> Result<Vec<f32>, Error> {
    let units = Units(code.lattice);
    let n = preds.len();
    let given = |k: usize| known.and_then(|m| m[k]);
    let mut escapes = BitReader::new(&code.escapes, "escape bits end early or run on");
    let mut coded = vec![false; n];
    let mut exact_count = 0;
    for k in 0..n {
        if given(k).is_some() {
            continue;
        }
        coded[k] = preds[k] != Pred::None && !escapes.bit()?;
        exact_count += usize::from(!coded[k]);
    }
    escapes.end()?;
    let exact = unshuffle(&code.exact, exact_count)?;
    let mut mb = vec![0u32; n];
    let mut negative = vec![false; n];
    for (t, plane) in code.planes[..held].iter().enumerate() {
        let t = t as u8 + 1;
        let mut r = BitReader::new(plane, "a depth plane ends early or runs on");
        let part = || (0..n).filter(|&k| coded[k] && code.levels[level[k]].planes >= t);
        for k in part() {
            mb[k] = mb[k] << 1 | u32::from(r.bit()?);
        }
        for k in part() {
            if mb[k] == 1 {
                negative[k] = r.bit()?;
            }
        }
        r.end()?;
    }
    let mut held_units = vec![0f64; n];
    let mut out = vec![0f32; n];
    let mut next_exact = exact.iter();
    for k in 0..n {
        let (z, u) = if let Some(z) = given(k) {
            if !valid(z) {
                return Err("a known depth is not finite and positive");
            }
            (z, units.of(z))
        } else if coded[k] {
            let lc = code.levels[level[k]];
            let s = u32::from(lc.planes - lc.planes.min(held as u8));
            let pred = units.predict(preds[k], &held_units);
            let d = reconstruct(units, pred, negative[k], magnitude(mb[k], s), f64::from(lc.step))
                .ok_or("depths decode to no valid depth")?;
            if code.lattice.is_some() && d.1.abs() >= MAX_RAW {
                return Err("depths leave the lattice's range");
            }
            d
        } else {
            let z = *next_exact.next().ok_or("exact depths end early")?;
            if !valid(z) {
                return Err("an exact depth is not finite and positive");
            }
            let u = units.of(z);
            if code.lattice.is_some() && u.abs() >= MAX_RAW {
                return Err("an exact depth lies off the lattice's range");
            }
            (z, u)
        };
        out[k] = z;
        held_units[k] = u;
    }
    Ok(out)
}

fn unshuffle(bytes: &[u8], n: usize) -> Result<Vec<f32>, Error> {
    if bytes.len() != 4 * n {
        return Err("exact depth bytes do not match the anchors and escapes");
    }
    Ok((0..n)
        .map(|k| f32::from_le_bytes([bytes[k], bytes[n + k], bytes[2 * n + k], bytes[3 * n + k]]))
        .collect())
}
