//! Joining strips by tunnelling (Stewart, "Tunneling for triangle strips in
//! continuous level-of-detail meshes", GI 2001), weighed by the exact index
//! count of generalised strips.
//!
//! A set of strips is a set of *links* between adjacent triangles in which
//! every triangle has at most two and which has no cycle: the strips are
//! its paths. A tunnel is an alternating path in the triangle adjacency from
//! one strip end to another: its odd edges are not links, its even edges
//! are; swapping the two kinds keeps every inner triangle at its degree and
//! gives each end one link more, so two strips become one. The same path
//! stopped after a link (an even edge) moves a strip end instead: as many
//! strips, routed differently, kept when that removes swaps.
//!
//! What a strip costs: with `n` triangles and `s` swaps it takes `n + 2 + s`
//! indices and one restart before the next, so the whole index buffer is
//! `4 T - 1 - sum over links of (3 - swap(link))`, where a link between two
//! inner triangles is a swap when both *pivot* on the same vertex (the
//! corner a triangle shares with both its strip neighbours; the older of
//! two equal pivots must be written again). A link is worth 3 indices, or 2
//! when it is a swap, and a pivot depends only on a triangle's own two
//! links, so the change each step of a tunnel makes is counted over the
//! links at the two or three triangles it touches. The search applies a
//! tunnel step by step, depth first, adding up those changes, and keeps
//! the first tunnel that saves indices and closes no cycle.

use super::adjacency::{adjacency, in_order, NONE};
use super::greedy::greedy_paths;
use super::traversal::stripify;

/// Strips that walk around right-angle corners, joined by tunnels
/// (below). `tris` must have their right-angle corner last, as the
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
    join(tris, &nb, &mut links);
    stripify(&in_order(tris, &links))
}

/// Alternations (link removals) in one tunnel at most: the search from a
/// strip end grows by at most four ways per alternation.
const DEPTH: usize = 4;

/// Passes over all strip ends. Every tunnel kept saves at least one index,
/// so a pass that keeps none ends the search early.
const PASSES: usize = 3;

struct Strips<'a> {
    tris: &'a [[u32; 3]],
    nb: &'a [[u32; 3]],
    /// The (unordered) strip neighbours of each triangle, `NONE` if fewer.
    links: &'a mut [[u32; 2]],
    /// Each triangle's pivot, `NONE` unless it has two strip neighbours.
    pivots: Vec<u32>,
}

impl<'a> Strips<'a> {
    fn degree(&self, t: u32) -> usize {
        self.links[t as usize].iter().filter(|&&l| l != NONE).count()
    }

    fn linked(&self, t: u32, u: u32) -> bool {
        self.links[t as usize].contains(&u)
    }

    fn new(tris: &'a [[u32; 3]], nb: &'a [[u32; 3]], links: &'a mut [[u32; 2]]) -> Self {
        let mut s = Self {
            tris,
            nb,
            links,
            pivots: vec![NONE; tris.len()],
        };
        for t in 0..tris.len() as u32 {
            s.pivots[t as usize] = s.pivot(t);
        }
        s
    }

    fn link(&mut self, t: u32, u: u32) {
        for (a, b) in [(t, u), (u, t)] {
            let l = &mut self.links[a as usize];
            debug_assert!(l.contains(&NONE), "a triangle has two strip neighbours at most");
            let slot = if l[0] == NONE { 0 } else { 1 };
            l[slot] = b;
            self.pivots[a as usize] = self.pivot(a);
        }
    }

    fn unlink(&mut self, t: u32, u: u32) {
        for (a, b) in [(t, u), (u, t)] {
            for l in &mut self.links[a as usize] {
                if *l == b {
                    *l = NONE;
                }
            }
            self.pivots[a as usize] = NONE;
        }
    }

