//! The reference kernel of the levels pass and its tests: `split_vertex`
//! states the computation once for any split vertex, in the order
//! `for_each_coarse` gives; the proptests check the pass's loops (and
//! `finest.rs`'s) against it.

use super::super::deviation::{half_rows, max_deviation};
use super::super::deviation_f32::{MARGIN, RELATIVE};
use super::super::grid::cell_half;
use super::super::level_deviations::{coarse_deviations, small_deviations};
use super::super::level_one_shared::lend;
use super::super::split_order::{for_each_split, split_count};
use super::*;
use proptest::prelude::*;

thread_local! {
    /// Deviation scans the pass skipped on this thread
    /// (`deviation_bound.rs`).
    pub(super) static SKIPPED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    /// Those it scanned though it had the bound.
    pub(super) static SCANNED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Calls `f` on every split vertex above level 0 in the order the pass
/// needs them: level by level from fine to coarse, and within a level the
/// edge midpoints (which depend on the centres of the level below) before
/// the centres (which depend on them). The general kernel's order in the
/// tests.
fn for_each_coarse(grid: Grid, f: impl FnMut(Split)) {
    for_each_split(grid, 1..grid.k, f);
}

impl Levels<'_> {
    /// Computes flags, own and saturated error and radius of the split vertex
    /// `s`, given its halves' squared deviations (`None`: scanned here).
    /// Children are finer and already done. This is the general kernel:
    /// [`run_finest`]'s loops give the same results for level 0 (a
    /// test checks), where a half's children are full-resolution triangles.
    fn split_vertex(&mut self, flags: &mut [Flags], zmax: f32, s: Split, dev2: Option<[f32; 2]>) {
        let Split { v, a, b, apex, bisects } = s;
        let gw = self.grid.gw() as usize;
        let at = |p: Pt| p.1 as usize * gw + p.0 as usize;
        let h = s.h();
        let vi = at(v);
        let (za, zb, zv) = (self.z[at(a)], self.z[at(b)], self.z[vi]);
        let pv = self.bp.point(v.0, v.1, zv);
        let mut bits = flags[vi].cell_only();
        let mut own = 0f64;
        // Squared deviations arrive rounded up; the maximum of rounded-up
        // values is the rounded-up maximum, so this is the same as adding
        // them to `own`.
        let mut own_dev2 = 0f32;
        let mut err = 0f32;
        let mut radius = 0f64;
        let mut eq12_done = false;
        for half in 0..2 {
            let Some(apex) = apex[half] else {
                bits.set_half(half, Half::ABSENT);
                continue;
            };
            // The half's children: hypotenuses a-apex and apex-b, both with
            // apex v; a unit diagonal is a full-resolution triangle of a
            // cell (only on the finest level: h is 1).
            let mut kids = [Half::ABSENT; 2];
            for (k, kid) in kids.iter_mut().enumerate() {
                let (e0, e1) = if k == 0 { (a, apex) } else { (apex, b) };
                *kid = if h == 1 && e0.0.abs_diff(e1.0) == 1 && e0.1.abs_diff(e1.1) == 1 {
                    let cell = (e0.0.min(e1.0), e0.1.min(e1.1));
                    Half::leaf(flags[at(cell)].cell(cell_half(cell, v)))
                } else {
                    let c = ((e0.0 + e1.0) / 2, (e0.1 + e1.1) / 2);
                    let ci = at(c);
                    // Saturation and nesting over the DAG children.
                    err = err.max(self.err2[ci]);
                    let d = pv - self.bp.point(c.0, c.1, self.z[ci]);
                    radius = radius.max(norm_bound(d) + f64::from(self.radius[ci]));
                    flags[ci].half(half_of(c, v))
                };
            }
            let [c0, c1] = kids;
            let flagged = c0.join(c1);
            bits.set_half(half, flagged);
            if flagged.unflagged() {
                own_dev2 = own_dev2.max(match dev2 {
                    Some(d) => d[half],
                    None => half_deviation2(self.z, gw, s, h, apex),
                });
                if !eq12_done {
                    eq12_done = true;
                    let (pa, pb) = (self.bp.point(a.0, a.1, za), self.bp.point(b.0, b.1, zb));
                    own = own.max(eq12(bisects, pv, pa, pb));
                }
            } else if flagged.partial() {
                let len = bisects.hypotenuse(h);
                own = own.max(footprint2(self.camera, len, [za, zb, zv, self.z[at(apex)]], zmax));
            }
        }
        flags[vi] = bits;
        self.err2[vi] = err.max(round_up(own)).max(own_dev2);
        self.radius[vi] = round_up(radius);
    }
}

