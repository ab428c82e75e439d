//! Greedy generalised strips over the triangle adjacency, and the fan walks
//! the tunnelled order starts from.

use super::adjacency::{adjacency, in_order, NONE};
use super::traversal::{stripify, third};

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

/// The greedy's strips as links: for each triangle, the triangles before
/// and after it in its strip (`NONE` at an end). `fans`: see
/// [`super::stripify_tunnelled`].
pub(super) fn greedy_paths(tris: &[[u32; 3]], nb: &[[u32; 3]], vertex_count: usize, fans: bool) -> Vec<[u32; 2]> {
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
