//! The split vertices above the finest level (DMesh Sec. 4.2, Eq. 1-2, and
//! Sec. 5.3), a row of one kind at a time, in straight loops the compiler
//! widens, as `finest.rs` does for level 0: one for Eq. 1 or Eq. 2 and the
//! nested radius over the four children (f64 alone: with the flags' bytes
//! in the same loop, the compiler's cost model kept it scalar), one for the
//! halves' segmentation joined from the children's and the saturated error
//! with the deviations of the unsegmented halves when they are given.
//!
//! Every vertex of one kind on one level has the same shape, up to the turn
//! of a centre's diagonal from one centre to the next. So what each vertex
//! reads is first put in rows of their own, one per role ([`Samples`]: the
//! vertex, the ends of the edge it bisects and its four children), and the
//! column factors once per level and kind ([`Columns`]).
//!
//! The children are not gathered from the grid, `2h` apart (twenty loads
//! and stores per vertex that way cost what the loop saved): each kind's
//! results are kept row by row as the pass writes them ([`Plane`]), for
//! the kind that reads them next. A centre's children are its own level's
//! edge midpoints, at its lane and the next in the kept rows (contiguous);
//! an edge midpoint's are the level below's centres, at twice its lane
//! (two apart). Level 1 reads the finest centres in the grid, four apart:
//! kept, they would be the largest copy of the build. Only the vertex's own
//! depth and cell and the ends of its edge come from the grid.
//!
//! The sweep's results go to the grid's row and to the kind's kept row in
//! straight loops too ([`Scratch::write`], [`Plane::set_row`]). What stays
//! per vertex (`levels.rs`) is rare or costly: the footprint of
//! a partly segmented half, and a deviation not given, which is scanned
//! only for a half found unsegmented, and only where the bound from its
//! children's kept deviations (`deviation_bound.rs`) leaves it open. Only vertices with both halves come
//! here (every centre, and the edge midpoints off the grid's border); the
//! results are bit for bit those of the general kernel (`levels_tests.rs`),
//! which the tests check.

use super::backproject::BackProject;
use super::error_metric::norm_bound;
use super::finest::{eq1, eq2};
use super::flags::Flags;
use super::grid::Grid;
use super::levels::round_up;
use super::split_order::Bisects;

/// The roles a split vertex reads, in the order of [`Columns`] and
/// [`Samples`]: the vertex, the ends `a` and `b` of the edge it bisects,
/// then its four children.
const ROLES: usize = 7;
const V: usize = 0;
const A: usize = 1;
const B: usize = 2;
const CHILD: usize = 3;

/// One row of split vertices of one kind: the `i`-th lies at
/// `(x0 + 2h i, y)`.
#[derive(Clone, Copy)]
pub(super) struct Row {
    pub bisects: Bisects,
    pub h: u32,
    pub x0: u32,
    pub y: u32,
}

impl Row {
    /// Vertices on a row of this kind in a grid of rows `gw` long: at
    /// `x0`, `x0 + 2h`, ... before the row's end.
    #[inline(always)]
    pub(super) fn count(self, gw: usize) -> usize {
        (gw - self.x0 as usize).div_ceil(2 * self.h as usize)
    }

    /// Whether the end `a` of a centre's diagonal lies on the row above
    /// (the row is the level's centre row of odd index).
    #[inline(always)]
    fn odd_row(self) -> bool {
        (self.y - self.h) / (2 * self.h) % 2 == 1
    }

    /// The two children (in the order of [`Self::offset`]) of half `half`
    /// of the `i`-th vertex, as the sweep joins their flags: an edge
    /// midpoint's above or left of it in half 0; a centre's left one and,
    /// as its diagonal turns, the one above or below in half 0.
    #[inline(always)]
    pub(super) fn half_children(self, half: usize, i: usize) -> [usize; 2] {
        let pairs = match self.bisects {
            Bisects::Row => [[0, 1], [2, 3]],
            Bisects::Column => [[0, 2], [1, 3]],
            Bisects::Diagonal if (i % 2 == 1) == self.odd_row() => [[0, 3], [1, 2]],
            Bisects::Diagonal => [[0, 2], [1, 3]],
        };
        pairs[half]
    }

