//! The bottom-up pass of the build over the levels of the 4-8 hierarchy,
//! finest first: flags, own and saturated errors and nested radii of every
//! split vertex (DMesh Sec. 4.2 and 5.3; what each term is, is documented in
//! `hierarchy.rs`). It reads the depths and writes flags, errors and radii
//! only, so the normals can be computed beside it; the deviations of the
//! levels above the finest, which need the depths alone, can be computed on
//! another thread ([`small_deviations`] for levels 1 to 3,
//! [`coarse_deviations`] for each level above), while this pass builds the
//! finest level and the levels below. On one thread levels 1 to 3 are
//! swept before the pass reaches them, and each coarser unsegmented half is
//! scanned as the pass comes to it, unless the bound from its children's
//! deviations (`deviation_bound.rs`) shows the scan cannot change the
//! vertex's error: the results are the same bits either way.
//!
//! Every level runs per kind of vertex (edge midpoints along rows, along
//! columns, centres) and row: the vertices with both halves in the straight
//! loops of `coarse_rows.rs`, the grid's border one by one, with the rows
//! a kind's children lie on sliced once beside the row it writes. A general kernel
//! per split vertex, `split_vertex`, states the same computation once for
//! any vertex; the tests (`levels_tests.rs`, which holds it) check the loops
//! against it. The finest level's loops are in `finest.rs`.

use super::backproject::BackProject;
use super::coarse_rows::{Child, GridRows, Grids, Kept, Plane, Results, Row, RowTask, Scratch};
use super::deviation::{half_rows, max_deviation};
use super::deviation_bound;
use super::deviation_f32::max_deviation_f32;
use super::error_metric::{norm_bound, point_line_2d_sq, point_line_3d_sq};
use super::flags::{Flags, Half};
use super::grid::{half_of, Grid, Pt};
use super::level_row_scan::level_row_scan;
use super::small_half_sweep::{small_half_deviation2, small_level_deviations};
use super::split_order::{for_each_split, split_count, Bisects, Split};
use crate::camera::Camera;
use glam::DVec3;

/// `v >= 0` as f32, rounded up (an error or radius may grow, never
/// shrink), saturated at `f32::MAX` (which NaN also gives). Without
/// branches: one step up of a non-negative f32 is the next bit pattern,
/// which `f32::next_up` finds through tests of sign and class.
#[inline(always)]
pub(super) fn round_up(v: f64) -> f32 {
    debug_assert!(v >= 0.0 || v.is_nan(), "round_up of {v}");
    let f = v as f32;
    f32::from_bits(f.to_bits() + u32::from(f64::from(f) < v)).min(f32::MAX)
}

/// Eq. 1 (a diagonal) or Eq. 2 (an edge along a row or a column): the
/// squared distance of `v` to the edge `a-b` it bisects.
fn eq12(bisects: Bisects, pv: DVec3, pa: DVec3, pb: DVec3) -> f64 {
    match bisects {
        Bisects::Diagonal => point_line_3d_sq(pv, pa, pb),
        Bisects::Row => point_line_2d_sq((pv.x, pv.z), (pa.x, pa.z), (pb.x, pb.z)),
        Bisects::Column => point_line_2d_sq((pv.y, pv.z), (pa.y, pa.z), (pb.y, pb.z)),
    }
}

/// The squared footprint of a partly segmented half: its hypotenuse, `len`
/// pixels, at the pixel size of the deepest valid of `corners` (or of the
/// image's deepest sample when none is valid).
pub(super) fn footprint2(camera: &Camera, len: f64, corners: [f32; 4], zmax: f32) -> f64 {
    let zref = corners.into_iter().fold(0f32, f32::max);
    let zref = if zref > 0.0 { zref } else { zmax };
    let extent = len * camera.pixel_size(f64::from(zref));
    extent * extent
}

/// Rows `y - d` and `y + d` of a row-major `v` of rows `gw` long, to read
/// (empty where off the grid), beside row `y` to write.
#[inline(always)]
fn rows3<T>(v: &mut [T], gw: usize, y: u32, d: u32) -> (&[T], &mut [T], &[T]) {
    let (y, d) = (y as usize, d as usize);
    let (head, tail) = v.split_at_mut(y * gw);
    let (row, rest) = tail.split_at_mut(gw.min(tail.len()));
    let up = if y >= d {
        &head[(y - d) * gw..(y - d + 1) * gw]
    } else {
        &[]
    };
    let down = rest.get((d - 1) * gw..d * gw).unwrap_or(&[]);
    (up, row, down)
}

