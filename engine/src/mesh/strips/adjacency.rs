//! The triangle adjacency the greedy and tunnelled orders walk, and strips
//! given as links between adjacent triangles turned back into a sequence.

use super::traversal::BREAK;

/// No neighbour, no link.
pub(crate) const NONE: u32 = u32::MAX;

/// For each triangle, the triangle across the edge opposite each corner
/// (`NONE` on a boundary), from a vertex-to-triangle incidence table.
pub(crate) fn adjacency(tris: &[[u32; 3]], vertex_count: usize) -> Vec<[u32; 3]> {
    let mut start = vec![0u32; vertex_count + 1];
    for t in tris {
        for &v in t {
            start[v as usize + 1] += 1;
        }
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut fill = start.clone();
    let mut incident = vec![0u32; tris.len() * 3];
    for (i, t) in tris.iter().enumerate() {
        for &v in t {
            incident[fill[v as usize] as usize] = i as u32;
            fill[v as usize] += 1;
        }
    }
    tris.iter()
        .enumerate()
        .map(|(i, t)| {
            [0, 1, 2].map(|k| {
                let (a, b) = (t[(k + 1) % 3], t[(k + 2) % 3]);
                incident[start[a as usize] as usize..start[a as usize + 1] as usize]
                    .iter()
                    .copied()
                    .find(|&o| o as usize != i && tris[o as usize].contains(&b))
                    .unwrap_or(NONE)
            })
        })
        .collect()
}

/// The triangles of the strips given as `links` (each triangle's strip
/// neighbours, `NONE` at an end), strip by strip from one end, with
/// [`BREAK`] between strips; a closed loop of links, which neither the
/// greedy nor the tunnels make, would be opened anywhere.
pub(crate) fn in_order(tris: &[[u32; 3]], links: &[[u32; 2]]) -> Vec<[u32; 3]> {
    let mut out = Vec::with_capacity(tris.len() + tris.len() / 8);
    let mut done = vec![false; tris.len()];
    let starts = (0..tris.len()).filter(|&t| links[t].contains(&NONE));
    for t in starts.chain(0..tris.len()) {
        if done[t] {
            continue;
        }
        let (mut prev, mut cur) = (NONE, t as u32);
        while cur != NONE && !done[cur as usize] {
            done[cur as usize] = true;
            out.push(tris[cur as usize]);
            let [a, b] = links[cur as usize];
            let next = if a == prev { b } else { a };
            (prev, cur) = (cur, next);
        }
        out.push(BREAK);
    }
    out
}