    /// Where role `role` of the `i`-th vertex lies, as offsets from it.
    /// A centre's diagonal runs through the corner whose coordinates are
    /// odd multiples of `2h` (`grid.rs`), so its ends turn with the parity
    /// of `i` (x) and of the row (y). The children lie left, right, above
    /// and below for a centre, and at the four diagonal neighbours `h / 2`
    /// away (left above, right above, left below, right below) for an edge
    /// midpoint; each child holds the vertex in its half 1 when it lies
    /// before it (left, or above), else in half 0.
    #[inline(always)]
    fn offset(self, role: usize, i: usize) -> (i64, i64) {
        let (h, q) = (i64::from(self.h), i64::from(self.h / 2));
        let end = |odd: bool, first: bool| if odd == first { -h } else { h };
        match (self.bisects, role) {
            (_, V) => (0, 0),
            (Bisects::Row, A) => (-h, 0),
            (Bisects::Row, B) => (h, 0),
            (Bisects::Column, A) => (0, -h),
            (Bisects::Column, B) => (0, h),
            (Bisects::Diagonal, A) => (end(i % 2 == 1, true), end(self.odd_row(), true)),
            (Bisects::Diagonal, B) => (end(i % 2 == 1, false), end(self.odd_row(), false)),
            (Bisects::Diagonal, c) => [(-h, 0), (h, 0), (0, -h), (0, h)][c - CHILD],
            (_, c) => [(-q, -q), (q, -q), (-q, q), (q, q)][c - CHILD],
        }
    }

    /// The column of role `role` of the `i`-th vertex (on the grid: the
    /// vertex has both halves).
    #[inline(always)]
    fn x(self, role: usize, i: usize) -> usize {
        (i64::from(self.x0) + 2 * i64::from(self.h) * i as i64 + self.offset(role, i).0) as usize
    }

    /// The row of role `role` (the same for every vertex of the row).
    #[inline(always)]
    fn y(self, role: usize) -> usize {
        (i64::from(self.y) + self.offset(role, 0).1) as usize
    }
}

/// The column factors of each role, `(a, b)` of `x = a + b z`, for the
/// vertices `lanes` of a row of one kind and level: the same on every row.
#[derive(Default)]
pub(super) struct Columns {
    a: [Vec<f64>; ROLES],
    b: [Vec<f64>; ROLES],
}

impl Columns {
    /// Gathers the factors of the vertices `lanes` of rows like `row`.
    pub(super) fn gather(&mut self, bp: &BackProject, row: Row, lanes: std::ops::Range<usize>) {
        let (ca, cb) = bp.cols();
        for role in 0..ROLES {
            let (a, b) = (&mut self.a[role], &mut self.b[role]);
            a.clear();
            b.clear();
            a.extend(lanes.clone().map(|i| ca[row.x(role, i)]));
            b.extend(lanes.clone().map(|i| cb[row.x(role, i)]));
        }
    }
}

/// What one row's vertices read, one row per role: depths (`z[role]`), the
/// children's nested radii, saturated errors and the flags of their half
/// that holds the vertex (as [`Flags::half_bits`] gives them), and the
/// vertex's own flags (its cell's).
#[derive(Default)]
pub(super) struct Samples {
    z: [Vec<f32>; ROLES],
    radius: [Vec<f32>; 4],
    err: [Vec<f32>; 4],
    half: [Vec<u8>; 4],
    cell: Vec<Flags>,
}

