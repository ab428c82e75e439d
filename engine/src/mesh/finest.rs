//! The finest level of the bottom-up pass (DMesh Sec. 4.2, Eq. 1-2, and
//! Sec. 5.3): three quarters of all split vertices, whose halves are
//! full-resolution triangles. Per row, in two sweeps:
//!
//! - **geometry**, without branches over the row's vertices: Eq. 1 or Eq. 2
//!   and the detail (a finest half's exact deviation: its one interior
//!   sample is `v`), rounded up to f32, and for centres the nested radius.
//!   Every vertex of a kind on a row has the same shape, so the loop is
//!   straight and the compiler widens it (AVX2 where the CPU has it). A
//!   centre's diagonal turns from one centre to the next, so the centres'
//!   samples and column factors are first gathered into rows of their own,
//!   one per role ([`CentreSamples`], [`CentreColumns`]): read in place,
//!   the turn kept the loop scalar;
//! - **flags**, byte by byte: the halves' segmentation from the leaf cells,
//!   which geometric error counts (an unflagged half's), a partly segmented
//!   half's footprint (rare: only along discontinuities), and the
//!   saturation over a centre's four children.
//!
//! The results are bit for bit those of the general kernel in `levels.rs`
//! (`split_vertex`), except that a partly segmented half's footprint is
//! taken at the deeper of the two apexes (never smaller); the tests there
//! check both.

use super::backproject::BackProject;
use super::coarse_rows::{scatter, strided};
use super::error_metric::norm_bound;
use super::flags::{finish_halves, join_bits, join_leaves, Flags, Half};
use super::levels::{footprint2, round_up, Levels};
use glam::DVec3;

/// Eq. 2 in the plane of one image axis and depth, squared, as
/// `point_line_2d_sq` computes it (the same operations in the same order,
/// both branches evaluated and one selected, so the loop has none).
#[inline(always)]
pub(super) fn eq2(sa: f64, za: f64, sv: f64, zv: f64, sb: f64, zb: f64) -> f64 {
    let (ds, dz) = (sb - sa, zb - za);
    let (ps, pz) = (sv - sa, zv - za);
    let len2 = ds * ds + dz * dz;
    let cross = ds * pz - dz * ps;
    let on_line = cross * cross / len2;
    let degenerate = ps * ps + pz * pz;
    if len2 > 0.0 {
        on_line
    } else {
        degenerate
    }
}

/// The squared detail of `zv` against the midpoint of `za` and `zb`.
#[inline(always)]
fn detail2(za: f64, zv: f64, zb: f64) -> f64 {
    let detail = zv - 0.5 * (za + zb);
    detail * detail
}

/// Eq. 1, squared, as `point_line_3d_sq` computes it, without branches.
#[inline(always)]
pub(super) fn eq1(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let ap = p - a;
    let len2 = ab.length_squared();
    let on_line = (ab.cross(ap).length_squared() / len2).max(0.0);
    let degenerate = ap.length_squared();
    if len2 > 0.0 {
        on_line
    } else {
        degenerate
    }
}

/// A half off the grid, as bits ([`Half::bits`]).
const ABSENT: u8 = Half::ABSENT.bits();

/// The column factors the centres of level 0 read, one row per role, `i`
/// for the centre at `x = 2i + 1`: their own column's, their left and right
/// neighbours', and the ends of their diagonal (`a` on the row of `p`, `b`
/// on the other), which trade places from one centre to the next. The same
/// for every row, so gathered once.
struct CentreColumns {
    v: [Vec<f64>; 2],
    left: [Vec<f64>; 2],
    right: [Vec<f64>; 2],
    a: [Vec<f64>; 2],
    b: [Vec<f64>; 2],
}

impl CentreColumns {
    fn new(bp: &BackProject, n: usize) -> Self {
        let (ca, cb) = bp.cols();
        let at = |x: fn(usize) -> usize| {
            [ca, cb].map(|c| {
                let mut v = Vec::new();
                fill(&mut v, n, |i| c[x(i)]);
                v
            })
        };
        Self {
            v: at(|i| 2 * i + 1),
            left: at(|i| 2 * i),
            right: at(|i| 2 * i + 2),
            a: at(|i| if i % 2 == 1 { 2 * i } else { 2 * i + 2 }),
            b: at(|i| if i % 2 == 1 { 2 * i + 2 } else { 2 * i }),
        }
    }
}

