//! Residual bit-depth coding of vertex depths (DESIGN.md "Residual
//! bit-depth"; the proxy-plus-residue idea of Verlani et al. Sec. 4, Table 2,
//! with the mesh's own coarser levels as the proxy).
//!
//! Vertices travel coarse to fine. A vertex bisects the edge `a-b` of the
//! restricted quadtree (its *parent edge*, the same `a, b` as its error
//! metric); both endpoints come earlier, and its depth is predicted from
//! their *decoded* depths (closed loop, so errors do not accumulate). With
//! `bits = 0` the prediction is the depth. With `bits >= 1` the prediction
//! residual travels as a `bits`-bit code: code 0 is an *escape* (the exact
//! `f32` follows in `exact`), code `c >= 1` is the residual
//! `(c - 2^(bits-1)) * step`, symmetric about zero.
//!
//! The step comes from the residuals themselves, not from the depth range:
//! the 90th percentile `R` of the open-loop residuals split into the codes'
//! range (the few beyond escape), but never more than the decoding error
//! `E(bits - 1)` of one bit less. The encoder
//! runs the decoder at every bit-depth from 0 up and escapes any vertex
//! whose decoded depth would be further than `E(bits - 1) / 2` from the
//! truth, so by construction `max_error(bits) <= max_error(bits - 1) / 2`:
//! each bit at least halves the error, and no bit-depth is worse than
//! `bits = 0`'s interpolation.
//!
//! A vertex whose parent edge has an endpoint missing from the mesh (root
//! corners, and vertices next to dropped, segmented triangles) is an
//! *anchor*: its depth travels exact, with no code.
//!
//! When the server knows the depth came from integers (`z = raw * scale +
//! offset`, a 16-bit PNG for instance) and every depth lies on that
//! *lattice*, the coding runs in raw units: predictions are floored to an
//! integer, the step is a whole number of raw units, and a step of 1 is
//! lossless, which `bits = 16` always reaches for 16-bit input (its
//! interpolation error is under 2^16 raw units, and each bit halves it).
//! `max_error` states the largest decoding error of this response, computed
//! by the encoder running the decoder.

use std::collections::HashMap;

use crate::bits::{BitReader, BitWriter};
use serde::{Deserialize, Serialize};

/// Largest residual bit-depth.
pub const MAX_BITS: u8 = 16;

/// The share of open-loop residuals the codes are sized to reach; the rest
/// escape to exact depths.
const RANGE_QUANTILE: f64 = 0.9;

/// Raw values of lattice depths stay below this, so sums of two are exact
/// in f64 (and in JavaScript numbers).
pub(crate) const MAX_RAW: f64 = (1u64 << 50) as f64;

/// Depths coded as residuals from parent-edge predictions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResidualDepths {
    /// Bits per residual code, `0..=16`.
    pub bits: u8,
    /// Side of the root quads of the reference view's grid (a power of two):
    /// it decides each vertex's parent edge, see [`parent_edge`].
    pub root_side: u32,
    /// The integer lattice the depths lie on, when coding runs in raw units.
    pub lattice: Option<RawGrid>,
    /// Residual per code step: metres, or whole raw units on a lattice (0
    /// with `bits = 0`).
    pub step: f64,
    /// Exact depths of the anchors and escaped vertices, in vertex order.
    pub exact: Vec<f32>,
    /// One `bits`-bit code per non-anchor vertex in vertex order, packed
    /// least significant bit first.
    pub residuals: Vec<u8>,
    /// Largest `|decoded - true|` depth over the vertices, metres.
    pub max_error: f32,
}

/// How the server knows the depths were integers: `z = raw * scale + offset`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawGrid {
    /// Metres per raw unit (non-zero).
    pub scale: f64,
    /// Metres at raw 0.
    pub offset: f64,
}

