//! A bound on a half's depth deviation from its two children's, used to
//! skip the scan of a half whose deviation cannot change its vertex's
//! saturated error (DMesh Sec. 4.2; the deviation term is `hierarchy.rs`'s,
//! issue 16's; the bound is the one issue 27 names: "from the children's
//! deviations plus the difference of the interpolants at their corners").
//!
//! A half `T` with corners `a`, `b` (the edge its split vertex `v` bisects)
//! and apex `c` is bisected at `v` into its two children, `(a, c, v)` and
//! `(c, b, v)`: the halves of the midpoints of `a-c` and `c-b` that hold
//! `v`. Over a child `T1`, the interpolant `L` of `T` and `L1` of `T1`
//! agree at `a` and `c` and differ by `z_v - (z_a + z_b) / 2` at `v`; both
//! are affine, so over `T1` they differ by at most that. Every sample `s`
//! of `T` lies in a child, so
//!
//! `|z_s - L(s)| <= |z_s - L1(s)| + |L1(s) - L(s)| <= dev(T1) + |z_v - (z_a + z_b) / 2|`,
//!
//! and `dev(T) <= max(dev(T1), dev(T2)) + |z_v - (z_a + z_b) / 2|`. The
//! children's values need only be upper bounds of their exact deviations:
//! the scanned ones are, and so is this bound where it stood in for one.
//!
//! The build stores a half's scanned deviation above the exact value by at
//! most `2^-22` of it plus `2^-20` of the half's largest corner depth
//! (`deviation_f32.rs`, `small_half_sweep.rs`). [`bound2`] adds twice those
//! margins (the second over the largest depth of the grid, the f64
//! arithmetic's rounding well inside the doubling), so it is never below
//! what a scan would store. Where it is at most the vertex's saturated
//! error without the deviation, the scan cannot change that error: the
//! pass skips it, keeps the bound as the half's value for its parent, and
//! stores the same bits as with the scan.

use super::levels::round_up;

/// An upper bound on the squared deviation a scan would store for a half
/// whose children's kept squared deviations are `children`, whose split
/// vertex has depth `zv` and bisects the edge from depth `za` to `zb`, on
/// a grid of largest depth `zmax`; rounded up, saturated like an error.
#[inline(always)]
pub(super) fn bound2(children: [f32; 2], za: f32, zb: f32, zv: f32, zmax: f32) -> f32 {
    let worst_child = f64::from(children[0].max(children[1])).sqrt();
    let at_v = (f64::from(zv) - 0.5 * (f64::from(za) + f64::from(zb))).abs();
    let margin = |d: f64| d * (1.0 + f64::powi(2.0, -21)) + f64::powi(2.0, -19) * f64::from(zmax);
    let d = margin(worst_child + at_v);
    round_up(d * d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_half_is_bounded_by_its_children_and_the_margin() {
        // Children exact (0) and v on the edge: only the margin remains.
        let b = bound2([0.0, 0.0], 1.0, 3.0, 2.0, 4.0);
        assert!(b > 0.0 && b <= (f64::powi(2.0, -19) * 4.0 * 1.01).powi(2) as f32, "{b}");
    }

    #[test]
    fn the_bound_adds_the_midpoint_offset_to_the_worst_child() {
        // sqrt(9) = 3 from the worse child, |5 - 2| = 3 at v.
        let b = bound2([4.0, 9.0], 1.0, 3.0, 5.0, 1.0);
        assert!((36.0..36.01).contains(&b), "{b}");
    }

    #[test]
    fn squares_past_f32_saturate() {
        assert_eq!(bound2([f32::MAX, 0.0], 1.0, 1.0, 1.0, 1.0), f32::MAX);
        assert_eq!(bound2([0.0, 0.0], 1.0, f32::MAX, 1.0, 1.0), f32::MAX);
    }
}
