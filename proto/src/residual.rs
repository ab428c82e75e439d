//! Residual bit-depth coding of vertex depths (DESIGN.md "Residual
//! bit-depth"; the proxy-plus-residue idea of Verlani et al. Sec. 4, Table 2,
//! with the mesh's own coarser levels as the proxy).
//!
//! Vertices travel coarse to fine. Each depth is a code `n` in `0..2^bits` on a
//! uniform grid, `z = ((code_origin + n * code_step) * scale + offset) as f32`
//! (the arithmetic in f64), sent as the residual from the prediction of its
//! *parent edge*: the vertex bisects the edge `a-b` of the restricted quadtree
//! (the same `a, b` as its error metric), both endpoints come earlier, and the
//! prediction is `(n_a + n_b) >> 1`. The residual is taken modulo `2^bits`, so
//! it always fits in `bits` bits and decoding is exact on the code grid; small
//! residuals (smooth surfaces) compress well under gzip or zstd.
//!
//! A vertex whose parent edge has an endpoint missing from the mesh (root
//! corners, and vertices next to dropped, segmented triangles) is an *anchor*:
//! its depth travels as an exact `f32`. With `bits = 0` no residuals travel and
//! every other depth is the mean of its parent edge's decoded depths.
//!
//! When the server knows the depth came from integers (`z = raw * scale +
//! offset`, a 16-bit PNG for instance) the code grid is the raw grid, so
//! `bits = 16` reproduces those depths bit for bit. Otherwise the grid spans
//! the mesh's depth range in `2^bits - 1` steps. Either way `max_error` states
//! the largest decoding error of this response, computed by the encoder
//! running the decoder; for `bits >= 1` it is at most half a step
//! ([`ResidualDepths::step`]) plus the f32 rounding of the depth.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

/// Largest residual bit-depth.
pub const MAX_BITS: u8 = 16;