/// What the pass has computed so far.
#[derive(Clone)]
struct State {
    flags: Vec<Flags>,
    err2: Vec<f32>,
    radius: Vec<f32>,
}

/// Level 0 computed by the loops and by the general kernel, in two
/// stages (edge midpoints, then centres), each from the same state: the
/// centres of both start from the loops' edges, so a difference is the
/// stage's own. Returns the two results of each stage.
fn stages(n: u32, z: &[f32], cells: &[u8]) -> [[State; 2]; 2] {
    let fx = Fixture::new(n, n, z);
    let (grid, zmax) = (fx.grid, fx.zmax);
    let general = |diagonal: bool| {
        move |l: &mut Levels<'_>, flags: &mut [Flags]| {
            for_each_split(grid, 0..1, |s| {
                if (s.bisects == Bisects::Diagonal) == diagonal {
                    l.split_vertex(flags, zmax, s, None);
                }
            });
        }
    };
    let start = fx.start(cells);
    let edges = [
        fx.run(&start, &|l, flags| {
            let mut geo = vec![0f32; grid.gw() as usize];
            l.finest_edges::<true>(flags, zmax, &mut geo);
            l.finest_edges::<false>(flags, zmax, &mut geo);
        }),
        fx.run(&start, &general(false)),
    ];
    let centres = [
        fx.run(&edges[0], &|l, flags| {
            let (mut geo, mut rad) = (vec![0f32; grid.gw() as usize], vec![0f32; grid.gw() as usize]);
            l.finest_centres(flags, zmax, &mut geo, &mut rad)
        }),
        fx.run(&edges[0], &general(true)),
    ];
    [edges, centres]
}

/// Every coarse level's deviations as the helper gives them, level 1
/// first.
fn given_levels(grid: Grid, z: &[f32]) -> Vec<Vec<[f32; 2]>> {
    let small = small_deviations(grid, z, [Vec::new(), Vec::new(), Vec::new()]);
    (1..grid.k)
        .map(|g| match g {
            1..=3 => small[g as usize - 1].clone(),
            _ => coarse_deviations(grid, z, g, Vec::new()),
        })
        .collect()
}

/// The levels above the finest, from the same finest level, by the row
/// loops of [`Levels::run_coarse`] (scanning; given the helper's
/// deviations; given them below level `handover` and scanning from it, as
/// a two-thread build does when the pass overtakes the helper) and by the
/// general kernel.
fn coarse_ways((w, h): (u32, u32), z: &[f32], cells: &[u8], handover: u32) -> [State; 4] {
    let fx = Fixture::new(w, h, z);
    let (grid, zmax) = (fx.grid, fx.zmax);
    let finest = fx.run(&fx.start(cells), &|l, flags| run_finest(l, flags, zmax));
    let levels = given_levels(grid, z);
    [
        fx.run(&finest, &|l, flags| run_coarse(l, flags, zmax, &mut |_| None, None)),
        fx.run(&finest, &|l, flags| {
            run_coarse(l, flags, zmax, &mut |g| Some(levels[g as usize - 1].clone()), None)
        }),
        fx.run(&finest, &|l, flags| {
            run_coarse(
                l,
                flags,
                zmax,
                &mut |g| (g < handover).then(|| levels[g as usize - 1].clone()),
                None,
            )
        }),
        fx.run(&finest, &|l, flags| {
            for_each_coarse(grid, |s| l.split_vertex(flags, zmax, s, None))
        }),
    ]
}

/// Leaf flags of a `w x h` grid as segmentation sets them: a cell
/// touching an invalid sample has both its triangles flagged, the
/// others take `random`.
fn leaf_cells((w, h): (usize, usize), depths: &[f32], random: &[u8]) -> Vec<u8> {
    let z = |x: usize, y: usize| depths[y.min(h - 1) * w + x.min(w - 1)];
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let touches = [z(x, y), z(x + 1, y), z(x, y + 1), z(x + 1, y + 1)].contains(&0.0);
            if touches {
                3
            } else {
                random[i]
            }
        })
        .collect()
}

/// A `w x h` grid of depths `z` seen by a perspective camera, and passes
/// run on copies of a state.
struct Fixture<'z> {
    grid: Grid,
    camera: Camera,
    bp: BackProject,
    z: &'z [f32],
    zmax: f32,
}