    /// The corner `t` shares with both its strip neighbours, if it has two
    /// (the corner across neither link), else `NONE`.
    fn pivot(&self, t: u32) -> u32 {
        let [l0, l1] = self.links[t as usize];
        if l0 == NONE || l1 == NONE {
            return NONE;
        }
        let n = &self.nb[t as usize];
        (0..3)
            .find(|&k| n[k] != l0 && n[k] != l1)
            .map_or(NONE, |k| self.tris[t as usize][k])
    }

    /// What the links at the triangles `on` are worth: 3 indices each, 2
    /// for a swap; a link between two of them counts once.
    fn worth(&self, on: &[u32]) -> i64 {
        let mut sum = 0;
        for (i, &t) in on.iter().enumerate() {
            let pt = self.pivots[t as usize];
            for &u in &self.links[t as usize] {
                if u == NONE || on[..i].contains(&u) {
                    continue;
                }
                sum += if pt != NONE && pt == self.pivots[u as usize] {
                    2
                } else {
                    3
                };
            }
        }
        sum
    }

    /// Whether the strip through `t` closes on itself.
    fn cycles(&self, t: u32) -> bool {
        let (mut prev, mut cur) = (t, self.links[t as usize][0]);
        if cur == NONE {
            return false;
        }
        loop {
            if cur == t {
                return true;
            }
            let [a, b] = self.links[cur as usize];
            let next = if a == prev { b } else { a };
            if next == NONE {
                return false;
            }
            (prev, cur) = (cur, next);
        }
    }

    /// Looks for a tunnel on from the strip end `x`, with the tunnel so far
    /// already applied: `on` are its triangles, `gain` the indices it has
    /// saved so far. Keeps the first tunnel that saves indices and closes no
    /// cycle (and returns true); undoes every other step.
    fn search(&mut self, x: u32, on: &mut Vec<u32>, gain: i64) -> bool {
        for k in 0..3 {
            let u = self.nb[x as usize][k];
            if u == NONE || self.linked(x, u) || on.contains(&u) {
                continue;
            }
            on.push(u);
            if self.degree(u) < 2 {
                // Join x to the strip end u.
                let before = self.worth(&[x, u]);
                self.link(x, u);
                let g = gain + self.worth(&[x, u]) - before;
                if g > 0 && !on.iter().any(|&t| self.cycles(t)) {
                    return true;
                }
                self.unlink(x, u);
            } else if on.len() <= 2 * DEPTH {
                for w in self.links[u as usize] {
                    if on.contains(&w) {
                        continue;
                    }
                    // Link x to u in place of w, which becomes a strip end:
                    // keep that if it already saves indices, else go on from w.
                    on.push(w);
                    let before = self.worth(&[x, u, w]);
                    self.unlink(u, w);
                    self.link(x, u);
                    let g = gain + self.worth(&[x, u, w]) - before;
                    if (g > 0 && !on.iter().any(|&t| self.cycles(t))) || self.search(w, on, g) {
                        return true;
                    }
                    self.unlink(x, u);
                    self.link(u, w);
                    on.pop();
                }
            }
            on.pop();
        }
        false
    }
}

