//! Strips in the traversal's own order (DMesh Sec. 5.3, Fig. 13; Lindstrom
//! and Pascucci's parity trick), the restart marker, and their decoding.

/// Primitive-restart marker in the index buffer (`u32::MAX`; a client that
/// uses 16-bit indices maps it to `u16::MAX`).
pub const RESTART: u32 = u32::MAX;

/// A break in the triangle sequence: the next triangle starts a new strip.
pub(crate) const BREAK: [u32; 3] = [RESTART; 3];

fn shares_both(t: &[u32; 3], a: u32, b: u32) -> bool {
    t.contains(&a) && t.contains(&b)
}

pub(super) fn third(t: &[u32; 3], a: u32, b: u32) -> u32 {
    t.iter().copied().find(|&v| v != a && v != b).unwrap_or(t[0])
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
    // About 1.7 indices per triangle in traversal order: one allocation.
    let mut out = Vec::with_capacity(tris.len() * 7 / 4 + 8);
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