/// The results of every split vertex of one kind on one level, row by row
/// (row `r`, lane `j`: the `j`-th vertex of the kind's `r`-th row), kept
/// for the kind that reads them as children: a centre reads its own
/// level's edge midpoints at the lanes of its own (contiguous), an edge
/// midpoint the level below's centres at twice its lane (two apart).
#[derive(Default)]
pub(super) struct Plane {
    /// The kind's row held first (0 but for a band's own planes:
    /// `level_one_shared.rs`).
    row0: usize,
    lanes: usize,
    z: Vec<f32>,
    err2: Vec<f32>,
    radius: Vec<f32>,
    flags: Vec<Flags>,
    /// Each half's squared deviation, or an upper bound of it
    /// (`deviation_bound.rs`); 0 for a segmented half. Kept from level 2
    /// on, where a level's deviations may be scanned as the pass comes.
    dev2: Vec<[f32; 2]>,
}

impl Plane {
    /// Room for `rows` rows of `lanes` from row `row0` on (the values are
    /// overwritten), with the halves' deviations if `deviations`.
    pub(super) fn reset(&mut self, row0: usize, rows: usize, lanes: usize, deviations: bool) {
        self.row0 = row0;
        self.lanes = lanes;
        let n = rows * lanes;
        self.z.resize(n, 0.0);
        self.err2.resize(n, 0.0);
        self.radius.resize(n, 0.0);
        self.flags.resize(n, Flags::default());
        self.dev2.clear();
        if deviations {
            self.dev2.resize(n, [0.0; 2]);
        }
    }

    /// The rows `other` holds (a band's own plane), copied into this one
    /// (the whole level's), the halves' deviations with them if kept.
    pub(super) fn absorb(&mut self, other: &Plane) {
        let at = (other.row0 - self.row0) * self.lanes;
        let n = other.z.len();
        self.z[at..at + n].copy_from_slice(&other.z);
        self.err2[at..at + n].copy_from_slice(&other.err2);
        self.radius[at..at + n].copy_from_slice(&other.radius);
        self.flags[at..at + n].copy_from_slice(&other.flags);
        if let Some(kept) = self.dev2.get_mut(at..at + other.dev2.len()) {
            kept.copy_from_slice(&other.dev2);
        }
    }

    /// The results of vertex `j` of row `r`.
    #[inline(always)]
    pub(super) fn set(&mut self, r: usize, j: usize, v: Results) {
        let at = (r - self.row0) * self.lanes + j;
        self.z[at] = v.z;
        self.err2[at] = v.err2;
        self.radius[at] = v.radius;
        self.flags[at] = v.flags;
        if let Some(d) = self.dev2.get_mut(at) {
            *d = v.dev2;
        }
    }

    /// The results of the vertices swept in `scratch` as the sweep gave
    /// them, from lane `first` of row `r` on, with their halves'
    /// deviations `dev2` (0 where not given).
    #[inline(always)]
    pub(super) fn set_row(&mut self, r: usize, first: usize, scratch: &Scratch, dev2: Option<&[[f32; 2]]>) {
        let swept = &scratch.swept;
        let n = swept.flags.len();
        let at = (r - self.row0) * self.lanes + first;
        self.z[at..at + n].copy_from_slice(&scratch.samples.z[V][..n]);
        self.err2[at..at + n].copy_from_slice(&swept.err2[..n]);
        self.radius[at..at + n].copy_from_slice(&swept.radius[..n]);
        self.flags[at..at + n].copy_from_slice(&swept.flags[..n]);
        if let Some(kept) = self.dev2.get_mut(at..at + n) {
            match dev2 {
                Some(d) => kept.copy_from_slice(&d[..n]),
                None => kept.fill([0.0; 2]),
            }
        }
    }
}

/// The kept planes of the pass: the level below's centres, and this
/// level's edge midpoints along rows, along columns and its centres.
#[derive(Default)]
pub(super) struct Planes {
    pub below: Plane,
    pub row_edges: Plane,
    pub column_edges: Plane,
    pub centres: Plane,
}

/// One grid row of the pass's outputs, as [`Scratch::write`] fills it.
pub(super) struct GridRows<'a> {
    pub flags: &'a mut [Flags],
    pub err2: &'a mut [f32],
    pub radius: &'a mut [f32],
}

