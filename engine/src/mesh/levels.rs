//! The bottom-up pass of the build over the levels of the 4-8 hierarchy,
//! finest first: flags, own and saturated errors and nested radii of every
//! split vertex (DMesh Sec. 4.2 and 5.3; what each term is, is documented in
//! `hierarchy.rs`). It reads the depths and writes flags, errors and radii
//! only, so the normals can be computed beside it; the deviations of the
//! levels above the finest, which need the depths alone, can be computed on
//! another thread (`level_deviations.rs`), while this pass builds the
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
//! against it. The finest level's loops are in `finest.rs`; level 1 on
//! two threads is in `level_one_shared.rs`.

use super::backproject::BackProject;
use super::coarse_rows::{Child, GridRows, Grids, Kept, Plane, Planes, Results, Row, RowTask, Scratch};
use super::deviation_bound;
use super::error_metric::{norm_bound, point_line_2d_sq, point_line_3d_sq};
use super::flags::{Flags, Half};
use super::grid::{half_of, Grid, Pt};
use super::level_deviations::half_deviation2;
use super::level_one_shared::{Share, SHARED_ROWS};
use super::split_order::{Bisects, Split};
use crate::camera::Camera;
use glam::DVec3;
use std::ops::Range;

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
    /// The grid row `err2`, `radius` and the flags the pass is given
    /// start at (0 but for a band of rows: `level_one_shared.rs`).
    pub row0: u32,
}

/// One kind of vertex of a level, as [`Levels::kind_rows`] takes it: the
/// shape of its rows, its first row, and per row its vertices with both
/// halves (`lanes`) and where their children are kept.
struct Kind<L, C> {
    row: Row,
    y0: u32,
    lanes: L,
    children: C,
}

/// Vertices per row of level `g` (centres, and edge midpoints along rows;
/// one more along columns) and rows per kind (one more along rows).
pub(super) fn level_size(grid: Grid, g: u32) -> (usize, usize) {
    let step = 2usize << g;
    ((grid.gw() as usize - 1) / step, (grid.gh() as usize - 1) / step)
}

/// Where the pass over the levels above the finest gets each level's
/// deviations: called once per level, finest first; `None` has the pass
/// scan each unflagged half as it comes.
pub(crate) type DeviationSource<'a> = &'a mut dyn FnMut(u32) -> Option<Vec<[f32; 2]>>;

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
    pub(crate) fn run_coarse(levels: &mut Levels<'_>, flags: &mut [Flags], zmax: f32, deviations: DeviationSource<'_>, share: Option<Share>) -> () = run_coarse_body;
}

#[inline(always)]
fn run_coarse_body(
    levels: &mut Levels<'_>,
    flags: &mut [Flags],
    zmax: f32,
    deviations: DeviationSource<'_>,
    share: Option<Share>,
) {
    levels.run_coarse(flags, zmax, deviations, share);
}