/// The depths one row of level-0 centres reads, one row per role (see
/// [`CentreColumns`]): the centre's, its four neighbours', and its
/// diagonal's ends.
#[derive(Default)]
struct CentreSamples {
    v: Vec<f32>,
    left: Vec<f32>,
    right: Vec<f32>,
    up: Vec<f32>,
    down: Vec<f32>,
    a: Vec<f32>,
    b: Vec<f32>,
}

impl CentreSamples {
    /// The `n` centres between rows `zs[0]` and `zs[2]` (at least `2n + 1`
    /// long), whose diagonals start on row `p_row` (0 or 2). Inlined into
    /// the AVX2 caller (out of line, it ran without AVX2), and the samples
    /// beside and at the centres read a pair at a time, so none is checked
    /// against its row's end: the finest stage at 1920 x 1080 on one thread
    /// went from 28.8-29.0 ms to 27.0-27.2. The diagonal's ends, which turn
    /// from centre to centre, are read by index.
    #[inline(always)]
    fn gather(&mut self, zs: [&[f32]; 3], p_row: usize, n: usize) {
        let (up, row, down) = (&zs[0][..2 * n + 1], &zs[1][..2 * n + 1], &zs[2][..2 * n + 1]);
        let (zp, zq) = if p_row == 0 { (up, down) } else { (down, up) };
        fill_pairs(&mut self.v, &row[1..], n);
        fill_pairs(&mut self.left, row, n);
        fill_pairs(&mut self.right, &row[2..], n);
        fill_pairs(&mut self.up, &up[1..], n);
        fill_pairs(&mut self.down, &down[1..], n);
        // Centres 2m and 2m + 1 share their diagonal's `a` end, zp[4m + 2];
        // centre i's `b` end is zq[4 ceil(i / 2)].
        fill(&mut self.a, n, |i| zp[4 * (i / 2) + 2]);
        fill(&mut self.b, n, |i| zq[4 * i.div_ceil(2)]);
    }
}

/// `v` holds `z[0], z[2], ..., z[2 (n - 1)]`, in the memory it had, read
/// as [`strided`] reads the coarser levels' children.
#[inline(always)]
fn fill_pairs(v: &mut Vec<f32>, z: &[f32], n: usize) {
    v.clear();
    strided::<2, _, _>(v, z, n, |z| z);
}

/// `v` holds `f(0), ..., f(n - 1)`, in the memory it had.
#[inline(always)]
fn fill<T>(v: &mut Vec<T>, n: usize, f: impl Fn(usize) -> T) {
    v.clear();
    v.extend((0..n).map(f));
}

/// The detail and Eq. 1 (`geo`) and the nested radius (`rad`) of a row of
/// level-0 centres, rounded up, from their samples in rows of their own: a
/// straight loop over equal-length slices, which the compiler widens.
#[inline(always)]
fn centre_geometry(
    c: &CentreColumns,
    s: &CentreSamples,
    rows: [(f64, f64); 3],
    (rp, rq): ((f64, f64), (f64, f64)),
    geo: &mut [f32],
    rad: &mut [f32],
) {
    let n = geo.len();
    let rad = &mut rad[..n];
    fn two(v: &[Vec<f64>; 2], n: usize) -> (&[f64], &[f64]) {
        (&v[0][..n], &v[1][..n])
    }
    let (cv, cl, cr) = (two(&c.v, n), two(&c.left, n), two(&c.right, n));
    let (ca, cb) = (two(&c.a, n), two(&c.b, n));
    let (zv, zl, zr) = (&s.v[..n], &s.left[..n], &s.right[..n]);
    let (zu, zd, za, zb) = (&s.up[..n], &s.down[..n], &s.a[..n], &s.b[..n]);
    let point = BackProject::point_from;
    for i in 0..n {
        let pv = point((cv.0[i], cv.1[i]), rows[1], zv[i]);
        let mut radius = 0f64;
        for (col, row, zc) in [
            ((cl.0[i], cl.1[i]), rows[1], zl[i]),
            ((cr.0[i], cr.1[i]), rows[1], zr[i]),
            ((cv.0[i], cv.1[i]), rows[0], zu[i]),
            ((cv.0[i], cv.1[i]), rows[2], zd[i]),
        ] {
            radius = radius.max(norm_bound(pv - point(col, row, zc)));
        }
        let pa = point((ca.0[i], ca.1[i]), rp, za[i]);
        let pb = point((cb.0[i], cb.1[i]), rq, zb[i]);
        let own = eq1(pv, pa, pb).max(detail2(f64::from(za[i]), f64::from(zv[i]), f64::from(zb[i])));
        geo[i] = round_up(own);
        rad[i] = round_up(radius);
    }
}

