//! Which side of an outline holds the surface: the halves an outline's
//! refinement must reach (issue 28; DMesh Sec. 5.3 drops a segmented
//! triangle whole, `outline.rs` refines it instead).
//!
//! A full-resolution triangle that a discontinuity crosses has corners on
//! the near surface and on the far one. Its *near* corners are those at
//! most halfway from its nearest depth to its farthest (every valid corner,
//! when one is invalid: a hole has no far side). An unsegmented
//! full-resolution triangle *holds the surface* when one of its corners is
//! near: dropping it would erode the near surface's outline. A hierarchy
//! triangle holds the surface when one of the full-resolution triangles in
//! it does, propagated up the levels as the segmentation flags are (an OR
//! over the two children, `flags.rs`).
//!
//! A triangle that holds a segmented one but not the surface lies on the
//! far side of its outline: dropping it whole loses only the far surface
//! beside the near one, which the near surface hides from every viewpoint
//! close to the reference's, and which the other references show. So an
//! outline's refinement need not reach into it, and the triangles it spares
//! go to the surfaces' interiors.

use super::flags::Flags;
use super::grid::{cell_half, half_of, Grid, Pt};
use super::split_order::for_each_split;

/// Per grid vertex, bit `h`: half `h` of the diamond it splits holds the
/// surface (see the module doc).
pub(crate) fn surface_halves(grid: Grid, z: &[f32], flags: &[Flags]) -> Vec<u8> {
    let (gw, gh) = (grid.gw(), grid.gh());
    let at = |p: Pt| grid.index(p);
    let corners = |cell: Pt, half: usize| grid.cell_triangle(cell, half);
    // The near corners of every segmented full-resolution triangle.
    let mut near = vec![false; grid.len()];
    for y in 0..gh.saturating_sub(1) {
        for x in 0..gw.saturating_sub(1) {
            for half in 0..2 {
                if !flags[at((x, y))].cell(half) {
                    continue;
                }
                let pts = corners((x, y), half);
                let zs = pts.map(|p| z[at(p)]);
                let (lo, hi) = zs.iter().fold((f32::MAX, 0f32), |(lo, hi), &z| (lo.min(z), hi.max(z)));
                let mid = if lo > 0.0 { 0.5 * (lo + hi) } else { f32::MAX };
                for (p, zp) in pts.into_iter().zip(zs) {
                    if zp > 0.0 && zp <= mid {
                        near[at(p)] = true;
                    }
                }
            }
        }
    }
    // The finest triangles that hold the surface, then every level's halves.
    let holds_cell =
        |cell: Pt, half: usize| !flags[at(cell)].cell(half) && corners(cell, half).iter().any(|&p| near[at(p)]);
    let mut holds = vec![0u8; grid.len()];
    for_each_split(grid, 0..grid.k, |s| {
        let unit = |e0: Pt, e1: Pt| e0.0.abs_diff(e1.0) == 1 && e0.1.abs_diff(e1.1) == 1;
        let mut bits = 0u8;
        for (half, apex) in s.apex.into_iter().enumerate() {
            let Some(c) = apex else {
                continue;
            };
            let any = [(s.a, c), (c, s.b)].into_iter().any(|(e0, e1)| {
                if unit(e0, e1) {
                    let cell = (e0.0.min(e1.0), e0.1.min(e1.1));
                    holds_cell(cell, cell_half(cell, s.v))
                } else {
                    let m = ((e0.0 + e1.0) / 2, (e0.1 + e1.1) / 2);
                    holds[at(m)] >> half_of(m, s.v) & 1 == 1
                }
            });
            bits |= u8::from(any) << half;
        }
        holds[at(s.v)] = bits;
    });
    holds
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::camera::Camera;
    use crate::image::DepthImage;
    use crate::mesh::{Hierarchy, Segmentation};

    fn build(w: u32, h: u32, z: Vec<f32>) -> Hierarchy {
        let f = f64::from(w.max(h));
        let cam = Camera::perspective(w, h, f, f, f64::from(w - 1) / 2.0, f64::from(h - 1) / 2.0).unwrap();
        let depth = DepthImage::from_z(w, h, z).unwrap();
        Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap()
    }

    /// Twice the signed area of `a, b, c`, in grid units.
    fn cross(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> f64 {
        (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
    }

    /// The definition read directly: a half holds the surface when a
    /// full-resolution triangle whose centroid lies inside it is
    /// unsegmented and has a near corner.
    fn oracle(hier: &Hierarchy) -> Vec<u8> {
        let grid = hier.grid;
        let (gw, gh) = (grid.gw(), grid.gh());
        let corners = |cell: Pt, half: usize| grid.cell_triangle(cell, half);
        let mut near = vec![false; grid.len()];
        let mut cells = Vec::new();
        for y in 0..gh - 1 {
            for x in 0..gw - 1 {
                for half in 0..2 {
                    let pts = corners((x, y), half);
                    let zs = pts.map(|p| hier.z[grid.index(p)]);
                    let segmented = hier.flags[grid.index((x, y))].cell(half);
                    if segmented {
                        let lo = zs.iter().copied().fold(f32::MAX, f32::min);
                        let hi = zs.iter().copied().fold(0f32, f32::max);
                        for (p, zp) in pts.into_iter().zip(zs) {
                            let is_near = zp > 0.0 && (lo <= 0.0 || zp <= 0.5 * (lo + hi));
                            near[grid.index(p)] |= is_near;
                        }
                    }
                    cells.push((pts, segmented));
                }
            }
        }
        let mut out = vec![0u8; grid.len()];
        for y in 0..gh {
            for x in 0..gw {
                let Some(d) = grid.diamond((x, y)) else {
                    continue;
                };
                for (half, &(cx, cy)) in d.apex.iter().enumerate() {
                    if !grid.contains(cx, cy) {
                        continue;
                    }
                    let f = |p: (i64, i64)| (p.0 as f64, p.1 as f64);
                    let t = [f(d.a), f(d.b), f((cx, cy))];
                    let inside = |p: (f64, f64)| {
                        let s = [cross(t[0], t[1], p), cross(t[1], t[2], p), cross(t[2], t[0], p)];
                        s.iter().all(|&v| v > 0.0) || s.iter().all(|&v| v < 0.0)
                    };
                    let holds = cells.iter().any(|(pts, segmented)| {
                        let c = pts.iter().fold((0.0, 0.0), |(u, v), p| {
                            (u + f64::from(p.0) / 3.0, v + f64::from(p.1) / 3.0)
                        });
                        !segmented && inside(c) && pts.iter().any(|&p| near[grid.index(p)])
                    });
                    out[grid.index((x, y))] |= u8::from(holds) << half;
                }
            }
        }
        out
    }

    #[test]
    fn a_box_before_a_wall_holds_its_surface_on_the_box_side() {
        let (w, h) = (33u32, 33u32);
        let z: Vec<f32> = (0..w * h)
            .map(|i| {
                if (8..20).contains(&(i % w)) && (10..24).contains(&(i / w)) {
                    1.0
                } else {
                    3.0
                }
            })
            .collect();
        let hier = build(w, h, z);
        let got = surface_halves(hier.grid, &hier.z, &hier.flags);
        assert_eq!(got, oracle(&hier));
        // Some segmented halves hold the surface (the box's side), and some
        // do not (the wall's side of the outline).
        let partial = |i: usize, k: usize| hier.flags[i].half(k).partial();
        let (mut near_side, mut far_side) = (0, 0);
        for (i, bits) in got.iter().enumerate() {
            for k in 0..2 {
                if partial(i, k) {
                    if bits >> k & 1 == 1 {
                        near_side += 1;
                    } else {
                        far_side += 1;
                    }
                }
            }
        }
        assert!(near_side > 0 && far_side > 0, "{near_side} {far_side}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// The propagation up the levels gives what the definition says of
        /// every half, on rough depths with holes and steps.
        #[test]
        fn the_propagation_matches_the_definition(
            (w, h) in (2u32..20, 2u32..20),
            seed in any::<u64>(),
        ) {
            let mut s = seed;
            let z: Vec<f32> = (0..w * h)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    match s >> 61 {
                        0 => 0.0,
                        1 | 2 => 4.0 + (s >> 40 & 0xff) as f32 / 256.0,
                        _ => 1.0 + (s >> 40 & 0xff) as f32 / 1024.0,
                    }
                })
                .collect();
            let hier = build(w, h, z);
            prop_assert_eq!(surface_halves(hier.grid, &hier.z, &hier.flags), oracle(&hier));
        }
    }
}