/// Why residual depths do not decode.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ResidualError {
    /// `bits` above [`MAX_BITS`].
    #[error("bits is {0}; it must be 0..=16")]
    Bits(u8),
    /// `root_side` not a power of two.
    #[error("root_side is {0}; it must be a power of two")]
    RootSide(u32),
    /// A step or lattice that no encoder writes.
    #[error("residual depths have a bad header: {0}")]
    Header(&'static str),
    /// Fewer exact depths or residual bits than the vertices need.
    #[error("residual depths are truncated: {0}")]
    Truncated(&'static str),
    /// The codes decode to a depth that is not finite and positive.
    #[error("residual depths decode to {0}, not a finite positive depth")]
    Invalid(f32),
    /// Depths and vertices differ in number.
    #[error("{depths} depths for {vertices} vertices")]
    Count {
        /// Depths given.
        depths: usize,
        /// Vertices given.
        vertices: usize,
    },
}

/// The endpoints of the edge that vertex `(i, j)` bisects in a grid of root
/// quads of side `root_side` (a power of two; below 2 it is taken as 2), or
/// `None` for a root corner: the hypotenuse of its diamond
/// ([`crate::diamond`]), whose ends always lie on the grid.
pub fn parent_edge(v: (u32, u32), root_side: u32) -> Option<((u32, u32), (u32, u32))> {
    let d = crate::diamond::diamond(v, root_side.max(2))?;
    // A hypotenuse's ends are grid vertices: never negative.
    let p = |(x, y): (i64, i64)| (x as u32, y as u32);
    Some((p(d.a), p(d.b)))
}

/// For each vertex, the indices of its parent edge's endpoints when both
/// come earlier in `ij`; `None` makes it an anchor.
fn parents(ij: &[(u16, u16)], root_side: u32) -> Vec<Option<(usize, usize)>> {
    let mut seen: HashMap<(u32, u32), usize> = HashMap::with_capacity(ij.len());
    ij.iter()
        .enumerate()
        .map(|(k, &(i, j))| {
            let v = (u32::from(i), u32::from(j));
            let p = parent_edge(v, root_side).and_then(|(a, b)| Some((*seen.get(&a)?, *seen.get(&b)?)));
            seen.insert(v, k);
            p
        })
        .collect()
}

/// The arithmetic both ends share: depths in *units* (metres, or raw
/// integers on a lattice), predictions and reconstructions.
#[derive(Clone, Copy)]
struct Units {
    lattice: Option<RawGrid>,
}

impl Units {
    /// Units of an exact depth.
    fn of(self, z: f32) -> f64 {
        match self.lattice {
            None => f64::from(z),
            Some(g) => ((f64::from(z) - g.offset) / g.scale).round(),
        }
    }

    /// The prediction from the parent edge's endpoints.
    fn predict(self, a: f64, b: f64) -> f64 {
        match self.lattice {
            None => (a + b) * 0.5,
            Some(_) => ((a + b) * 0.5).floor(),
        }
    }

    /// A reconstruction `u` as a depth, and as the units its children see.
    fn depth(self, u: f64) -> (f32, f64) {
        match self.lattice {
            None => {
                let z = u as f32;
                (z, f64::from(z))
            }
            Some(g) => ((u * g.scale + g.offset) as f32, u),
        }
    }
}

fn valid(z: f32) -> bool {
    z.is_finite() && z > 0.0
}

/// Half the code range: code `c >= 1` is the residual `(c - half) * step`.
fn half(bits: u8) -> u32 {
    1 << (bits - 1)
}

impl ResidualDepths {
    /// Metres per code step: the quantisation step (0 with `bits = 0`).
    pub fn step(&self) -> f64 {
        match self.lattice {
            _ if self.bits == 0 => 0.0,
            None => self.step,
            Some(g) => self.step * g.scale.abs(),
        }
    }

    /// Codes `depths` of the vertices `ij` (coarse to fine) with `bits` bits.
    /// `raw` is used as the lattice when every depth lies on it exactly.
    pub fn encode(
        ij: &[(u16, u16)],
        depths: &[f32],
        bits: u8,
        root_side: u32,
        raw: Option<RawGrid>,
    ) -> Result<Self, ResidualError> {
        check_header(bits, root_side)?;
        if ij.len() != depths.len() {
            return Err(ResidualError::Count {
                depths: depths.len(),
                vertices: ij.len(),
            });
        }
        let parents = parents(ij, root_side);
        let continuous = Units { lattice: None };
        let metres: Vec<f64> = depths.iter().map(|&z| f64::from(z)).collect();
        let mut out = Self::pass(&parents, depths, &metres, root_side, 0, continuous, 0.0, 0.0);
        if bits == 0 {
            return Ok(out);
        }
        let units = Units {
            lattice: raw.filter(|g| on_lattice(depths, *g)),
        };
        let truth: Vec<f64> = match units.lattice {
            None => metres,
            Some(_) => depths.iter().map(|&z| units.of(z)).collect(),
        };
        // The residuals' own range, in metres: a high quantile of the
        // open-loop residuals, so that the few beyond it (vertices beside a
        // depth jump that segmentation kept) escape instead of coarsening
        // every other vertex's step.
        let unit = units.lattice.map_or(1.0, |g| g.scale.abs());
        let mut residuals: Vec<f64> = parents
            .iter()
            .zip(&truth)
            .filter_map(|(p, &u)| {
                let (a, b) = (*p)?;
                Some((u - units.predict(truth[a], truth[b])).abs() * unit)
            })
            .collect();
        let range = quantile(&mut residuals, RANGE_QUANTILE);
        for b in 1..=bits {
            let previous = out.max_error;
            // Codes reach (half - 1) steps each way; one bit has only zero.
            let codes = f64::from(half(b) - 1).max(0.5);
            let mut step = f64::from(previous).min(range / codes);
            if let Some(g) = units.lattice {
                step = (step / g.scale.abs()).floor().clamp(1.0, MAX_RAW);
            }
            out = Self::pass(&parents, depths, &truth, root_side, b, units, step, previous / 2.0);
        }
        Ok(out)
    }

    /// One encoding at `bits` with `step`: every coded vertex decodes within
    /// `limit` of its depth or escapes. `truth` holds the depths in `units`.
    #[allow(clippy::too_many_arguments)]
    fn pass(
        parents: &[Option<(usize, usize)>],
        depths: &[f32],
        truth: &[f64],
        root_side: u32,
        bits: u8,
        units: Units,
        step: f64,
        limit: f32,
    ) -> Self {
        let mut out = Self {
            bits,
            root_side,
            lattice: units.lattice,
            step: if bits == 0 { 0.0 } else { step },
            exact: Vec::new(),
            residuals: Vec::new(),
            max_error: 0.0,
        };
        let mut held = vec![0f64; depths.len()];
        let mut writer = BitWriter::default();
        for (k, (&z, p)) in depths.iter().zip(parents).enumerate() {
            let decoded = p.and_then(|(a, b)| {
                let prediction = units.predict(held[a], held[b]);
                if bits == 0 {
                    return Some(units.depth(prediction));
                }
                let q = if step > 0.0 {
                    ((truth[k] - prediction) / step).round()
                } else {
                    0.0
                };
                let coded = (q.abs() < f64::from(half(bits)))
                    .then(|| units.depth(prediction + q * step))
                    .filter(|&(d, _)| valid(d) && (d - z).abs() <= limit);
                writer.field(coded.map_or(0, |_| (q + f64::from(half(bits))) as u32), bits);
                coded
            });
            let (d, u) = decoded.unwrap_or_else(|| {
                out.exact.push(z);
                (z, truth[k])
            });
            held[k] = u;
            out.max_error = out.max_error.max((d - z).abs());
        }
        out.residuals = writer.finish();
        out
    }

    /// Decodes the depths of the vertices `ij` (the response's vertices, in order).
    pub fn decode(&self, ij: &[(u16, u16)]) -> Result<Vec<f32>, ResidualError> {
        check_header(self.bits, self.root_side)?;
        let units = Units { lattice: self.lattice };
        if let Some(g) = self.lattice {
            if !(g.scale.is_finite() && g.scale != 0.0 && g.offset.is_finite()) {
                return Err(ResidualError::Header("lattice scale must be finite and non-zero"));
            }
            if !(self.step >= 1.0 && self.step <= MAX_RAW && self.step.fract() == 0.0) {
                return Err(ResidualError::Header("a lattice step is a whole number of raw units"));
            }
        } else if !(self.step.is_finite() && self.step >= 0.0) {
            return Err(ResidualError::Header("step must be finite and not negative"));
        }
        let parents = parents(ij, self.root_side);
        let coded = parents.iter().filter(|p| p.is_some()).count();
        if self.bits > 0 && self.residuals.len() != (coded * usize::from(self.bits)).div_ceil(8) {
            return Err(ResidualError::Truncated("residual bytes do not match the vertices"));
        }
        let mut exact = self.exact.iter();
        let mut reader = BitReader::new(&self.residuals, "residual bits end early or run on");
        let mut held = vec![0f64; ij.len()];
        let mut out = vec![0f32; ij.len()];
        for (k, p) in parents.iter().enumerate() {
            let decoded = match *p {
                None => None,
                Some((a, b)) => {
                    let prediction = units.predict(held[a], held[b]);
                    if self.bits == 0 {
                        Some(units.depth(prediction))
                    } else {
                        let c = reader.field(self.bits).map_err(ResidualError::Truncated)?;
                        let q = f64::from(c) - f64::from(half(self.bits));
                        (c != 0).then(|| units.depth(prediction + q * self.step))
                    }
                }
            };
            let (z, u) = match decoded {
                Some(d) => d,
                None => {
                    let z = *exact.next().ok_or(ResidualError::Truncated("exact depths end early"))?;
                    (z, units.of(z))
                }
            };
            if !valid(z) || (self.lattice.is_some() && u.abs() >= MAX_RAW) {
                return Err(ResidualError::Invalid(z));
            }
            out[k] = z;
            held[k] = u;
        }
        if exact.next().is_some() {
            return Err(ResidualError::Truncated("more exact depths than anchors and escapes"));
        }
        if self.bits > 0 {
            reader.end().map_err(ResidualError::Truncated)?;
        }
        Ok(out)
    }
}

/// The `q`-quantile of `values` (0 when empty), reordering them.
fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let k = ((values.len() - 1) as f64 * q).round() as usize;
    *values.select_nth_unstable_by(k, f64::total_cmp).1
}