/// What the pass reads and writes.
pub(crate) struct Levels<'a> {
    pub grid: Grid,
    pub camera: &'a Camera,
    pub bp: &'a BackProject,
    /// Depth per grid vertex, 0 for invalid and padding.
    pub z: &'a [f32],
    /// Saturated squared errors, written.
    pub err2: &'a mut [f32],
    /// Nested radii, written; zero on entry (the finest edge midpoints',
    /// which have no children, are left so).
    pub radius: &'a mut [f32],
}

/// The levels whose halves [`coarse_deviations`] reads grid row by grid
/// row (`level_row_scan.rs`); the others half by half. Medians of twelve
/// builds at 1920 x 1080 on two threads, on a 2 GHz Zen 1, in ms per level
/// (half by half, then by rows): level 3 10.4, 10.5 (12.5 with it in the
/// rows' groups); level 4 8.7-9.0, 7.1-7.4; level 5 8.9-9.0, 5.8-6.3;
/// level 6 5.7-5.8, 6.1-6.2. Level 3's rows are too short to gain, and from
/// level 6 on a half's rows (65 samples and more) are long enough for the
/// prefetchers to follow half by half. At 513 x 513, whose depths stay in
/// cache, the two ways cost the same.
const ROW_SCAN_LEVELS: std::ops::Range<u32> = 4..6;

crate::simd::dispatch! {
    /// The depth deviation of each half of every split vertex of level `g`
    /// (at least 4: levels 1 to 3 come from [`small_deviations`]), squared
    /// and rounded up (0 where a half does not exist), in the order
    /// [`Levels::run_coarse`] takes them. It reads only the depths, so it
    /// can run on another thread, a level ahead of the pass. Halves that
    /// turn out segmented get a value too, which the pass ignores (it is
    /// finite: invalid samples are 0). Levels 4 and 5 grid row by grid
    /// row, the others half by half ([`ROW_SCAN_LEVELS`]), with AVX2 where
    /// the CPU has it. The deviations go into `out` (whatever it holds), so a build on two
    /// threads can hand the helper memory the calling thread has used.
    pub(crate) fn coarse_deviations(grid: Grid, z: &[f32], g: u32, out: Vec<[f32; 2]>) -> Vec<[f32; 2]> = coarse_deviations_body;
}

crate::simd::dispatch! {
    /// The deviations of levels 1 to 3 as [`coarse_deviations`] gives
    /// them, all from one set of phase planes (`small_half_sweep.rs`),
    /// into `out` (whatever they hold; empty where the grid has no such
    /// level). With AVX2 where the CPU has it.
    pub(crate) fn small_deviations(grid: Grid, z: &[f32], out: [Vec<[f32; 2]>; 3]) -> [Vec<[f32; 2]>; 3] = small_deviations_body;
}

#[inline(always)]
fn small_deviations_body(grid: Grid, z: &[f32], out: [Vec<[f32; 2]>; 3]) -> [Vec<[f32; 2]>; 3] {
    let [mut one, mut two, mut three] = out;
    small_level_deviations(grid, z, [&mut one, &mut two, &mut three]);
    [one, two, three]
}

#[inline(always)]
fn coarse_deviations_body(grid: Grid, z: &[f32], g: u32, mut out: Vec<[f32; 2]>) -> Vec<[f32; 2]> {
    out.clear();
    out.reserve(split_count(grid, g));
    if ROW_SCAN_LEVELS.contains(&g) {
        level_row_scan(grid, z, g, &mut out);
        return out;
    }
    let (gw, h) = (grid.gw() as usize, 1 << g);
    for_each_split(
        grid,
        g..g + 1,
        #[inline(always)]
        |s| {
            let mut pair = [0f32; 2];
            for (d, apex) in pair.iter_mut().zip(s.apex) {
                if let Some(apex) = apex {
                    *d = half_deviation2(z, gw, s, h, apex);
                }
            }
            out.push(pair);
        },
    );
    out
}