/// What a [`Plane`] keeps of one vertex: its depth, saturated error,
/// nested radius, flags, and its halves' squared deviations (or bounds).
pub(super) struct Results {
    pub z: f32,
    pub err2: f32,
    pub radius: f32,
    pub flags: Flags,
    pub dev2: [f32; 2],
}

/// Bytes a [`Plane`] keeps per vertex (its depth, error, radius and
/// flags; the halves' deviations apart).
pub(super) const PLANE_BYTES: usize = 3 * std::mem::size_of::<f32>() + std::mem::size_of::<Flags>();

/// Bytes of the planes the pass above the finest level holds at once, at
/// most: level 1's three kinds and level 2's centres (the buffers are
/// reused from level to level, so the first are the largest), and the
/// halves' deviations from level 2 on.
pub(crate) fn scratch_bytes(grid: Grid) -> usize {
    let per_vertex = PLANE_BYTES;
    let (gw, gh) = (grid.gw() as usize, grid.gh() as usize);
    // Centres and edge midpoints along rows and along columns of level g.
    let kinds = |g: u32| {
        let step = 2usize << g;
        let (nx, ny) = ((gw - 1) / step, (gh - 1) / step);
        [ny * nx, (ny + 1) * nx, ny * (nx + 1)]
    };
    let level_1: usize = if grid.k > 1 { kinds(1).iter().sum() } else { 0 };
    let level_2: usize = if grid.k > 2 { kinds(2).iter().sum() } else { 0 };
    let centres_2 = if grid.k > 2 { kinds(2)[0] } else { 0 };
    (level_1 + centres_2) * per_vertex + (level_2 + centres_2) * std::mem::size_of::<[f32; 2]>()
}

/// One row of the pass above the finest level: its vertices (`row`), those
/// swept (`lanes`: those with both halves), where their children are kept,
/// and where its own results are kept (row `r` of `out`).
pub(super) struct RowTask<'a> {
    pub row: Row,
    pub lanes: std::ops::Range<usize>,
    pub children: [Child<'a>; 4],
    pub out: &'a mut Plane,
    pub r: usize,
}

/// Where the results of a kind are kept: in its [`Plane`], or (the finest
/// level's centres, which fill a quarter of the grid: kept apart, their
/// copy would be the largest of the build's scratch) in the grid.
#[derive(Clone, Copy)]
pub(super) enum Kept<'a> {
    Plane(&'a Plane),
    Grid,
}

/// Where one child of each vertex of a row is kept: in row `row` of
/// `kept`, column `first + stride * k` for the row's `k`-th lane swept.
#[derive(Clone, Copy)]
pub(super) struct Child<'a> {
    pub kept: Kept<'a>,
    pub row: usize,
    pub first: usize,
    pub stride: usize,
}

/// The half of the `c`-th child ([`Row::offset`]) that holds the vertex:
/// children 0 and 2 lie before it (left, or above), in their half 1.
#[inline(always)]
fn holding_half(c: usize) -> usize {
    if c % 2 == 0 {
        1
    } else {
        0
    }
}

impl Child<'_> {
    /// The kept squared deviation (or bound) of the half of this child of
    /// the row's `k`-th swept lane that holds the vertex, the child being
    /// the `c`-th ([`Row::offset`]); `None` where it is not kept.
    #[inline(always)]
    pub(super) fn dev2(self, k: usize, c: usize) -> Option<f32> {
        let Kept::Plane(p) = self.kept else { return None };
        let d = p
            .dev2
            .get((self.row - p.row0) * p.lanes + self.first + self.stride * k)?;
        Some(d[holding_half(c)])
    }

    /// `out` holds `f` of the child's `values` (rows `width` long) for
    /// `n` lanes.
    #[inline(always)]
    fn copy<T: Copy, U>(self, out: &mut Vec<U>, values: &[T], width: usize, n: usize, f: impl Fn(T) -> U) {
        let src = &values[self.row * width + self.first..];
        out.clear();
        match self.stride {
            1 => out.extend(src[..n].iter().map(|&t| f(t))),
            2 => strided::<2, _, _>(out, src, n, f),
            4 => strided::<4, _, _>(out, src, n, f),
            stride => out.extend((0..n).map(|i| f(src[i * stride]))),
        }
    }
}