impl<'z> Fixture<'z> {
    fn new(w: u32, h: u32, z: &'z [f32]) -> Self {
        let grid = Grid::for_image(w, h);
        let f = 0.8 * f64::from(w);
        let camera = Camera::perspective(w, h, f, f, 0.5 * f64::from(w), 0.5 * f64::from(h)).unwrap();
        let bp = BackProject::new(&camera, grid.gw(), grid.gh());
        let zmax = z.iter().copied().fold(0f32, f32::max);
        Self {
            grid,
            camera,
            bp,
            z,
            zmax,
        }
    }

    /// The leaf flags `cells`, nothing computed yet.
    fn start(&self, cells: &[u8]) -> State {
        State {
            flags: cells.iter().copied().map(Flags::of_cell).collect(),
            err2: vec![0f32; self.grid.len()],
            radius: vec![0f32; self.grid.len()],
        }
    }

    /// `pass` run on a copy of `from`.
    fn run(&self, from: &State, pass: &dyn Fn(&mut Levels<'_>, &mut [Flags])) -> State {
        let mut st = from.clone();
        let mut levels = Levels {
            grid: self.grid,
            camera: &self.camera,
            bp: &self.bp,
            z: self.z,
            err2: &mut st.err2,
            radius: &mut st.radius,
            row0: 0,
        };
        pass(&mut levels, &mut st.flags);
        st
    }
}

/// The levels above the finest by the pass (on one thread) and by the
/// general kernel given every half's deviation from the exact f64 scan
/// (`deviation.rs`), the oracle the f32 scans of the coarser levels are
/// held to.
fn coarse_against_exact(n: u32, z: &[f32], cells: &[u8]) -> [State; 2] {
    let fx = Fixture::new(n, n, z);
    let (grid, zmax) = (fx.grid, fx.zmax);
    let gw = grid.gw() as usize;
    let finest = fx.run(&fx.start(cells), &|l, flags| run_finest(l, flags, zmax));
    let exact = |s: Split| {
        s.apex.map(|apex| {
            apex.map_or(0.0, |c| {
                let rows = half_rows(s.v, s.h(), c, s.bisects == Bisects::Row, s.bisects == Bisects::Diagonal);
                let d = max_deviation(z, gw, [s.a, s.b, c], rows);
                round_up(d * d)
            })
        })
    };
    [
        fx.run(&finest, &|l, flags| run_coarse(l, flags, zmax, &mut |_| None, None)),
        fx.run(&finest, &|l, flags| {
            for_each_coarse(grid, |s| l.split_vertex(flags, zmax, s, Some(exact(s))))
        }),
    ]
}

/// Depths on a 65 x 65 grid: a paraboloid of curvature `curve` around
/// `centre` plus `amplitude` times `noise`.
fn noisy_paraboloid(curve: f32, noise: &[f32], amplitude: f32, (cx, cy): (f32, f32)) -> Vec<f32> {
    (0..65 * 65)
        .map(|i| {
            let (x, y) = ((i % 65) as f32 - cx, (i / 65) as f32 - cy);
            2.0 + curve * (x * x + y * y) / 4096.0 + amplitude * noise[i]
        })
        .collect()
}

/// Where noise dominates the errors, the pass skips a fifth or more of the
/// scans of the levels it scans as it comes (3 and up, and 4 and up where
/// it takes over from the helper; 70 of 244 here), and the results stay
/// the general kernel's.
#[test]
fn the_pass_skips_the_scans_the_bound_shows_needless() {
    // A fixed pseudo-random noise (a linear congruential sequence).
    let mut state = 12345u32;
    let noise: Vec<f32> = (0..65 * 65)
        .map(|_| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        })
        .collect();
    let depths = noisy_paraboloid(0.5, &noise, 0.2, (20.0, 40.0));
    let count = || [SKIPPED.with(std::cell::Cell::get), SCANNED.with(std::cell::Cell::get)];
    let before = count();
    coarse_rows_match_the_general_kernel((65, 65), &depths, &[0; 65 * 65], 4).unwrap();
    let [skipped, scanned] = [0, 1].map(|k| count()[k] - before[k]);
    assert!(
        5 * skipped >= skipped + scanned,
        "{skipped} scans skipped, {scanned} scanned"
    );
}

/// The pass's row loops, scanning, given the helper's deviations, or given
/// them below level `handover` only, give the general kernel's flags,
/// radii and errors on a `w x h` grid.
fn coarse_rows_match_the_general_kernel(
    (w, h): (usize, usize),
    depths: &[f32],
    random: &[u8],
    handover: u32,
) -> Result<(), TestCaseError> {
    let cells = leaf_cells((w, h), depths, random);
    let [rows, given, handed_over, general] = coarse_ways((w as u32, h as u32), depths, &cells, handover);
    for pass in [&rows, &given, &handed_over] {
        prop_assert_eq!(&pass.flags, &general.flags);
        prop_assert_eq!(&pass.radius, &general.radius);
        prop_assert_eq!(&pass.err2, &general.err2);
    }
    Ok(())
}