impl Levels<'_> {
    /// The edge midpoints of level 0 along rows (`ROW`) or columns.
    #[inline(always)]
    pub(super) fn finest_edges<const ROW: bool>(&mut self, flags: &mut [Flags], zmax: f32, geo: &mut [f32]) {
        let (gw, gh) = (self.grid.gw() as usize, self.grid.gh() as usize);
        let (bp, camera, z) = (self.bp, self.camera, self.z);
        let len = 2.0;
        let ys = if ROW { (0..gh).step_by(2) } else { (1..gh).step_by(2) };
        // The row above the first, read but not used (its halves are off
        // the grid).
        let none = &vec![Flags::default(); gw][..];
        let mut bits = vec![Flags::default(); gw];
        for y in ys {
            let zr = &z[y * gw..(y + 1) * gw];
            // Geometry of every vertex of the row: v at x = 2i + 1 along
            // rows, x = 2i along columns.
            if ROW {
                let n = gw / 2;
                let geo = &mut geo[..n];
                // Slices as long as the loop reads (x + 1 <= 2n), so the
                // compiler sees every index in bounds and widens the loop.
                let (zr, (col_a, col_b)) = (&zr[..2 * n + 1], bp.cols());
                let (col_a, col_b) = (&col_a[..2 * n + 1], &col_b[..2 * n + 1]);
                let col = |x: usize| (col_a[x], col_b[x]);
                for (i, g) in geo.iter_mut().enumerate() {
                    let x = 2 * i + 1;
                    let (za, zv, zb) = (f64::from(zr[x - 1]), f64::from(zr[x]), f64::from(zr[x + 1]));
                    let ((aa, ba), (av, bv), (ab, bb)) = (col(x - 1), col(x), col(x + 1));
                    let own = eq2(aa + ba * za, za, av + bv * zv, zv, ab + bb * zb, zb).max(detail2(za, zv, zb));
                    *g = round_up(own);
                }
            } else {
                let (zu, zd) = (&z[(y - 1) * gw..y * gw], &z[(y + 1) * gw..(y + 2) * gw]);
                let [(au, bu), (av, bv), (ad, bd)] = [bp.row(y - 1), bp.row(y), bp.row(y + 1)];
                let n = gw / 2 + 1;
                let geo = &mut geo[..n];
                for (i, g) in geo.iter_mut().enumerate() {
                    let x = 2 * i;
                    let (za, zv, zb) = (f64::from(zu[x]), f64::from(zr[x]), f64::from(zd[x]));
                    let own = eq2(au + bu * za, za, av + bv * zv, zv, ad + bd * zb, zb).max(detail2(za, zv, zb));
                    *g = round_up(own);
                }
            }
            // Flags, and which error counts: straight loops over the row
            // (so they widen) into rows of their own, written to the grid
            // two apart, then the partly segmented halves, which are rare
            // (only along discontinuities), one by one.
            let (head, tail) = flags.split_at_mut(y * gw);
            let row = &mut tail[..gw];
            let up: &[Flags] = if y > 0 { &head[(y - 1) * gw..y * gw] } else { none };
            let err = &mut self.err2[y * gw..(y + 1) * gw];
            // Vertex i at x = 2i + 1 along rows, x = 2i along columns.
            let (first, n) = if ROW { (1, gw / 2) } else { (0, gw / 2 + 1) };
            let (geo, bits) = (&mut geo[..n], &mut bits[..n]);
            let partial = if ROW {
                // Half 0 above the row (off the grid on the first), half 1
                // below (off the grid on the last); the leaves either side
                // of v: the cells at x - 1 and x.
                let above = if y > 0 { 0 } else { ABSENT };
                let below = if y + 1 < gh { 0 } else { ABSENT };
                let pairs = up[..2 * n].chunks_exact(2).zip(row[..2 * n].chunks_exact(2));
                let mut partial = 0;
                for (((u, r), g), b) in pairs.zip(geo.iter_mut()).zip(bits.iter_mut()) {
                    let h0 = join_leaves(u[0].leaf_bit(1), u[1].leaf_bit(0)) | above;
                    let h1 = join_leaves(r[0].leaf_bit(1), r[1].leaf_bit(0)) | below;
                    let (f, unflagged, p) = finish_halves(r[1].cell_only(), h0, h1);
                    (*b, *g, partial) = (f, if unflagged { *g } else { 0.0 }, partial | p);
                }
                partial
            } else {
                // Half 0 left of the column (off the grid at x = 0), half 1
                // right (off the grid at the row's end); the leaves above
                // and below v: the cells at (x - 1, y - 1) and (x - 1, y),
                // then at x.
                let halves = |x: usize| {
                    let h0 = if x > 0 {
                        join_leaves(up[x - 1].leaf_bit(1), row[x - 1].leaf_bit(1))
                    } else {
                        ABSENT
                    };
                    let h1 = if x + 1 < gw {
                        join_leaves(up[x].leaf_bit(0), row[x].leaf_bit(0))
                    } else {
                        ABSENT
                    };
                    finish_halves(row[x].cell_only(), h0, h1)
                };
                let mut partial = 0;
                for i in [0, n - 1] {
                    let (f, unflagged, p) = halves(2 * i);
                    (bits[i], geo[i], partial) = (f, if unflagged { geo[i] } else { 0.0 }, partial | p);
                }
                // Between the ends, in pairs (x - 1, x) from x = 2.
                let inner = 1..n - 1;
                let pairs = up[1..2 * n - 3].chunks_exact(2).zip(row[1..2 * n - 3].chunks_exact(2));
                for (((u, r), g), b) in pairs.zip(geo[inner.clone()].iter_mut()).zip(bits[inner].iter_mut()) {
                    let h0 = join_leaves(u[0].leaf_bit(1), r[0].leaf_bit(1));
                    let h1 = join_leaves(u[1].leaf_bit(0), r[1].leaf_bit(0));
                    let (f, unflagged, p) = finish_halves(r[1].cell_only(), h0, h1);
                    (*b, *g, partial) = (f, if unflagged { *g } else { 0.0 }, partial | p);
                }
                partial
            };
            scatter(bits, row, first, 2);
            scatter(geo, err, first, 2);
            if partial == 0 {
                continue;
            }
            for x in (first..gw).step_by(2) {
                if row[x].partial_halves() == 0 {
                    continue;
                }
                let exists = if ROW { [y > 0, y + 1 < gh] } else { [x > 0, x + 1 < gw] };
                let apex = |dx: isize, dy: isize| {
                    let (ax, ay) = (x as isize + dx, y as isize + dy);
                    z[(ay as usize) * gw + ax as usize]
                };
                let (back, forth) = if ROW { ((0, -1), (0, 1)) } else { ((-1, 0), (1, 0)) };
                let zapex = match exists {
                    [true, true] => apex(back.0, back.1).max(apex(forth.0, forth.1)),
                    [true, false] => apex(back.0, back.1),
                    [false, true] => apex(forth.0, forth.1),
                    [false, false] => 0.0,
                };
                let (za, zb) = if ROW {
                    (zr[x - 1], zr[x + 1])
                } else {
                    (z[(y - 1) * gw + x], z[(y + 1) * gw + x])
                };
                err[x] = err[x].max(round_up(footprint2(camera, len, [za, zb, zr[x], zapex], zmax)));
            }
        }
    }

    /// The centres of level 0: their four children are the finest edge
    /// midpoints around them (radius 0), already done.
    #[inline(always)]
    pub(super) fn finest_centres(&mut self, flags: &mut [Flags], zmax: f32, geo: &mut [f32], rad: &mut [f32]) {
        let (gw, gh) = (self.grid.gw() as usize, self.grid.gh() as usize);
        let (bp, camera, z) = (self.bp, self.camera, self.z);
        let columns = CentreColumns::new(bp, gw / 2);
        let mut samples = CentreSamples::default();
        let mut bits = vec![Flags::default(); gw / 2];
        for y in (1..gh).step_by(2) {
            let rows = [bp.row(y - 1), bp.row(y), bp.row(y + 1)];
            let zs = [
                &z[(y - 1) * gw..y * gw],
                &z[y * gw..(y + 1) * gw],
                &z[(y + 1) * gw..(y + 2) * gw],
            ];
            // The diagonal through v runs from (px, py) to (qx, qy): py is
            // the row above (0) or below (2), qy the other; px is x - 1 for
            // odd i (v at x = 2i + 1), x + 1 for even.
            let p_row = if (y - 1) / 2 % 2 == 1 { 0 } else { 2 };
            let q_row = 2 - p_row;
            let (rp, rq) = (rows[p_row], rows[q_row]);
            let n = gw / 2;
            let (geo, rad) = (&mut geo[..n], &mut rad[..n]);
            samples.gather(zs, p_row, n);
            centre_geometry(&columns, &samples, rows, (rp, rq), geo, rad);
            let (head, tail) = self.err2.split_at_mut(y * gw);
            let (err_row, rest) = tail.split_at_mut(gw);
            let (err_up, err_down) = (&head[(y - 1) * gw..], &rest[..gw]);
            let (head, tail) = flags.split_at_mut(y * gw);
            let (flag_row, rest) = tail.split_at_mut(gw);
            let (flag_up, flag_down) = (&head[(y - 1) * gw..], &rest[..gw]);
            let radius_row = &mut self.radius[y * gw..(y + 1) * gw];
            // Half 0 has its apex at x - 1, half 1 at x + 1; each holds the
            // child beside v on its side and the one above or below v on
            // its apex's row: p's row for half 0 of even centres and half 1
            // of odd ones, q's for the others. Children before v (left, or
            // above) hold v in their half 1, those after in half 0. Flags
            // and errors in a straight loop into rows of their own (so it
            // widens), written to the grid two apart; then the partly
            // segmented halves, which are rare, one by one.
            let (vp, vq) = if p_row == 0 {
                (flag_up, flag_down)
            } else {
                (flag_down, flag_up)
            };
            let (hp, hq) = if p_row == 0 { (1, 0) } else { (0, 1) };
            let (bits, geo) = (&mut bits[..n], &mut geo[..n]);
            let mut partial = 0;
            {
                let m = 2 * n + 1;
                let (fr, vp, vq) = (&flag_row[..m], &vp[..m], &vq[..m]);
                let (er, eu, ed) = (&err_row[..m], &err_up[..m], &err_down[..m]);
                for (i, (b, g)) in bits.iter_mut().zip(geo.iter_mut()).enumerate() {
                    let x = 2 * i + 1;
                    let (on_p, on_q) = (vp[x].half_bits(hp), vq[x].half_bits(hq));
                    let odd = 0u8.wrapping_sub((i & 1) as u8);
                    let (v0, v1) = (on_p & !odd | on_q & odd, on_q & !odd | on_p & odd);
                    let h0 = join_bits(fr[x - 1].half_bits(1), v0);
                    let h1 = join_bits(fr[x + 1].half_bits(0), v1);
                    let (f, unflagged, p) = finish_halves(fr[x].cell_only(), h0, h1);
                    let own = if unflagged { *g } else { 0.0 };
                    let children = er[x - 1].max(er[x + 1]).max(eu[x]).max(ed[x]);
                    (*b, *g, partial) = (f, children.max(own), partial | p);
                }
            }
            scatter(bits, flag_row, 1, 2);
            scatter(geo, err_row, 1, 2);
            scatter(&rad[..n], radius_row, 1, 2);
            if partial == 0 {
                continue;
            }
            for i in 0..n {
                let x = 2 * i + 1;
                let halves = flag_row[x].partial_halves();
                if halves == 0 {
                    continue;
                }
                let odd = i % 2 == 1;
                let apex_rows = if odd { [q_row, p_row] } else { [p_row, q_row] };
                // Each partial half's footprint; the larger apex depth
                // covers both when both are partial.
                let zapex = (0..2)
                    .filter(|&half| halves >> half & 1 == 1)
                    .map(|half| zs[apex_rows[half]][x + 2 * half - 1])
                    .fold(f32::MIN, f32::max);
                let (za, zb) = if odd {
                    (zs[p_row][x - 1], zs[q_row][x + 1])
                } else {
                    (zs[p_row][x + 1], zs[q_row][x - 1])
                };
                let len = 2.0 * std::f64::consts::SQRT_2;
                err_row[x] = err_row[x].max(round_up(footprint2(camera, len, [za, zb, zs[1][x], zapex], zmax)));
            }
        }
    }
}