/// `out` (empty) holds `f` of values `0, S, ..., (n - 1) S` of `src`: all
/// but the last as the first of a group of `S`, so no value is checked
/// against the slice's end (by index, the checks cost what the copies do:
/// the level above the finest reads its children four apart).
#[inline(always)]
pub(super) fn strided<const S: usize, T: Copy, U>(out: &mut Vec<U>, src: &[T], n: usize, f: impl Fn(T) -> U) {
    let Some(last) = n.checked_sub(1) else { return };
    out.extend(src[..last * S].chunks_exact(S).map(|group| f(group[0])));
    out.push(f(src[last * S]));
}

/// `out` holds values `first, first + step, ...` of `src`: all but the last
/// as the first of a group of `step`, so none is checked against the
/// slice's end.
#[inline(always)]
fn every<T: Copy>(src: &[T], first: usize, step: usize, out: &mut [T]) {
    let Some(last) = out.len().checked_sub(1) else { return };
    let src = &src[first..=first + last * step];
    for (o, group) in out[..last].iter_mut().zip(src.chunks_exact(step)) {
        *o = group[0];
    }
    out[last] = src[last * step];
}

/// [`every`]'s inverse: `src` into values `first, first + step, ...` of
/// `out`, each the first of a chunk of `step`, so none is checked against
/// the slice's end.
#[inline(always)]
pub(super) fn scatter<T: Copy>(src: &[T], out: &mut [T], first: usize, step: usize) {
    let Some(last) = src.len().checked_sub(1) else { return };
    for (o, &s) in out[first..=first + last * step].chunks_mut(step).zip(src) {
        o[0] = s;
    }
}

/// What the grid holds so far, as the sweep reads it: the depths whole,
/// the rest from grid row `row0` on.
pub(super) struct Grids<'a> {
    pub gw: usize,
    pub row0: usize,
    pub z: &'a [f32],
    pub radius: &'a [f32],
    pub err2: &'a [f32],
    pub flags: &'a [Flags],
}