/// Whether every depth is `raw * g.scale + g.offset` for an integer `raw`
/// small enough for exact sums.
pub(crate) fn on_lattice(depths: &[f32], g: RawGrid) -> bool {
    g.scale != 0.0
        && g.scale.is_finite()
        && g.offset.is_finite()
        && depths.iter().all(|&z| {
            let r = ((f64::from(z) - g.offset) / g.scale).round();
            r.abs() < MAX_RAW && (r * g.scale + g.offset) as f32 == z
        })
}

fn check_header(bits: u8, root_side: u32) -> Result<(), ResidualError> {
    if bits > MAX_BITS {
        return Err(ResidualError::Bits(bits));
    }
    if !root_side.is_power_of_two() {
        return Err(ResidualError::RootSide(root_side));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every vertex of a 17 x 17 grid (one root quad of side 16), coarse to
    /// fine by the size of its parent edge.
    fn grid_vertices() -> Vec<(u16, u16)> {
        let mut v: Vec<(u16, u16)> = (0..17u16).flat_map(|j| (0..17u16).map(move |i| (i, j))).collect();
        v.sort_by_key(|&(i, j)| match parent_edge((i.into(), j.into()), 16) {
            None => (0, 0),
            Some((a, b)) => {
                let len = a.0.abs_diff(b.0) + a.1.abs_diff(b.1);
                (1, u32::MAX - len)
            }
        });
        v
    }

    fn surface(ij: &[(u16, u16)]) -> Vec<f32> {
        ij.iter()
            .map(|&(i, j)| 2.0 + 0.3 * (f32::from(i) * 0.4).sin() + 0.01 * f32::from(j))
            .collect()
    }

    #[test]
    fn parent_edges_are_bisected_and_coarser() {
        for (i, j) in grid_vertices() {
            let v = (u32::from(i), u32::from(j));
            match parent_edge(v, 16) {
                None => assert!(i % 16 == 0 && j % 16 == 0),
                Some((a, b)) => {
                    assert_eq!((a.0 + b.0, a.1 + b.1), (2 * v.0, 2 * v.1));
                    assert!(a.0 <= 16 && a.1 <= 16 && b.0 <= 16 && b.1 <= 16);
                }
            }
        }
        // A centre bisects the diagonal through its parent square's centre.
        let (a, b) = parent_edge((1, 1), 16).unwrap();
        assert!(a == (2, 2) || b == (2, 2));
    }

    #[test]
    fn every_bit_depth_decodes_within_its_stated_error() {
        let ij = grid_vertices();
        let z = surface(&ij);
        for bits in 0..=MAX_BITS {
            let r = ResidualDepths::encode(&ij, &z, bits, 16, None).unwrap();
            let back = r.decode(&ij).unwrap();
            let worst = back.iter().zip(&z).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert_eq!(worst, r.max_error, "bits {bits}");
            if bits > 0 {
                let bound = r.step() / 2.0 + 4.0 * f64::from(f32::EPSILON);
                assert!(
                    f64::from(r.max_error) <= bound,
                    "bits {bits}: {} > {bound}",
                    r.max_error
                );
                let coded = parents(&ij, 16).iter().filter(|p| p.is_some()).count();
                assert_eq!(r.residuals.len(), (coded * usize::from(bits)).div_ceil(8));
            }
        }
    }

    /// Each added bit at least halves the decoding error, and no bit-depth
    /// is worse than `bits = 0`'s interpolation (issue: 2 bits were).
    fn assert_each_bit_halves(ij: &[(u16, u16)], z: &[f32], raw: Option<RawGrid>) {
        let errors: Vec<f32> = (0..=MAX_BITS)
            .map(|bits| ResidualDepths::encode(ij, z, bits, 16, raw).unwrap().max_error)
            .collect();
        for (b, w) in errors.windows(2).enumerate() {
            assert!(w[1] <= w[0] / 2.0, "bits {} -> {}: {:?}", b, b + 1, errors);
        }
    }

    #[test]
    fn each_bit_at_least_halves_the_error() {
        let ij = grid_vertices();
        assert_each_bit_halves(&ij, &surface(&ij), None);
        // A depth step: large residuals at a few vertices, escaped at low bits.
        let z: Vec<f32> = ij
            .iter()
            .map(|&(i, j)| if i > 11 { 9.0 } else { 1.0 + 0.02 * f32::from(j) })
            .collect();
        assert_each_bit_halves(&ij, &z, None);
        let grid = RawGrid {
            scale: 0.001,
            offset: 0.0,
        };
        let z: Vec<f32> = ij
            .iter()
            .map(|&(i, j)| ((500.0 + f64::from(i * i * 37 + j * 911)) * 0.001) as f32)
            .collect();
        assert_each_bit_halves(&ij, &z, Some(grid));
    }

    #[test]
    fn sixteen_bits_on_the_raw_grid_are_lossless() {
        let ij = grid_vertices();
        let scale = 0.001;
        let z: Vec<f32> = ij
            .iter()
            .map(|&(i, j)| {
                let raw = 1000.0 + f64::from(i) * 3000.0 + f64::from(j * j) * 17.0;
                (raw * scale) as f32
            })
            .collect();
        let grid = RawGrid { scale, offset: 0.0 };
        let r = ResidualDepths::encode(&ij, &z, 16, 16, Some(grid)).unwrap();
        assert_eq!(r.lattice, Some(grid));
        assert_eq!(r.step, 1.0);
        assert_eq!(r.decode(&ij).unwrap(), z);
        assert_eq!(r.max_error, 0.0);
        // Fewer bits coarsen the raw grid by an integer step.
        let r = ResidualDepths::encode(&ij, &z, 2, 16, Some(grid)).unwrap();
        assert!(r.step > 1.0 && r.step.fract() == 0.0, "{}", r.step);
        assert!(f64::from(r.max_error) <= r.step() / 2.0 + 1e-6);
    }

    #[test]
    fn vertices_without_both_parents_are_anchors() {
        // (8, 8) bisects (0, 0)-(16, 16); without (16, 16) it is an anchor.
        let ij = [(0, 0), (16, 0), (0, 16), (8, 8)];
        let z = [1.0, 2.0, 3.0, 4.5];
        let r = ResidualDepths::encode(&ij, &z, 4, 16, None).unwrap();
        assert_eq!(r.exact, z.to_vec());
        assert!(r.residuals.is_empty());
        assert_eq!(r.decode(&ij).unwrap(), z.to_vec());
    }

    #[test]
    fn bad_headers_and_truncation_are_errors() {
        let ij = grid_vertices();
        let z = surface(&ij);
        assert_eq!(
            ResidualDepths::encode(&ij, &z, 17, 16, None).unwrap_err(),
            ResidualError::Bits(17)
        );
        assert!(ResidualDepths::encode(&ij, &z, 4, 12, None).is_err());
        assert!(ResidualDepths::encode(&ij, &z[1..], 4, 16, None).is_err());
        let mut r = ResidualDepths::encode(&ij, &z, 5, 16, None).unwrap();
        r.residuals.pop();
        assert!(matches!(r.decode(&ij), Err(ResidualError::Truncated(_))));
        r.residuals.clear();
        r.exact.clear();
        assert!(r.decode(&ij).is_err());
    }

    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

        #[test]
        fn any_subset_and_depths_decode_positive_and_within_the_stated_error(
            keep in proptest::collection::vec(any::<bool>(), 289),
            logs in proptest::collection::vec(-3.0f64..4.0, 289),
            bits in 0u8..=16,
        ) {
            let ij: Vec<(u16, u16)> = grid_vertices()
                .into_iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(v, _)| v)
                .collect();
            let z: Vec<f32> = logs.iter().take(ij.len()).map(|l| 10f64.powf(*l) as f32).collect();
            let r = ResidualDepths::encode(&ij, &z, bits, 16, None).unwrap();
            let back = r.decode(&ij).unwrap();
            let zmax = z.iter().copied().fold(0f32, f32::max);
            for (a, b) in back.iter().zip(&z) {
                prop_assert!(a.is_finite() && *a > 0.0, "{a}");
                prop_assert!((a - b).abs() <= r.max_error, "{a} vs {b}");
            }
            if bits > 0 {
                let bound = r.step() / 2.0 + 1e-6 * f64::from(zmax);
                prop_assert!(f64::from(r.max_error) <= bound, "{} > {bound}", r.max_error);
            }
        }

        #[test]
        fn raw_grids_of_either_sign_stay_positive(
            raws in proptest::collection::vec(0u16..=u16::MAX, 289),
            negative in any::<bool>(),
            bits in 1u8..=16,
        ) {
            let ij = grid_vertices();
            let grid = if negative {
                RawGrid { scale: -0.001, offset: 65.6 }
            } else {
                RawGrid { scale: 0.001, offset: 0.0 }
            };
            let z: Vec<f32> = raws
                .iter()
                .map(|&r| ((f64::from(r) * grid.scale + grid.offset) as f32).max(1e-3))
                .collect();
            let r = ResidualDepths::encode(&ij, &z, bits, 16, Some(grid)).unwrap();
            let back = r.decode(&ij).unwrap();
            for (a, b) in back.iter().zip(&z) {
                prop_assert!(a.is_finite() && *a > 0.0, "{a}");
                prop_assert!((a - b).abs() <= r.max_error, "{a} vs {b}");
            }
            if bits == 16 && z.iter().all(|&v| v > 1e-3) {
                prop_assert_eq!(back, z.clone());
            }
            if bits > 1 {
                let fewer = ResidualDepths::encode(&ij, &z, bits - 1, 16, Some(grid)).unwrap();
                prop_assert!(r.max_error <= fewer.max_error / 2.0, "{} vs {}", r.max_error, fewer.max_error);
            }
        }
    }

    #[test]
    fn corrupt_headers_are_errors_not_infinities() {
        let ij = grid_vertices();
        let z = surface(&ij);
        let good = ResidualDepths::encode(&ij, &z, 8, 16, None).unwrap();
        let mut r = good.clone();
        r.step = f64::MAX;
        assert!(matches!(r.decode(&ij), Err(ResidualError::Invalid(_))));
        for step in [-1.0, f64::NAN, f64::INFINITY] {
            r.step = step;
            assert!(matches!(r.decode(&ij), Err(ResidualError::Header(_))), "{step}");
        }
        let mut r = good.clone();
        r.lattice = Some(RawGrid {
            scale: 0.0,
            offset: 1.0,
        });
        assert!(matches!(r.decode(&ij), Err(ResidualError::Header(_))));
        r.lattice = Some(RawGrid {
            scale: 1.0,
            offset: -1e6,
        });
        r.step = 1.5;
        assert!(matches!(r.decode(&ij), Err(ResidualError::Header(_))));
        r.step = 1.0;
        assert!(matches!(r.decode(&ij), Err(ResidualError::Invalid(_))));
        let mut r = good;
        r.exact.push(1.0);
        assert!(matches!(r.decode(&ij), Err(ResidualError::Truncated(_))));
    }

    #[test]
    fn bincode_layout_matches_protocol_md() {
        let r = ResidualDepths {
            bits: 3,
            root_side: 16,
            lattice: Some(RawGrid {
                scale: 0.001,
                offset: 0.5,
            }),
            step: 2.0,
            exact: vec![1.5, 2.5],
            residuals: vec![0xab],
            max_error: 0.125,
        };
        let b = crate::to_bincode(&r).unwrap();
        assert_eq!(b[0], 3);
        assert_eq!(&b[1..5], &16u32.to_le_bytes());
        assert_eq!(b[5], 1, "Some(lattice)");
        assert_eq!(&b[6..14], &0.001f64.to_le_bytes());
        assert_eq!(&b[14..22], &0.5f64.to_le_bytes());
        assert_eq!(&b[22..30], &2.0f64.to_le_bytes());
        assert_eq!(&b[30..38], &2u64.to_le_bytes());
        assert_eq!(&b[38..42], &1.5f32.to_le_bytes());
        assert_eq!(&b[46..54], &1u64.to_le_bytes());
        assert_eq!(b[54], 0xab);
        assert_eq!(&b[55..59], &0.125f32.to_le_bytes());
        assert_eq!(b.len(), 59);
        let none = crate::to_bincode(&ResidualDepths { lattice: None, ..r }).unwrap();
        assert_eq!((none[5], none.len()), (0, 59 - 16));
    }

    #[test]
    fn constant_depth_needs_no_step() {
        let ij = grid_vertices();
        let z = vec![3.25f32; ij.len()];
        for bits in [1, 8, 16] {
            let r = ResidualDepths::encode(&ij, &z, bits, 16, None).unwrap();
            assert_eq!(r.decode(&ij).unwrap(), z);
            assert!(r.step().is_finite());
        }
    }
}