/// Depths coded as residuals from parent-edge predictions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResidualDepths {
    /// Bits per residual, `0..=16`.
    pub bits: u8,
    /// Side of the root quads of the reference view's grid (a power of two):
    /// it decides each vertex's parent edge, see [`parent_edge`].
    pub root_side: u32,
    /// Metres per raw unit.
    pub scale: f64,
    /// Metres at raw 0.
    pub offset: f64,
    /// Raw value of code 0.
    pub code_origin: i64,
    /// Raw units per code step.
    pub code_step: u32,
    /// Exact depths of the anchor vertices, in vertex order.
    pub anchors: Vec<f32>,
    /// One `bits`-bit residual per non-anchor vertex in vertex order, packed
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
    /// Fewer anchors or residual bits than the vertices need.
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
/// quads of side `root_side` (a power of two), or `None` for a root corner.
///
/// With `t` the largest power of two dividing both coordinates (at most
/// `root_side / 2`), and `h = t`: if `i / h` and `j / h` are both odd the
/// vertex is a square's centre and bisects the diagonal through the corner
/// whose coordinates are both odd multiples of `2h`; otherwise it is the
/// midpoint of the edge of length `2h` along the axis of its odd coordinate.
pub fn parent_edge((i, j): (u32, u32), root_side: u32) -> Option<((u32, u32), (u32, u32))> {
    let s = root_side.max(2);
    if i % s == 0 && j % s == 0 {
        return None;
    }
    let cap = s.trailing_zeros();
    let tz = |c: u32| if c == 0 { cap } else { c.trailing_zeros().min(cap) };
    let (tx, ty) = (tz(i), tz(j));
    let h = 1u32 << tx.min(ty);
    Some(match tx.cmp(&ty) {
        std::cmp::Ordering::Equal => {
            // Of c - h and c + h, the odd multiple of 2h.
            let odd = |c: u32| if ((c - h) / (2 * h)) % 2 == 1 { c - h } else { c + h };
            let (px, py) = (odd(i), odd(j));
            ((px, py), (2 * i - px, 2 * j - py))
        }
        std::cmp::Ordering::Less => ((i - h, j), (i + h, j)),
        std::cmp::Ordering::Greater => ((i, j - h), (i, j + h)),
    })
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

impl ResidualDepths {
    /// Metres per code step: the quantisation step (0 with `bits = 0`).
    pub fn step(&self) -> f64 {
        if self.bits == 0 {
            0.0
        } else {
            f64::from(self.code_step) * self.scale.abs()
        }
    }

    /// Depth of code `n`.
    fn depth_of(&self, n: u32) -> f32 {
        let raw = self.code_origin + i64::from(n) * i64::from(self.code_step);
        (raw as f64 * self.scale + self.offset) as f32
    }

    /// The code nearest to depth `z`, clamped to `0..2^bits`.
    fn code_of(&self, z: f32) -> u32 {
        let raw = ((f64::from(z) - self.offset) / self.scale).round();
        let n = ((raw - self.code_origin as f64) / f64::from(self.code_step)).round();
        n.clamp(0.0, f64::from((1u32 << self.bits) - 1)) as u32
    }

    /// Codes `depths` of the vertices `ij` (coarse to fine) with `bits` bits.
    /// `raw` is used when every depth lies on it exactly.
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
        let mut out = Self {
            bits,
            root_side,
            scale: 1.0,
            offset: 0.0,
            code_origin: 0,
            code_step: 1,
            anchors: Vec::new(),
            residuals: Vec::new(),
            max_error: 0.0,
        };
        if bits > 0 {
            out.choose_grid(depths, raw);
        }
        let parents = parents(ij, root_side);
        let mut codes = vec![0u32; ij.len()];
        let mut decoded = vec![0f32; ij.len()];
        let mut writer = BitWriter::default();
        let modulus_mask = if bits == 0 { 0 } else { (1u32 << bits) - 1 };
        for (k, (&z, p)) in depths.iter().zip(&parents).enumerate() {
            match *p {
                None => {
                    out.anchors.push(z);
                    decoded[k] = z;
                    codes[k] = if bits > 0 { out.code_of(z) } else { 0 };
                }
                Some((a, b)) if bits == 0 => decoded[k] = mean(decoded[a], decoded[b]),
                Some((a, b)) => {
                    let n = out.code_of(z);
                    let prediction = (codes[a] + codes[b]) >> 1;
                    writer.push(n.wrapping_sub(prediction) & modulus_mask, bits);
                    codes[k] = n;
                    decoded[k] = out.depth_of(n);
                }
            }
            out.max_error = out.max_error.max((decoded[k] - z).abs());
        }
        out.residuals = writer.finish();
        // A coarsened raw grid can round past the depth range; with a
        // negative scale that could reach zero. The range grid cannot.
        if raw.is_some() && decoded.iter().any(|z| !(z.is_finite() && *z > 0.0)) {
            return Self::encode(ij, depths, bits, root_side, None);
        }
        Ok(out)
    }

    /// Picks the code grid: the raw grid when every depth lies on it (coarsened
    /// by an integer step until the span fits), else the depth range.
    fn choose_grid(&mut self, depths: &[f32], raw: Option<RawGrid>) {
        let levels = (1u64 << self.bits) - 1;
        let on_raw = raw.filter(|g| g.scale != 0.0 && g.scale.is_finite()).and_then(|g| {
            let mut lo = i64::MAX;
            let mut hi = i64::MIN;
            for &z in depths {
                let r = ((f64::from(z) - g.offset) / g.scale).round();
                if r.is_nan() || r.abs() >= 9e15 || (r * g.scale + g.offset) as f32 != z {
                    return None;
                }
                lo = lo.min(r as i64);
                hi = hi.max(r as i64);
            }
            Some((g, lo, hi))
        });
        match on_raw {
            Some((g, lo, hi)) if lo <= hi => {
                let span = (hi - lo) as u64;
                let step = span.div_ceil(levels).max(1);
                if let Ok(step) = u32::try_from(step) {
                    self.scale = g.scale;
                    self.offset = g.offset;
                    self.code_origin = lo;
                    self.code_step = step;
                    return;
                }
            }
            _ => {}
        }
        let (lo, hi) = depths
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &z| (l.min(z), h.max(z)));
        if lo < hi {
            self.offset = f64::from(lo);
            self.scale = (f64::from(hi) - f64::from(lo)) / levels as f64;
        } else if lo.is_finite() {
            self.offset = f64::from(lo);
        }
    }

    /// Decodes the depths of the vertices `ij` (the response's vertices, in order).
    pub fn decode(&self, ij: &[(u16, u16)]) -> Result<Vec<f32>, ResidualError> {
        check_header(self.bits, self.root_side)?;
        let parents = parents(ij, self.root_side);
        let coded = parents.iter().filter(|p| p.is_some()).count();
        if self.anchors.len() != parents.len() - coded {
            return Err(ResidualError::Truncated("anchor count does not match the vertices"));
        }
        if self.bits > 0 && self.residuals.len() != (coded * usize::from(self.bits)).div_ceil(8) {
            return Err(ResidualError::Truncated("residual bytes do not match the vertices"));
        }
        let mask = if self.bits == 0 { 0 } else { (1u32 << self.bits) - 1 };
        let mut anchors = self.anchors.iter();
        let mut reader = BitReader::new(&self.residuals);
        let mut codes = vec![0u32; ij.len()];
        let mut out = vec![0f32; ij.len()];
        for (k, p) in parents.iter().enumerate() {
            match *p {
                None => {
                    let z = *anchors.next().ok_or(ResidualError::Truncated("anchors"))?;
                    out[k] = z;
                    codes[k] = if self.bits > 0 { self.code_of(z) } else { 0 };
                }
                Some((a, b)) if self.bits == 0 => out[k] = mean(out[a], out[b]),
                Some((a, b)) => {
                    let r = reader.take(self.bits);
                    let n = ((codes[a] + codes[b]) >> 1).wrapping_add(r) & mask;
                    codes[k] = n;
                    out[k] = self.depth_of(n);
                }
            }
            if !(out[k].is_finite() && out[k] > 0.0) {
                return Err(ResidualError::Invalid(out[k]));
            }
        }
        Ok(out)
    }
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

