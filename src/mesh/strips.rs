//! Generalised triangle strips from the traversal order (DMesh Sec. 5.3, Fig. 13).
//!
//! The extraction visits triangles in the Sierpinski order of the bintree, in
//! which consecutive triangles share an edge, and marks where a segmented or
//! culled triangle was skipped. This module turns that sequence into one index
//! buffer: consecutive triangles extend the strip by one index; when the next
//! triangle pivots on the older of the two strip vertices (a *swap* of the
//! generalised strip), the older vertex is repeated first, which costs one
//! index and one degenerate triangle (Lindstrom and Pascucci's parity trick,
//! found here by one triangle of look-ahead). A skipped triangle or two
//! consecutive triangles without a shared edge end the strip with
//! [`RESTART`]. Strip winding is not consistent: draw without face culling,
//! or use the indexed triangle list, whose winding is.

/// Primitive-restart marker in the index buffer (`u32::MAX`; a client that
/// uses 16-bit indices maps it to `u16::MAX`).
pub const RESTART: u32 = u32::MAX;

/// A break in the triangle sequence: the next triangle starts a new strip.
pub(crate) const BREAK: [u32; 3] = [RESTART; 3];

fn shares_both(t: &[u32; 3], a: u32, b: u32) -> bool {
    t.contains(&a) && t.contains(&b)
}

fn third(t: &[u32; 3], a: u32, b: u32) -> u32 {
    t.iter()
        .copied()
        .find(|&v| v != a && v != b)
        .unwrap_or(t[0])
}

/// The edge two triangles share, if any.
fn shared(t: &[u32; 3], u: &[u32; 3]) -> Option<(u32, u32)> {
    let mut common = t.iter().copied().filter(|v| u.contains(v));
    match (common.next(), common.next()) {
        (Some(a), Some(b)) => Some((a, b)),
        _ => None,
    }
}

/// Converts a triangle sequence (with [`BREAK`] markers) into strips.
pub(crate) fn stripify(tris: &[[u32; 3]]) -> Vec<u32> {
    let mut out = Vec::with_capacity(tris.len() * 5 / 4 + 8);
    let next_of = |i: usize| tris.get(i).filter(|t| **t != BREAK);
    let mut i = 0;
    while i < tris.len() {
        let t = tris[i];
        if t == BREAK {
            i += 1;
            continue;
        }
        if !out.is_empty() {
            out.push(RESTART);
        }
        // Order the first triangle so that its last two vertices are the edge
        // shared with the next one, the very last also shared with the one after.
        let (mut p, mut q) = (t[1], t[2]);
        let mut o = t[0];
        if let Some(n1) = next_of(i + 1) {
            if let Some((a, b)) = shared(&t, n1) {
                o = third(&t, a, b);
                (p, q) = (a, b);
                let w = third(n1, a, b);
                if let Some(n2) = next_of(i + 2) {
                    if shares_both(n2, p, w) {
                        (p, q) = (q, p);
                    }
                }
            }
        }
        out.extend_from_slice(&[o, p, q]);
        i += 1;
        while let Some(t) = next_of(i) {
            if !shares_both(t, p, q) {
                break;
            }
            let w = third(t, p, q);
            // Look ahead: which of p, q does the next triangle pivot on?
            if next_of(i + 1).is_some_and(|n| shares_both(n, p, w) && !shares_both(n, q, w)) {
                out.push(p);
                out.push(w);
                q = w;
            } else {
                out.push(w);
                (p, q) = (q, w);
            }
            i += 1;
        }
    }
    out
}

/// Decodes strips back into their non-degenerate triangles, as a GPU draws
/// `TRIANGLE_STRIP` with primitive restart. Odd positions are flipped so the
/// result follows the strip's own winding convention.
pub fn decode_strips(indices: &[u32]) -> Vec<[u32; 3]> {
    let mut tris = Vec::new();
    for run in indices.split(|&i| i == RESTART) {
        for (k, w) in run.windows(3).enumerate() {
            let (a, b, c) = (w[0], w[1], w[2]);
            if a == b || b == c || a == c {
                continue;
            }
            tris.push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
        }
    }
    tris
}

#[cfg(test)]
mod tests {
    use super::*;

    fn canon(mut t: [u32; 3]) -> [u32; 3] {
        t.sort_unstable();
        t
    }

    #[test]
    fn a_fan_needs_swaps_and_decodes_exactly() {
        // Fan around vertex 0: (0,1,2), (0,2,3), (0,3,4), (0,4,5).
        let tris = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]];
        let strip = stripify(&tris);
        let mut got: Vec<_> = decode_strips(&strip).into_iter().map(canon).collect();
        got.sort_unstable();
        let mut want: Vec<_> = tris.iter().copied().map(canon).collect();
        want.sort_unstable();
        assert_eq!(got, want, "strip {strip:?}");
        assert!(!strip.contains(&RESTART));
    }

    #[test]
    fn breaks_and_disjoint_triangles_restart() {
        let tris = [[0, 1, 2], BREAK, [1, 2, 3], [7, 8, 9]];
        let strip = stripify(&tris);
        assert_eq!(strip.iter().filter(|&&i| i == RESTART).count(), 2);
        assert_eq!(decode_strips(&strip).len(), 3);
    }
}