impl Samples {
    /// Gathers what the vertices `lanes` of `row` read: their own depth
    /// and cell, and the depths of the ends of the edge they bisect, from
    /// the grid (`2h` apart, in one loop), their children's from where
    /// they are kept (`children`, in the order of [`Row::offset`]).
    #[inline(always)]
    pub(super) fn gather(
        &mut self,
        grids: &Grids<'_>,
        row: Row,
        lanes: std::ops::Range<usize>,
        children: [Child<'_>; 4],
    ) {
        let (gw, n, step) = (grids.gw, lanes.len(), 2 * row.h as usize);
        // Lane `i`'s role `r` is at `base[r][i % 2] + step * i`.
        let mut base = [[0usize; 2]; 3];
        for (role, b) in base.iter_mut().enumerate() {
            for (parity, b) in b.iter_mut().enumerate() {
                *b = (row.y(role) * gw + row.x(role, parity)).wrapping_sub(step * parity);
            }
        }
        for v in &mut self.z[..CHILD] {
            v.resize(n, 0.0);
        }
        self.cell.resize(n, Flags::default());
        let [z0, z1, z2, ..] = &mut self.z;
        let mut z = [&mut z0[..n], &mut z1[..n], &mut z2[..n]];
        let cell = &mut self.cell[..n];
        // A role that does not turn with the lane's parity (all but a
        // centre's diagonal ends) is every `step`-th value from its first
        // lane's, gathered without bounds checks (by index, they cost what
        // the copies do).
        let first = |role: usize| base[role][lanes.start % 2].wrapping_add(step * lanes.start);
        let turns = |role: usize| base[role][0] != base[role][1];
        every(grids.flags, first(V) - grids.row0 * gw, step, cell);
        for (role, z) in z.iter_mut().enumerate() {
            if turns(role) {
                for (k, z) in z.iter_mut().enumerate() {
                    let i = lanes.start + k;
                    *z = grids.z[base[role][i % 2].wrapping_add(step * i)];
                }
            } else {
                every(grids.z, first(role), step, z);
            }
        }
        for (c, child) in children.into_iter().enumerate() {
            // The depths are whole; the rest starts at the plane's or the
            // band's first row.
            let (width, z, z_row0, radius, err2, flags, row0) = match child.kept {
                Kept::Plane(p) => (
                    p.lanes,
                    &p.z[..],
                    p.row0,
                    &p.radius[..],
                    &p.err2[..],
                    &p.flags[..],
                    p.row0,
                ),
                Kept::Grid => (gw, grids.z, 0, grids.radius, grids.err2, grids.flags, grids.row0),
            };
            let at = |row0: usize| Child {
                row: child.row - row0,
                ..child
            };
            let own = at(row0);
            at(z_row0).copy(&mut self.z[CHILD + c], z, width, n, |z| z);
            own.copy(&mut self.radius[c], radius, width, n, |r| r);
            own.copy(&mut self.err[c], err2, width, n, |e| e);
            let half = holding_half(c);
            own.copy(&mut self.half[c], flags, width, n, |f| f.half_bits(half));
        }
    }
}

/// What the sweep gives per vertex: flags, the saturated error but for
/// what stays per vertex (see the module doc), and the nested radius.
#[derive(Default)]
pub(super) struct Swept {
    pub flags: Vec<Flags>,
    pub err2: Vec<f32>,
    pub radius: Vec<f32>,
}

/// The buffers of the sweep, reused from row to row and level to level.
#[derive(Default)]
pub(super) struct Scratch {
    pub columns: Columns,
    pub samples: Samples,
    pub swept: Swept,
    /// Zero deviations, for rows whose deviations are scanned per vertex.
    zeros: Vec<[f32; 2]>,
}

impl Scratch {
    /// The vertices gathered in `samples` of `row` (its first lane is
    /// `first`), their deviations `dev2` (`None`: scanned per vertex),
    /// into `swept`.
    #[inline(always)]
    pub(super) fn sweep(&mut self, bp: &BackProject, row: Row, first: usize, dev2: Option<&[[f32; 2]]>) {
        let n = self.samples.z[V].len();
        let dev2 = dev2.unwrap_or_else(|| {
            self.zeros.resize(n, [0.0; 2]);
            &self.zeros[..n]
        });
        sweep(
            row,
            first,
            &self.columns,
            &self.samples,
            rows(bp, row),
            dev2,
            &mut self.swept,
        );
    }