fn mean(a: f32, b: f32) -> f32 {
    ((f64::from(a) + f64::from(b)) * 0.5) as f32
}

#[derive(Default)]
struct BitWriter {
    bytes: Vec<u8>,
    acc: u64,
    filled: u32,
}

impl BitWriter {
    fn push(&mut self, value: u32, bits: u8) {
        self.acc |= u64::from(value) << self.filled;
        self.filled += u32::from(bits);
        while self.filled >= 8 {
            self.bytes.push(self.acc as u8);
            self.acc >>= 8;
            self.filled -= 8;
        }
    }

    fn finish(mut self) -> Vec<u8> {
        if self.filled > 0 {
            self.bytes.push(self.acc as u8);
        }
        self.bytes
    }
}

struct BitReader<'a> {
    bytes: &'a [u8],
    next: usize,
    acc: u64,
    filled: u32,
}

impl<'a> BitReader<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Self {
            bytes,
            next: 0,
            acc: 0,
            filled: 0,
        }
    }

    /// The next `bits` bits; lengths are checked before reading, so running
    /// out yields zeros rather than a panic.
    fn take(&mut self, bits: u8) -> u32 {
        while self.filled < u32::from(bits) {
            let byte = self.bytes.get(self.next).copied().unwrap_or(0);
            self.acc |= u64::from(byte) << self.filled;
            self.next += 1;
            self.filled += 8;
        }
        let v = (self.acc & ((1u64 << bits) - 1)) as u32;
        self.acc >>= bits;
        self.filled -= u32::from(bits);
        v
    }
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
                let coded = ij.len() - r.anchors.len();
                assert_eq!(r.residuals.len(), (coded * usize::from(bits)).div_ceil(8));
            }
        }
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
        assert_eq!(r.code_step, 1);
        assert_eq!(r.decode(&ij).unwrap(), z);
        assert_eq!(r.max_error, 0.0);
        // Fewer bits coarsen the raw grid by an integer step.
        let r = ResidualDepths::encode(&ij, &z, 8, 16, Some(grid)).unwrap();
        assert!(r.code_step > 1);
        assert!(f64::from(r.max_error) <= r.step() / 2.0 + 1e-6);
    }

    #[test]
    fn vertices_without_both_parents_are_anchors() {
        // (8, 8) bisects (0, 0)-(16, 16); without (16, 16) it is an anchor.
        let ij = [(0, 0), (16, 0), (0, 16), (8, 8)];
        let z = [1.0, 2.0, 3.0, 4.5];
        let r = ResidualDepths::encode(&ij, &z, 4, 16, None).unwrap();
        assert_eq!(r.anchors, z.to_vec());
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
        r.anchors.clear();
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
                prop_assert_eq!(back, z);
            }
        }
    }

    #[test]
    fn corrupt_headers_are_errors_not_infinities() {
        let ij = grid_vertices();
        let z = surface(&ij);
        let mut r = ResidualDepths::encode(&ij, &z, 8, 16, None).unwrap();
        r.scale = f64::MAX;
        assert!(matches!(r.decode(&ij), Err(ResidualError::Invalid(_))));
        r.scale = 0.0;
        r.offset = -1.0;
        assert!(matches!(r.decode(&ij), Err(ResidualError::Invalid(_))));
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