impl Levels<'_> {
    /// The levels above the finest, each given its `coarse_deviations`
    /// by `deviations` or computing each unsegmented half's as it comes:
    /// per level the edge midpoints along rows, along columns, then the
    /// centres, each in a straight loop over rows ([`Self::coarse_row`]),
    /// in the order of `for_each_split`. Level 1 is shared with a
    /// second thread when `share` lends one (`level_one_shared.rs`).
    #[inline(always)]
    pub(crate) fn run_coarse(
        &mut self,
        flags: &mut [Flags],
        zmax: f32,
        deviations: DeviationSource<'_>,
        mut share: Option<Share>,
    ) {
        let mut scratch = Scratch::default();
        // Each kind's results, kept for the kind that reads them as
        // children (`coarse_rows.rs`): the level below's centres, this
        // level's edge midpoints along rows and along columns, its centres.
        let mut planes = Planes::default();
        for g in 1..self.grid.k {
            let given = deviations(g);
            // (After the deviations, which may wait for the helper.)
            let _span = tracing::trace_span!("level", g).entered();
            let (nx, ny) = level_size(self.grid, g);
            // The halves' deviations are kept from level 2 on, for the
            // bound of the level above where it is scanned as the pass
            // comes (from level 4 in a build, which is given levels 1 to
            // 3; from level 1 in the tests' scanning paths).
            planes.row_edges.reset(0, ny + 1, nx, g >= 2);
            planes.column_edges.reset(0, ny, nx + 1, g >= 2);
            planes.centres.reset(0, ny, nx, g >= 2);
            let given = given.as_deref();
            match share.take() {
                Some(share) if g == 1 && ny >= SHARED_ROWS => {
                    self.level_one_shared(flags, zmax, given, &mut planes, &mut scratch, share);
                }
                _ => self.level_rows(
                    flags,
                    zmax,
                    g,
                    [0..ny + 1, 0..ny, 0..ny],
                    given,
                    &mut planes,
                    &mut scratch,
                ),
            }
            std::mem::swap(&mut planes.below, &mut planes.centres);
        }
    }

    /// The vertices of level `g` on rows `rows` of each kind (edge
    /// midpoints along rows, along columns, centres; rows counted per
    /// kind), in that order, with the level's deviations `given` (all of
    /// them, in the order `coarse_deviations` gives them), into the
    /// grid's rows and `planes`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn level_rows(
        &mut self,
        flags: &mut [Flags],
        zmax: f32,
        g: u32,
        rows: [Range<usize>; 3],
        given: Option<&[[f32; 2]]>,
        planes: &mut Planes,
        scratch: &mut Scratch,
    ) {
        let gw = self.grid.gw() as usize;
        let h = 1u32 << g;
        let (nx, ny) = level_size(self.grid, g);
        // The shape of each kind's rows; its rows of deviations, `count`
        // per row, the kinds one after the other.
        let shape = |bisects, x0| Row { bisects, h, x0, y: h };
        let shapes = [
            shape(Bisects::Row, h),
            shape(Bisects::Column, 0),
            shape(Bisects::Diagonal, h),
        ];
        let counts = shapes.map(|row| row.count(gw));
        let bases = [0, (ny + 1) * counts[0], (ny + 1) * counts[0] + ny * counts[1]];
        debug_assert!(
            given.is_none_or(|d| d.len() == bases[2] + ny * counts[2]),
            "deviations of another level"
        );
        let from = |kind: usize, r: usize| given.map(|d| &d[(bases[kind] + r * counts[kind]).min(d.len())..]);
        let [row_edge_rows, column_edge_rows, centre_rows] = rows;
        let Planes {
            below,
            row_edges,
            column_edges,
            centres,
        } = planes;

        // Each kind's vertices with both halves go through the sweep:
        // the edge midpoints along rows off the first and last rows,
        // those along columns off the first and last columns, every
        // centre. An edge midpoint's children are the centres of the
        // level below around it, at twice its lane (`Row::offset`'s
        // order: left above, right above, left below, right below):
        // lane `j` of row `r` of the level below's centres, which on
        // level 1 are the finest centres, in the grid at `(2j + 1,
        // 2r + 1)`.
        let two = |row: usize, first: usize| match g {
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
        // (The first and last rows along rows have no lanes, and do not
        // read their children there.)
        let row_edge = Kind {
            row: shapes[0],
            y0: 0,
            lanes: |r| if r == 0 || r == ny { 0..0 } else { 0..nx },
            children: |r: usize| {
                let above = (2 * r).saturating_sub(1);
                [two(above, 0), two(above, 1), two(2 * r, 0), two(2 * r, 1)]
            },
        };
        self.kind_rows(flags, zmax, row_edge, row_edge_rows, |r| from(0, r), row_edges, scratch);
        let column_edge = Kind {
            row: shapes[1],
            y0: h,
            lanes: |_| 1..nx,
            children: |r| [two(2 * r, 1), two(2 * r, 2), two(2 * r + 1, 1), two(2 * r + 1, 2)],
        };
        self.kind_rows(
            flags,
            zmax,
            column_edge,
            column_edge_rows,
            |r| from(1, r),
            column_edges,
            scratch,
        );
        // A centre's children are its level's edge midpoints: along
        // columns on its row at its lane and the next, along rows
        // above and below at its lane.
        let one = |plane, row, first| Child {
            kept: Kept::Plane(plane),
            row,
            first,
            stride: 1,
        };
        let (column_edges, row_edges) = (&*column_edges, &*row_edges);
        let centre = Kind {
            row: shapes[2],
            y0: h,
            lanes: |_| 0..nx,
            children: |r| {
                [
                    one(column_edges, r, 0),
                    one(column_edges, r, 1),
                    one(row_edges, r, 0),
                    one(row_edges, r + 1, 0),
                ]
            },
        };
        self.kind_rows(flags, zmax, centre, centre_rows, |r| from(2, r), centres, scratch);
    }

    /// Rows `rows` of one kind of a level, with its deviations from row
    /// `r` on given by `from(r)`, into the grid and `out`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn kind_rows<'p>(
        &mut self,
        flags: &mut [Flags],
        zmax: f32,
        kind: Kind<impl Fn(usize) -> Range<usize>, impl Fn(usize) -> [Child<'p>; 4]>,
        rows: Range<usize>,
        from: impl Fn(usize) -> Option<&'p [[f32; 2]]>,
        out: &mut Plane,
        scratch: &mut Scratch,
    ) {
        let Kind {
            row,
            y0,
            lanes,
            children,
        } = kind;
        if rows.is_empty() {
            return;
        }
        // The columns of the lanes inside the rows: the same on each.
        scratch.columns.gather(self.bp, row, lanes(1));
        let mut next = from(rows.start);
        for r in rows {
            let task = RowTask {
                row: Row {
                    y: y0 + r as u32 * 2 * row.h,
                    ..row
                },
                lanes: lanes(r),
                children: children(r),
                out: &mut *out,
                r,
            };
            self.coarse_row(flags, zmax, task, &mut next, scratch);
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
        let (x0, step, count) = (row.x0, 2 * h, row.count(gw as usize));
        // This row's deviations, if given.
        let given = next.as_mut().map(|rest| {
            let (now, later) = rest.split_at(count.min(rest.len()));
            *rest = later;
            now
        });
        if !lanes.is_empty() {
            let grids = Grids {
                gw: gw as usize,
                row0: self.row0 as usize,
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
            let row_at = (y - self.row0) as usize * gw as usize;
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
        let yb = y - self.row0;
        let (err_up, err_row, err_down) = rows3(self.err2, gw as usize, yb, d);
        let (flag_up, flag_row, flag_down) = rows3(flags, gw as usize, yb, d);
        let (rad_up, rad_row, rad_down) = rows3(self.radius, gw as usize, yb, d);
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