/// Where the pass over the levels above the finest gets each level's
/// deviations: called once per level, finest first; `None` has the pass
/// scan each unflagged half as it comes.
pub(crate) type DeviationSource<'a> = &'a mut dyn FnMut(u32) -> Option<Vec<[f32; 2]>>;

/// The squared deviation of the half of `s` with apex `apex`, rounded up:
/// in f32 within a stated margin above the exact value, for the two levels
/// just above the finest in straight code (`small_half_sweep.rs`, nine in
/// ten of these halves), for the coarser ones by rows
/// (`deviation_f32.rs`); the finest level's halves (only the tests' general
/// kernel scans them) exact, by rows.
#[inline(always)]
pub(super) fn half_deviation2(z: &[f32], gw: usize, s: Split, h: u32, apex: Pt) -> f32 {
    let rows = || half_rows(s.v, h, apex, s.bisects == Bisects::Row, s.bisects == Bisects::Diagonal);
    let v = s.v.1 as usize * gw + s.v.0 as usize;
    let dev = match h {
        1 => max_deviation(z, gw, [s.a, s.b, apex], rows()),
        2 => return small_half_deviation2::<2>(z, gw, v, s.small_shape(apex)),
        4 => return small_half_deviation2::<4>(z, gw, v, s.small_shape(apex)),
        8 => return small_half_deviation2::<8>(z, gw, v, s.small_shape(apex)),
        _ => max_deviation_f32(z, gw, [s.a, s.b, apex], rows()),
    };
    round_up(dev * dev)
}

