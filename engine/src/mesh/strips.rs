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
//!
//! The other two [`StripOrder`]s build strips over the triangle adjacency
//! instead, as links between triangles that `in_order` turns back into a
//! sequence for `stripify`: a greedy, and fan walks joined by tunnels
//! (`tunnel.rs`).

/// How triangles are ordered into strips.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StripOrder {
    /// The traversal's own Sierpinski order, in the same pass (DMesh, Lindstrom
    /// and Pascucci): fastest, about 1.7 indices per triangle.
    #[default]
    Traversal,
    /// Greedy strips over the triangle adjacency, seeded at the triangles with
    /// the fewest free neighbours and grown both ways: about 1.43 indices per
    /// triangle, for roughly twice the extraction time.
    Greedy,
    /// Strips that walk whole fans around right-angle corners, then joined
    /// and improved by tunnels weighed by their exact index count: about 1.35
    /// indices per triangle on adaptive meshes and 1.27 at full resolution,
    /// for 5 to 20 times the extraction time of [`StripOrder::Traversal`].
    Tunnelled,
}

/// Primitive-restart marker in the index buffer (`u32::MAX`; a client that
/// uses 16-bit indices maps it to `u16::MAX`).
pub const RESTART: u32 = u32::MAX;

/// A break in the triangle sequence: the next triangle starts a new strip.
pub(crate) const BREAK: [u32; 3] = [RESTART; 3];

fn shares_both(t: &[u32; 3], a: u32, b: u32) -> bool {
    t.contains(&a) && t.contains(&b)
}