/// Level 1 in two bands (`level_one_shared.rs`), both run on this
/// thread, meeting at every row they can: the same bytes as the pass
/// over the whole level, given the helper's deviations and scanning.
fn shared_level_one_matches_one_pass((w, h): (u32, u32), z: &[f32], cells: &[u8]) -> Result<(), TestCaseError> {
    let fx = Fixture::new(w, h, z);
    let (grid, zmax) = (fx.grid, fx.zmax);
    let finest = fx.run(&fx.start(cells), &|l, flags| run_finest(l, flags, zmax));
    let levels = given_levels(grid, z);
    let ny = level_size(grid, 1).1;
    prop_assert!(ny >= SHARED_ROWS, "{} rows of level 1 centres: not shared", ny);
    for given in [false, true] {
        let source = |g: u32| given.then(|| levels[g as usize - 1].clone());
        let one = fx.run(&finest, &|l, flags| {
            run_coarse(l, flags, zmax, &mut |g| source(g), None)
        });
        for t in 1..ny {
            let (mut share, _lender) = lend();
            share.in_turn = Some(t);
            let share = std::cell::Cell::new(Some(share));
            let two = fx.run(&finest, &|l, flags| {
                run_coarse(l, flags, zmax, &mut |g| source(g), share.take())
            });
            prop_assert!(share.take().is_none(), "the share was not used");
            let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            let flags_at = two.flags.iter().zip(&one.flags).position(|(a, b)| a != b);
            prop_assert!(
                flags_at.is_none(),
                "flags of grid vertex {:?} differ, meeting at {}",
                flags_at,
                t
            );
            for (what, a, b) in [
                ("error", bits(&two.err2), bits(&one.err2)),
                ("radius", bits(&two.radius), bits(&one.radius)),
            ] {
                let at = a.iter().zip(&b).position(|(a, b)| a != b);
                prop_assert!(
                    at.is_none(),
                    "{} of grid vertex {:?} differs, meeting at {}",
                    what,
                    at,
                    t
                );
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The row loops of the levels above the finest compute exactly what
    /// the general kernel does, with or without the helper's deviations.
    #[test]
    fn the_coarse_row_loops_match_the_general_kernel(
        depths in proptest::collection::vec(prop_oneof![1 => Just(0.0f32), 9 => 0.5f32..4.0], 33 * 33),
        cells in proptest::collection::vec(prop_oneof![6 => Just(0u8), 1 => 0u8..4], 33 * 33),
        handover in 3u32..6,
    ) {
        prop_assume!(Grid::for_image(33, 33).len() == depths.len());
        coarse_rows_match_the_general_kernel((33, 33), &depths, &cells, handover)?;
    }

    /// The same on a grid of two root quads by one, not square: edge
    /// midpoints with one half (on the grid's border) and with two (on
    /// the edge between the roots), on rows and columns of different
    /// lengths.
    #[test]
    fn the_coarse_row_loops_match_the_general_kernel_across_roots(
        depths in proptest::collection::vec(prop_oneof![1 => Just(0.0f32), 9 => 0.5f32..4.0], 33 * 17),
        cells in proptest::collection::vec(prop_oneof![6 => Just(0u8), 1 => 0u8..4], 33 * 17),
        handover in 3u32..5,
    ) {
        let grid = Grid::for_image(33, 17);
        prop_assert_eq!((grid.len(), grid.m, grid.n), (depths.len(), 2, 1));
        coarse_rows_match_the_general_kernel((33, 17), &depths, &cells, handover)?;
    }

    /// On smooth, fully valid surfaces with noise (a paraboloid's
    /// deviations grow fourfold a level, the noise's do not), where the
    /// pass skips some scans by the children's bound and scans others, it
    /// still gives the general kernel's results, which scan every half.
    #[test]
    fn skipped_scans_change_no_error(
        curve in 0.0f32..2.0,
        noise in proptest::collection::vec(-1.0f32..1.0, 65 * 65),
        amplitude in prop_oneof![Just(0.0f32), 0.0f32..0.05, 0.0f32..1.0],
        centre in (0.0f32..64.0, 0.0f32..64.0),
        handover in 3u32..7,
    ) {
        let depths = noisy_paraboloid(curve, &noise, amplitude, centre);
        coarse_rows_match_the_general_kernel((65, 65), &depths, &[0; 65 * 65], handover)?;
    }

    /// Level 1 shared by two threads in bands of rows gives the bytes of
    /// one pass, wherever the bands meet: on a square grid and on one of
    /// two roots (whose edge midpoints along columns on the border between
    /// the roots have two halves).
    #[test]
    fn level_one_in_two_bands_matches_one_pass(
        depths in proptest::collection::vec(prop_oneof![1 => Just(0.0f32), 9 => 0.5f32..4.0], 33 * 33),
        cells in proptest::collection::vec(prop_oneof![6 => Just(0u8), 1 => 0u8..4], 33 * 33),
        square in any::<bool>(),
    ) {
        let (w, h) = if square { (33, 33) } else { (33, 17) };
        let n = (w * h) as usize;
        let cells = leaf_cells((w as usize, h as usize), &depths[..n], &cells[..n]);
        shared_level_one_matches_one_pass((w, h), &depths[..n], &cells)?;
    }

    /// The pass's errors are never below those from the exact f64
    /// deviations, and above them by at most the f32 scans' margin
    /// (`deviation_f32.rs`); flags and radii are the same.
    #[test]
    fn the_coarse_errors_bound_the_exact_ones_within_the_margin(
        depths in proptest::collection::vec(prop_oneof![1 => Just(0.0f32), 9 => 0.5f32..4.0], 33 * 33),
        cells in proptest::collection::vec(prop_oneof![6 => Just(0u8), 1 => 0u8..4], 33 * 33),
        smooth in any::<bool>(),
    ) {
        prop_assume!(Grid::for_image(33, 33).len() == depths.len());
        // Smooth: a level plane with noise of a few f32 steps, where the
        // rounding the margin covers is most of a deviation.
        let depths: Vec<f32> = if smooth {
            depths.iter().map(|&d| if d == 0.0 { 0.0 } else { 3.0 + 1e-6 * d }).collect()
        } else {
            depths
        };
        let cells = leaf_cells((33, 33), &depths, &cells);
        let [pass, exact] = coarse_against_exact(33, &depths, &cells);
        prop_assert_eq!(&pass.flags, &exact.flags);
        prop_assert_eq!(&pass.radius, &exact.radius);
        let zmax = f64::from(depths.iter().copied().fold(0f32, f32::max));
        for (i, (&f, &e)) in pass.err2.iter().zip(&exact.err2).enumerate() {
            prop_assert!(f >= e, "vertex {}: {} below the exact {}", i, f, e);
            let (f, e) = (f64::from(f).sqrt(), f64::from(e).sqrt());
            let bound = e * (1.0 + 2.0 * RELATIVE) + 2.0 * MARGIN * zmax;
            prop_assert!(f <= bound, "vertex {}: {} above the exact {} by more than the margin", i, f, e);
        }
    }

    /// The tight loops of the finest level compute what the general
    /// kernel does: the same flags and radii, errors never below it and
    /// within one f32 rounding where no half is partly segmented (the
    /// general kernel scans the deviation, the loops take the detail).
    #[test]
    fn the_finest_loops_match_the_general_kernel(
        depths in proptest::collection::vec(prop_oneof![Just(0.0f32), 0.5f32..4.0], 17 * 17),
        cells in proptest::collection::vec(0u8..4, 17 * 17),
    ) {
        prop_assume!(Grid::for_image(17, 17).len() == depths.len());
        let cells = leaf_cells((17, 17), &depths, &cells);
        for [fast, general] in stages(17, &depths, &cells) {
            prop_assert_eq!(&fast.flags, &general.flags);
            prop_assert_eq!(&fast.radius, &general.radius);
            for (i, (f, g)) in fast.err2.iter().zip(&general.err2).enumerate() {
                // Never below the general kernel (the guarantee), and the
                // same up to one rounding unless a half is partly
                // segmented: the loops then take the deeper apex for both.
                let partial = (0..2).any(|h| fast.flags[i].half(h).partial());
                prop_assert!(*f >= g * (1.0 - 1e-6), "vertex {}: fast {} below general {}", i, f, g);
                prop_assert!(partial || (f - g) <= 1e-6 * f, "vertex {}: fast {} general {}", i, f, g);
            }
        }
    }
}

/// The count the helper's arrays are sized by is the number of split
/// vertices the pass visits, on grids padded or not.
#[test]
fn split_count_counts_the_splits() {
    for (w, h) in [(3, 7), (33, 33), (40, 17), (513, 300)] {
        let grid = Grid::for_image(w, h);
        for g in 1..grid.k {
            let mut visited = 0;
            for_each_split(grid, g..g + 1, |_| visited += 1);
            assert_eq!(split_count(grid, g), visited, "{w} x {h}, level {g}");
        }
    }
}