crate::simd::dispatch! {
    /// The finest level (three quarters of all vertices), in the row
    /// sweeps of `finest.rs` (with AVX2 where the CPU has it:
    /// [`crate::simd`]).
    pub(crate) fn run_finest(levels: &mut Levels<'_>, flags: &mut [Flags], zmax: f32) -> () = run_finest_body;
}

#[inline(always)]
fn run_finest_body(levels: &mut Levels<'_>, flags: &mut [Flags], zmax: f32) {
    let gw = levels.grid.gw() as usize;
    debug_assert!(levels.radius.iter().all(|&r| r == 0.0), "radii not zero on entry");
    let (mut geo, mut rad) = (vec![0f32; gw], vec![0f32; gw]);
    levels.finest_edges::<true>(flags, zmax, &mut geo);
    levels.finest_edges::<false>(flags, zmax, &mut geo);
    levels.finest_centres(flags, zmax, &mut geo, &mut rad);
}

crate::simd::dispatch! {
    /// The levels above the finest: [`Levels::run_coarse`] (with AVX2 where
    /// the CPU has it).
    pub(crate) fn run_coarse(levels: &mut Levels<'_>, flags: &mut [Flags], zmax: f32, deviations: DeviationSource<'_>) -> () = run_coarse_body;
}

#[inline(always)]
fn run_coarse_body(levels: &mut Levels<'_>, flags: &mut [Flags], zmax: f32, deviations: DeviationSource<'_>) {
    levels.run_coarse(flags, zmax, deviations);
}

impl Levels<'_> {
    /// The levels above the finest, each given its [`coarse_deviations`]
    /// by `deviations` or computing each unsegmented half's as it comes:
    /// per level the edge midpoints along rows, along columns, then the
    /// centres, each in a straight loop over rows ([`Self::coarse_row`]),
    /// in the order of [`for_each_split`].
    #[inline(always)]
    pub(crate) fn run_coarse(&mut self, flags: &mut [Flags], zmax: f32, deviations: DeviationSource<'_>) {
        let (gw, gh) = (self.grid.gw(), self.grid.gh());
        let mut scratch = Scratch::default();
        // Each kind's results, kept for the kind that reads them as
        // children (`coarse_rows.rs`): the level below's centres, this
        // level's edge midpoints along rows and along columns, its centres.
        let [mut below, mut row_edges, mut column_edges, mut centres] = [(); 4].map(|()| Plane::default());
        for g in 1..self.grid.k {
            let given = deviations(g);
            // (After the deviations, which may wait for the helper.)
            let _span = tracing::trace_span!("level", g).entered();
            let mut next = given.as_deref();
            let h = 1u32 << g;
            let step = 2 * h as usize;
            // Vertices per row (centres, and edge midpoints along rows; one
            // more along columns) and rows per kind (one more along rows).
            let (nx, ny) = ((gw as usize - 1) / step, (gh as usize - 1) / step);
            // The halves' deviations are kept from level 2 on, for the
            // bound of the level above where it is scanned as the pass
            // comes (from level 4 in a build, which is given levels 1 to
            // 3; from level 1 in the tests' scanning paths).
            row_edges.reset(ny + 1, nx, g >= 2);
            column_edges.reset(ny, nx + 1, g >= 2);
            centres.reset(ny, nx, g >= 2);
            // Each kind's vertices with both halves go through the sweep:
            // the edge midpoints along rows off the first and last rows,
            // those along columns off the first and last columns, every
            // centre. An edge midpoint's children are the centres of the
            // level below around it, at twice its lane (`Row::offset`'s
            // order: left above, right above, left below, right below):
            // lane `j` of row `r` of the level below's centres, which on
            // level 1 are the finest centres, in the grid at `(2j + 1,
            // 2r + 1)`.
            let two = |below, row: usize, first: usize| match g {
                1 => Child {
                    kept: Kept::Grid,
                    row: 2 * row + 1,
                    first: 2 * first + 1,
                    stride: 4,
                },
                _ => Child {
                    kept: Kept::Plane(below),
                    row,
                    first,
                    stride: 2,
                },
            };
            let row = Row {
                bisects: Bisects::Row,
                h,
                x0: h,
                y: h,
            };
            scratch.columns.gather(self.bp, row, 0..nx);
            for (r, y) in (0..gh).step_by(step).enumerate() {
                let lanes = if r == 0 || r == ny { 0..0 } else { 0..nx };
                // (Unread on the first and last rows, which have no lanes.)
                let above = (2 * r).saturating_sub(1);
                let children = [
                    two(&below, above, 0),
                    two(&below, above, 1),
                    two(&below, 2 * r, 0),
                    two(&below, 2 * r, 1),
                ];
                let task = RowTask {
                    row: Row { y, ..row },
                    lanes,
                    children,
                    out: &mut row_edges,
                    r,
                };
                self.coarse_row(flags, zmax, task, &mut next, &mut scratch);
            }
            let row = Row {
                bisects: Bisects::Column,
                h,
                x0: 0,
                y: h,
            };
            scratch.columns.gather(self.bp, row, 1..nx);
            for (r, y) in (h..gh).step_by(step).enumerate() {
                let children = [
                    two(&below, 2 * r, 1),
                    two(&below, 2 * r, 2),
                    two(&below, 2 * r + 1, 1),
                    two(&below, 2 * r + 1, 2),
                ];
                let task = RowTask {
                    row: Row { y, ..row },
                    lanes: 1..nx,
                    children,
                    out: &mut column_edges,
                    r,
                };
                self.coarse_row(flags, zmax, task, &mut next, &mut scratch);
            }
            // A centre's children are its level's edge midpoints: along
            // columns on its row at its lane and the next, along rows
            // above and below at its lane.
            let row = Row {
                bisects: Bisects::Diagonal,
                h,
                x0: h,
                y: h,
            };
            scratch.columns.gather(self.bp, row, 0..nx);
            let one = |plane, row, first| Child {
                kept: Kept::Plane(plane),
                row,
                first,
                stride: 1,
            };
            for (r, y) in (h..gh).step_by(step).enumerate() {
                let children = [
                    one(&column_edges, r, 0),
                    one(&column_edges, r, 1),
                    one(&row_edges, r, 0),
                    one(&row_edges, r + 1, 0),
                ];
                let task = RowTask {
                    row: Row { y, ..row },
                    lanes: 0..nx,
                    children,
                    out: &mut centres,
                    r,
                };
                self.coarse_row(flags, zmax, task, &mut next, &mut scratch);
            }
            std::mem::swap(&mut below, &mut centres);
            debug_assert!(next.is_none_or(<[_]>::is_empty), "deviations left over");
        }
    }

    /// The split vertices of one kind on one row (`row`):
    /// `split_vertex`'s results (`levels_tests.rs`). Those in `lanes`,
    /// which have both halves, in the sweep of `coarse_rows.rs`, then per
    /// vertex only for what is rare or costly there (a partly segmented
    /// half's footprint, a deviation not given); the others (on the grid's
    /// border) one by one, with the rows their children lie on sliced once
    /// beside the row written, and the children and their halves found by
    /// the kind's fixed geometry.
    #[inline(always)]
    fn coarse_row(
        &mut self,
        flags: &mut [Flags],
        zmax: f32,
        task: RowTask<'_>,
        next: &mut Option<&[[f32; 2]]>,
        scratch: &mut Scratch,
    ) {
        let RowTask {
            row,
            lanes,
            children,
            out,
            r,
        } = task;
        let gw = self.grid.gw();
        let (bp, camera, z) = (self.bp, self.camera, self.z);
        let Row { bisects, h, y, .. } = row;
        // The row's vertices lie at `x0 + step * i`.
        let (x0, step) = (if bisects == Bisects::Column { 0 } else { h }, 2 * h);
        let count = (gw - x0).div_ceil(step) as usize;
        // This row's deviations, if given.
        let given = next.as_mut().map(|rest| {
            let (now, later) = rest.split_at(count.min(rest.len()));
            *rest = later;
            now
        });
        if !lanes.is_empty() {
            let grids = Grids {
                gw: gw as usize,
                z,
                radius: self.radius,
                err2: self.err2,
                flags,
            };
            scratch.samples.gather(&grids, row, lanes.clone(), children);
            let dev2 = given.and_then(|d| d.get(lanes.clone()));
            scratch.sweep(bp, row, lanes.start, dev2);
            // Every swept vertex's results as the sweep gave them, in
            // straight loops; the rare ones the loop below finishes are
            // written again there.
            let row_at = y as usize * gw as usize;
            let grid_rows = GridRows {
                flags: &mut flags[row_at..row_at + gw as usize],
                err2: &mut self.err2[row_at..row_at + gw as usize],
                radius: &mut self.radius[row_at..row_at + gw as usize],
            };
            scratch.write(grid_rows, (x0 + step * lanes.start as u32) as usize, step as usize);
            out.set_row(r, lanes.start, scratch, dev2);
        }
        let q = h / 2;
        // Children lie `d` rows above and below (and, for centres, on the
        // row itself).
        let d = if bisects == Bisects::Diagonal { h } else { q };
        let (err_up, err_row, err_down) = rows3(self.err2, gw as usize, y, d);
        let (flag_up, flag_row, flag_down) = rows3(flags, gw as usize, y, d);
        let (rad_up, rad_row, rad_down) = rows3(self.radius, gw as usize, y, d);
        let factor = |yy: u32| bp.row(yy as usize);
        let point = BackProject::point_from;
        let at = |p: Pt| p.1 as usize * gw as usize + p.0 as usize;
        let row_factor = factor(y);
        // The vertices left: those off the sweep (on the grid's border),
        // and the swept ones with a partly segmented half or a deviation
        // to scan.
        let swept = &scratch.swept.flags;
        let rare = lanes.clone().filter(|&i| {
            let (unflagged, partial) = swept[i - lanes.start].halves_unflagged_partial();
            partial || (given.is_none() && unflagged)
        });
        for i in (0..lanes.start).chain(rare).chain(lanes.end..count) {
            let x = x0 + step * i as u32;
            let v = (x, y);
            let xi = x as usize;
            let dev2 = given.map(|d| d[i]);
            let k = i.wrapping_sub(lanes.start);
            let s = Split::at(self.grid, v, h, bisects);
            let Split { a, b, apex, .. } = s;
            let corners = |c: Pt| [z[at(a)], z[at(b)], z[at(v)], z[at(c)]];
            if k < lanes.len() {
                let swept = &scratch.swept;
                let bits = swept.flags[k];
                let mut err = swept.err2[k];
                // The footprints first, so a deviation is scanned only if
                // it could still raise the error (`deviation_bound.rs`).
                for (half, apex) in apex.into_iter().enumerate() {
                    if let (true, Some(c)) = (bits.half(half).partial(), apex) {
                        let len = bisects.hypotenuse(h);
                        err = err.max(round_up(footprint2(camera, len, corners(c), zmax)));
                    }
                }
                let mut kept = dev2.unwrap_or_default();
                for (half, apex) in apex.into_iter().enumerate() {
                    let (true, None, Some(c)) = (bits.half(half).unflagged(), dev2, apex) else {
                        continue;
                    };
                    let [c0, c1] = row.half_children(half, i);
                    let bound = children[c0]
                        .dev2(k, c0)
                        .zip(children[c1].dev2(k, c1))
                        .map(|(d0, d1)| deviation_bound::bound2([d0, d1], z[at(a)], z[at(b)], z[at(v)], zmax));
                    kept[half] = match bound {
                        Some(bound) if bound <= err => {
                            #[cfg(test)]
                            tests::SKIPPED.with(|n| n.set(n.get() + 1));
                            bound
                        }
                        _ => {
                            #[cfg(test)]
                            if bound.is_some() {
                                tests::SCANNED.with(|n| n.set(n.get() + 1));
                            }
                            half_deviation2(z, gw as usize, s, h, c)
                        }
                    };
                    err = err.max(kept[half]);
                }
                flag_row[xi] = bits;
                err_row[xi] = err;
                rad_row[xi] = swept.radius[k];
                out.set(
                    r,
                    i,
                    Results {
                        z: z[at(v)],
                        err2: err,
                        radius: swept.radius[k],
                        flags: bits,
                        dev2: kept,
                    },
                );
                continue;
            }
            let (za, zb, zv) = (z[at(a)], z[at(b)], z[at(v)]);
            let pv = point(bp.col(xi), row_factor, zv);
            let mut bits = flag_row[xi].cell_only();
            let mut own = 0f64;
            let mut kept = [0f32; 2];
            let mut err = 0f32;
            let mut radius = 0f64;
            let mut eq12_done = false;
            for half in 0..2 {
                let Some(c) = apex[half] else {
                    bits.set_half(half, Half::ABSENT);
                    continue;
                };
                // The half's children: the midpoints of a-c and c-b, on the
                // row above, the row itself or the row below.
                let mut flagged = None::<Half>;
                for (e0, e1) in [(a, c), (c, b)] {
                    let m = ((e0.0 + e1.0) / 2, (e0.1 + e1.1) / 2);
                    let mx = m.0 as usize;
                    let (ce, cr, cf) = match m.1.cmp(&y) {
                        std::cmp::Ordering::Less => (err_up[mx], rad_up[mx], flag_up[mx]),
                        std::cmp::Ordering::Equal => (err_row[mx], rad_row[mx], flag_row[mx]),
                        std::cmp::Ordering::Greater => (err_down[mx], rad_down[mx], flag_down[mx]),
                    };
                    err = err.max(ce);
                    let dd = pv - point(bp.col(mx), factor(m.1), z[at(m)]);
                    radius = radius.max(norm_bound(dd) + f64::from(cr));
                    let kid = cf.half(half_of(m, v));
                    flagged = Some(flagged.map_or(kid, |f| f.join(kid)));
                }
                let flagged = flagged.unwrap_or(Half::ABSENT);
                bits.set_half(half, flagged);
                if flagged.unflagged() {
                    kept[half] = match dev2 {
                        Some(dv) => dv[half],
                        None => half_deviation2(z, gw as usize, s, h, c),
                    };
                    if !eq12_done {
                        eq12_done = true;
                        let (pa, pb) = (
                            point(bp.col(a.0 as usize), factor(a.1), za),
                            point(bp.col(b.0 as usize), factor(b.1), zb),
                        );
                        own = own.max(eq12(bisects, pv, pa, pb));
                    }
                } else if flagged.partial() {
                    let len = bisects.hypotenuse(h);
                    own = own.max(footprint2(camera, len, corners(c), zmax));
                }
            }
            flag_row[xi] = bits;
            err_row[xi] = err.max(round_up(own)).max(kept[0]).max(kept[1]);
            rad_row[xi] = round_up(radius);
            out.set(
                r,
                i,
                Results {
                    z: zv,
                    err2: err_row[xi],
                    radius: rad_row[xi],
                    flags: bits,
                    dev2: kept,
                },
            );
        }
    }
}

#[cfg(test)]
#[path = "levels_tests.rs"]
mod tests;
