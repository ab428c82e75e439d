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
//!
//! - `traversal`: the restart marker, strips from a triangle sequence, and
//!   their decoding;
//! - `adjacency`: triangle neighbours, and links back into a sequence;
//! - `greedy`: greedy strips and fan walks over the adjacency;
//! - `tunnel`: joining and improving them by tunnels.

mod adjacency;
mod greedy;
mod traversal;
mod tunnel;

pub(crate) use greedy::stripify_greedy;
pub use traversal::{decode_strips, RESTART};
pub(crate) use traversal::{stripify, BREAK};
pub(crate) use tunnel::stripify_tunnelled;

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

impl StripOrder {
    /// Its names, as `dmesh mesh --strips` takes them.
    pub const NAMES: [(&'static str, Self); 3] = [
        ("traversal", Self::Traversal),
        ("greedy", Self::Greedy),
        ("tunnelled", Self::Tunnelled),
    ];
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