    /// The swept vertices' flags, errors and radii into their grid row,
    /// the first at column `x0`, `step` apart.
    #[inline(always)]
    pub(super) fn write(&self, row: GridRows<'_>, x0: usize, step: usize) {
        let swept = &self.swept;
        scatter(&swept.flags, row.flags, x0, step);
        scatter(&swept.err2, row.err2, x0, step);
        scatter(&swept.radius, row.radius, x0, step);
    }
}

/// The row factors of each role of `row`.
fn rows(bp: &BackProject, row: Row) -> [(f64, f64); ROLES] {
    let mut rows = [(0.0, 0.0); ROLES];
    for (role, f) in rows.iter_mut().enumerate() {
        *f = bp.row(row.y(role));
    }
    rows
}

/// The straight loop; see the module doc. Bit `0` of a half's bits is
/// "any", bit `2` "all" ([`Flags::half_bits`]).
#[inline(always)]
fn sweep(
    row: Row,
    first: usize,
    c: &Columns,
    s: &Samples,
    rows: [(f64, f64); ROLES],
    dev2: &[[f32; 2]],
    out: &mut Swept,
) {
    let n = s.z[V].len();
    out.flags.clear();
    out.flags.resize(n, Flags::default());
    out.err2.clear();
    out.err2.resize(n, 0.0);
    out.radius.clear();
    out.radius.resize(n, 0.0);
    let (flags, err2, radius) = (&mut out.flags[..n], &mut out.err2[..n], &mut out.radius[..n]);
    let point = BackProject::point_from;
    let [ca0, ca1, ca2, ca3, ca4, ca5, ca6] = &c.a;
    let [cb0, cb1, cb2, cb3, cb4, cb5, cb6] = &c.b;
    let [z0, z1, z2, z3, z4, z5, z6] = &s.z;
    let [r0, r1, r2, r3] = &s.radius;
    let [e0, e1, e2, e3] = &s.err;
    let [f0, f1, f2, f3] = &s.half;
    let ca = [
        &ca0[..n],
        &ca1[..n],
        &ca2[..n],
        &ca3[..n],
        &ca4[..n],
        &ca5[..n],
        &ca6[..n],
    ];
    let cb = [
        &cb0[..n],
        &cb1[..n],
        &cb2[..n],
        &cb3[..n],
        &cb4[..n],
        &cb5[..n],
        &cb6[..n],
    ];
    let z = [&z0[..n], &z1[..n], &z2[..n], &z3[..n], &z4[..n], &z5[..n], &z6[..n]];
    let r = [&r0[..n], &r1[..n], &r2[..n], &r3[..n]];
    let e = [&e0[..n], &e1[..n], &e2[..n], &e3[..n]];
    let f = [&f0[..n], &f1[..n], &f2[..n], &f3[..n]];
    let (cell, dev2) = (&s.cell[..n], &dev2[..n]);
    let odd_row = row.bisects == Bisects::Diagonal && row.odd_row();
    let join = |a: u8, b: u8| ((a | b) & 1) | (a & b & 4);
    // Geometry first, in f64 alone (with the flags' bytes in the same
    // loop, the compiler's cost model kept it scalar): Eq. 1-2 into
    // `err2`, the radius into `radius`.
    for i in 0..n {
        let p = |role: usize| point((ca[role][i], cb[role][i]), rows[role], z[role][i]);
        let pv = p(V);
        let mut rad = 0f64;
        for (child, r) in r.iter().enumerate() {
            rad = rad.max(norm_bound(pv - p(CHILD + child)) + f64::from(r[i]));
        }
        let (pa, pb) = (p(A), p(B));
        err2[i] = round_up(match row.bisects {
            Bisects::Diagonal => eq1(pv, pa, pb),
            Bisects::Row => eq2(pa.x, pa.z, pv.x, pv.z, pb.x, pb.z),
            Bisects::Column => eq2(pa.y, pa.z, pv.y, pv.z, pb.y, pb.z),
        });
        radius[i] = round_up(rad);
    }
    for i in 0..n {
        let geo = err2[i];
        // Each half's two children: an edge midpoint's above or left of
        // it in half 0; a centre's left one and, as its diagonal turns,
        // the one above or below in half 0.
        let k = [f[0][i], f[1][i], f[2][i], f[3][i]];
        let halves = match row.bisects {
            Bisects::Row => [join(k[0], k[1]), join(k[2], k[3])],
            Bisects::Column => [join(k[0], k[2]), join(k[1], k[3])],
            Bisects::Diagonal => {
                let below_first = ((first + i) % 2 == 1) == odd_row;
                let (v0, v1) = if below_first { (k[3], k[2]) } else { (k[2], k[3]) };
                [join(k[0], v0), join(k[1], v1)]
            }
        };
        let unflagged = [halves[0] & 1 == 0, halves[1] & 1 == 0];
        let mut err = e[0][i].max(e[1][i]).max(e[2][i]).max(e[3][i]);
        // Rounding up is monotonic: the larger of rounded values is the
        // rounded larger value, so the parts of `own` join one by one.
        err = err.max(if unflagged[0] || unflagged[1] { geo } else { 0.0 });
        err = err.max(if unflagged[0] { dev2[i][0] } else { 0.0 });
        err = err.max(if unflagged[1] { dev2[i][1] } else { 0.0 });
        flags[i] = cell[i].with_halves(halves);
        err2[i] = err;
    }
}