/// Joins and re-routes the strips given as `links` (each triangle's strip
/// neighbours, `NONE` at an end) by tunnels that save indices.
pub(crate) fn join(tris: &[[u32; 3]], nb: &[[u32; 3]], links: &mut [[u32; 2]]) {
    let mut s = Strips::new(tris, nb, links);
    let mut on = Vec::new();
    for _ in 0..PASSES {
        let mut joined = false;
        for t in 0..tris.len() as u32 {
            while s.degree(t) < 2 {
                on.clear();
                on.push(t);
                if !s.search(t, &mut on, 0) {
                    break;
                }
                joined = true;
            }
        }
        if !joined {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::strips::stripify_greedy;
    use crate::mesh::strips::tests::assert_exact;

    /// An `n` x `n` 4-8 mesh of unit cells, diagonals alternating so that
    /// they meet at every other vertex, each triangle's right angle last;
    /// every `hole`-th triangle left out.
    fn mesh48(n: u32, hole: usize) -> (Vec<[u32; 3]>, usize) {
        let v = |x: u32, y: u32| y * (n + 1) + x;
        let mut tris = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let (a, b, c, d) = (v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y + 1));
                if (x + y) % 2 == 0 {
                    tris.extend([[a, c, b], [c, a, d]]);
                } else {
                    tris.extend([[b, d, c], [d, b, a]]);
                }
            }
        }
        if hole > 0 {
            tris = tris
                .into_iter()
                .enumerate()
                .filter(|(i, _)| i % hole != 1)
                .map(|(_, t)| t)
                .collect();
        }
        (tris, ((n + 1) * (n + 1)) as usize)
    }

    /// Links between consecutive triangles of the list where they are
    /// adjacent: rows of the grid, in pieces where holes break them.
    fn serpentine(tris: &[[u32; 3]], nb: &[[u32; 3]]) -> Vec<[u32; 2]> {
        let mut links = vec![[NONE; 2]; tris.len()];
        let mut s = Strips::new(tris, nb, &mut links);
        for t in 1..tris.len() as u32 {
            if nb[t as usize].contains(&(t - 1)) && s.degree(t - 1) < 2 {
                s.link(t - 1, t);
            }
        }
        links
    }

    #[test]
    fn the_index_count_is_what_the_links_are_worth() {
        for (n, hole) in [(6, 0), (9, 7), (12, 5)] {
            let (tris, nv) = mesh48(n, hole);
            let nb = adjacency(&tris, nv);
            let mut links = serpentine(&tris, &nb);
            let s = Strips::new(&tris, &nb, &mut links);
            let all: Vec<u32> = (0..tris.len() as u32).collect();
            let predicted = 4 * tris.len() as i64 - 1 - s.worth(&all);
            let strips = stripify(&in_order(&tris, &links));
            assert_exact(&tris, &strips);
            assert_eq!(strips.len() as i64, predicted, "n {n} hole {hole}");
        }
    }

    #[test]
    fn tunnels_alone_join_single_triangles_into_strips() {
        let (tris, nv) = mesh48(10, 0);
        let nb = adjacency(&tris, nv);
        let mut links = vec![[NONE; 2]; tris.len()];
        join(&tris, &nb, &mut links);
        let strips = stripify(&in_order(&tris, &links));
        assert_exact(&tris, &strips);
        let per = strips.len() as f64 / tris.len() as f64;
        assert!(per < 1.6, "{per} indices per triangle from single triangles");
    }

    #[test]
    fn tunnels_never_add_indices_and_close_no_cycle() {
        for (n, hole) in [(8, 0), (11, 9), (16, 4)] {
            let (tris, nv) = mesh48(n, hole);
            let nb = adjacency(&tris, nv);
            let mut links = serpentine(&tris, &nb);
            let before = stripify(&in_order(&tris, &links)).len();
            join(&tris, &nb, &mut links);
            let s = Strips::new(&tris, &nb, &mut links);
            assert!((0..tris.len() as u32).all(|t| !s.cycles(t)));
            let after = stripify(&in_order(&tris, &links));
            assert_exact(&tris, &after);
            assert!(after.len() < before, "{} -> {} indices", before, after.len());
        }
    }

    #[test]
    fn fan_walks_reach_the_bound_of_a_uniform_mesh() {
        // Half the vertices have 8 triangles, half 4: a strip writes them at
        // least 3 and 2 times, 1.25 indices per triangle; plus, for one strip
        // per row of cells, 3 indices each to start it.
        let (tris, nv) = mesh48(32, 0);
        let strips = stripify_tunnelled(&tris, nv);
        assert_exact(&tris, &strips);
        let per = strips.len() as f64 / tris.len() as f64;
        let greedy = stripify_greedy(&tris, nv).len() as f64 / tris.len() as f64;
        let bound = 1.25 + 3.0 * 32.0 / tris.len() as f64;
        assert!(
            per <= bound && per < greedy,
            "{per} indices per triangle, greedy {greedy}"
        );
    }
}