fn third(t: &[u32; 3], a: u32, b: u32) -> u32 {
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

/// Greedy generalised strips over the triangle adjacency, seeded in the
/// given (Sierpinski) order: from each unused triangle, walk to the
/// neighbour across the edge of the last two strip vertices; before each
/// step prefer the continuation that needs no swap, take a swap (one
/// repeated index) when only the other edge leads on, and restart when
/// neither does. Unlike [`stripify`] on the traversal order, which walks
/// around vertices in fans and so swaps at most steps.
pub(crate) fn stripify_greedy(tris: &[[u32; 3]], vertex_count: usize) -> Vec<u32> {
    let nb = adjacency(tris, vertex_count);
    let links = greedy_paths(tris, &nb, vertex_count, false);
    stripify(&in_order(tris, &links))
}

/// Strips that walk around right-angle corners, joined by tunnels
/// (`tunnel.rs`). `tris` must have their right-angle corner last, as the
/// extraction emits them.
///
/// Why fans: on a uniform 4-8 mesh every triangle has its right angle at a
/// vertex with four such triangles around it. A strip that enters such a
/// fan across one hypotenuse, walks all four triangles and leaves across
/// the hypotenuse next to it writes the corner twice and needs one swap per
/// fan; the fans then chain into strips along the grid rows, for
/// 1.25 indices per triangle, which is the per-vertex lower bound of such a
/// mesh (a corner of `k` triangles is written at least `ceil(k / 3)` times).
/// The greedy's swap-avoiding steps instead strand triangles.
pub(crate) fn stripify_tunnelled(tris: &[[u32; 3]], vertex_count: usize) -> Vec<u32> {
    let nb = adjacency(tris, vertex_count);
    let mut links = greedy_paths(tris, &nb, vertex_count, true);
    super::tunnel::join(tris, &nb, &mut links);
    stripify(&in_order(tris, &links))
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

/// The greedy's strips as links: for each triangle, the triangles before
/// and after it in its strip (`NONE` at an end). `fans`: see
/// [`stripify_tunnelled`].
fn greedy_paths(tris: &[[u32; 3]], nb: &[[u32; 3]], vertex_count: usize, fans: bool) -> Vec<[u32; 2]> {
    let across = |t: usize, a: u32, b: u32| -> u32 {
        let k = (0..3).find(|&k| tris[t][k] != a && tris[t][k] != b).unwrap_or(0);
        nb[t][k]
    };
    let mut used = vec![false; tris.len()];
    let free = |used: &[bool], n: u32| n != NONE && !used[n as usize];
    let mut links = vec![[NONE; 2]; tris.len()];
    // Triangles with their right angle at each vertex (fans of at most 4).
    let mut fan_size = vec![0u8; if fans { vertex_count } else { 0 }];
    for t in tris.iter().filter(|_| fans) {
        fan_size[t[2] as usize] = fan_size[t[2] as usize].saturating_add(1);
    }
    // Seeds: the unused triangle with the fewest unused neighbours first (so
    // strips do not strand single triangles), ties in traversal order. Lazy
    // buckets: an entry is skipped when its count went stale.
    let mut degree: Vec<u8> = nb
        .iter()
        .map(|n| n.iter().filter(|&&m| m != NONE).count() as u8)
        .collect();
    let mut buckets: [Vec<u32>; 4] = Default::default();
    for (t, &d) in degree.iter().enumerate().rev() {
        buckets[usize::from(d)].push(t as u32);
    }
    let take = |t: usize, used: &mut [bool], degree: &mut [u8], buckets: &mut [Vec<u32>; 4]| {
        used[t] = true;
        for &m in &nb[t] {
            if m != NONE && !used[m as usize] {
                degree[m as usize] -= 1;
                buckets[usize::from(degree[m as usize])].push(m);
            }
        }
    };
    // Walks on from triangle `cur` across the edge of the last two strip
    // vertices `(p, q)`, linking each triangle it takes to the one before.
    let walk = |mut cur: usize,
                (mut p, mut q): (u32, u32),
                used: &mut [bool],
                degree: &mut [u8],
                buckets: &mut [Vec<u32>; 4],
                links: &mut [[u32; 2]],
                side: usize| {
        while free(used, across(cur, p, q)) {
            let n = across(cur, p, q) as usize;
            take(n, used, degree, buckets);
            links[cur][side] = n as u32;
            links[n][1 - side] = cur as u32;
            cur = n;
            let w = third(&tris[n], p, q);
            let (straight, turn) = (across(n, q, w), across(n, p, w));
            // Between the two ways on, take the one into the triangle with fewer
            // free neighbours (it would otherwise be stranded), a swap costing
            // one index more.
            let score = |m: u32| if free(used, m) { Some(degree[m as usize]) } else { None };
            // With `fans`: around the right-angle corner `v` of `n`, if at
            // least three triangles have it (a fan of two walked from
            // hypotenuse to hypotenuse needs a swap), walk on through them
            // while there are any, then leave across the hypotenuse (the
            // edge without `v`).
            let v = tris[n][2];
            let fans = fans && fan_size[v as usize] >= 3;
            let in_fan = |m: u32| free(used, m) && tris[m as usize][2] == v;
            let go_straight = if fans && (in_fan(straight) || in_fan(turn)) {
                in_fan(straight)
            } else if fans && w != v && (free(used, straight) || free(used, turn)) {
                if q != v {
                    free(used, straight)
                } else {
                    !free(used, turn)
                }
            } else {
                match (score(straight), score(turn)) {
                    (Some(a), Some(b)) => a <= b + 1,
                    (Some(_), None) => true,
                    (None, Some(_)) => false,
                    (None, None) => true,
                }
            };
            if go_straight {
                (p, q) = (q, w);
            } else {
                q = w;
            }
        }
    };
    let next_seed = |used: &[bool], degree: &[u8], buckets: &mut [Vec<u32>; 4]| {
        (0..4).find_map(|d| {
            while let Some(t) = buckets[d].pop() {
                if !used[t as usize] && usize::from(degree[t as usize]) == d {
                    return Some(t as usize);
                }
            }
            None
        })
    };
    while let Some(seed) = next_seed(&used, &degree, &mut buckets) {
        take(seed, &mut used, &mut degree, &mut buckets);
        let t = tris[seed];
        // Leave forwards across the edge whose neighbour leads on best.
        let k = (0..3)
            .filter(|&k| free(&used, nb[seed][k]))
            .max_by_key(|&k| nb[nb[seed][k] as usize].iter().filter(|&&m| free(&used, m)).count())
            .unwrap_or(0);
        let (o, p, q) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        walk(seed, (p, q), &mut used, &mut degree, &mut buckets, &mut links, 1);
        // Then backwards across (p, o), a strip [q, p, o, ...] reversed.
        walk(seed, (p, o), &mut used, &mut degree, &mut buckets, &mut links, 0);
    }
    links
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
pub(crate) mod tests {
    use super::*;

    fn canon(mut t: [u32; 3]) -> [u32; 3] {
        t.sort_unstable();
        t
    }

    /// The strips decode to exactly the triangles `tris`, each once.
    pub(crate) fn assert_exact(tris: &[[u32; 3]], strips: &[u32]) {
        let mut got: Vec<_> = decode_strips(strips).into_iter().map(canon).collect();
        let mut want: Vec<_> = tris.iter().copied().map(canon).collect();
        got.sort_unstable();
        want.sort_unstable();
        assert_eq!(got, want, "strips {strips:?}");
    }

    #[test]
    fn a_fan_needs_swaps_and_decodes_exactly() {
        // Fan around vertex 0: (0,1,2), (0,2,3), (0,3,4), (0,4,5).
        let tris = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]];
        let strip = stripify(&tris);
        assert_exact(&tris, &strip);
        assert!(!strip.contains(&RESTART));
    }

    #[test]
    fn greedy_strips_of_a_grid_decode_exactly_and_need_few_indices() {
        // A 10 x 10 grid of quads, two triangles each, in row order.
        let n = 10u32;
        let v = |x: u32, y: u32| y * (n + 1) + x;
        let mut tris = Vec::new();
        for y in 0..n {
            for x in 0..n {
                tris.push([v(x, y), v(x + 1, y), v(x, y + 1)]);
                tris.push([v(x + 1, y), v(x + 1, y + 1), v(x, y + 1)]);
            }
        }
        let strip = stripify_greedy(&tris, ((n + 1) * (n + 1)) as usize);
        assert_exact(&tris, &strip);
        assert!(
            strip.len() as f64 / (tris.len() as f64) < 1.2,
            "{} indices",
            strip.len()
        );
    }

    #[test]
    fn breaks_and_disjoint_triangles_restart() {
        let tris = [[0, 1, 2], BREAK, [1, 2, 3], [7, 8, 9]];
        let strip = stripify(&tris);
        assert_eq!(strip.iter().filter(|&&i| i == RESTART).count(), 2);
        assert_eq!(decode_strips(&strip).len(), 3);
    }
}
