//! Outlines as cuts (DESIGN.md "Outlines as cuts"): a hierarchy triangle
//! that a depth discontinuity crosses, drawn as two parts separated by one
//! straight cut instead of refined down to single cells.
//!
//! The idea is the wedgelet's and the platelet's (a block split by one
//! straight line into two surfaces, as 3D-HEVC's depth-modelling modes
//! code a depth edge inside a coarse block), placed on the 4-8 lattice so
//! that neighbours agree by construction:
//!
//! - **Jumps live on lattice steps.** A unit step between two adjacent
//!   samples (along a row, a column or a cell diagonal) *jumps* when one
//!   sample is valid and the other not, or when both are valid and every
//!   full-resolution triangle that has the step as an edge is segmented
//!   (DMesh Eq. 9-11, the flags of `segmentation.rs`). A step between two
//!   invalid samples never jumps. The rule reads the step alone, so the two
//!   triangles that share a lattice edge see the same jumps on it.
//! - **A crossing is a jump on a triangle's edge.** It sits at the step's
//!   midpoint, `(2k + 1) / 2n` along an edge of `n` steps (a run of
//!   jumping steps: the run's middle), so a part ends half a sample past
//!   its last valid sample, where that sample's pixel ends. At the image
//!   border of a padded grid that is the last pixel's far edge: a
//!   rasteriser's top-left rule then fills the image's last row and column
//!   as it fills its first ones, which a mesh ending on the last samples
//!   leaves unfilled. Its quantisation is the half step, in `log2 n + 1`
//!   bits: exact, since a jump has no finer position.
//! - **A triangle is cut** when exactly two of its edges hold one crossing
//!   each and the third none. The corner between the crossed edges is
//!   alone on its side; the cut joins the two crossings. Every other
//!   pattern (several crossings on an edge, a corner, an outline that ends
//!   inside) is not a cut, and the triangle is refined as before.
//! - **Each side of a crossing has its own depth**, a function of the
//!   edge alone: from the edge's end on that side through the last sample
//!   on that side, continued to the crossing. The triangles on
//!   both sides of the edge compute the same two depths bit for bit, so
//!   near meets near and far meets far at every crossing: no crack.
//! - **A side of invalid samples is void**: nothing is drawn there. The
//!   image border of a padded grid and the edge of a region of missing
//!   samples are cuts like any other, a straight border the easiest.
//! - **The case table**: the lone part is one triangle (corner, crossing,
//!   crossing), the other a quadrilateral drawn as two with a fixed
//!   diagonal, so a cut triangle draws at most three triangles, oriented
//!   as the triangle was.
//! - **The error bound** (the one `extract.rs` states for every emitted
//!   triangle): every sample on a drawn part's side is valid and within the
//!   tolerance of that part's surface, its depth interpolated affinely over
//!   the pixel grid; every sample on a void side is invalid; and no
//!   segmented full-resolution triangle lies wholly on a drawn side. The
//!   outline's position is kept to within `BAND` (one) sample: a sample that
//!   close to the cut may fit either part, or be in the jump (every
//!   full-resolution triangle around it segmented: a mixed sample, or a
//!   one-sample hole, which no surface holds, as no emitted triangle holds
//!   it without cuts). A straight cut through a staircase outline, or
//!   through a jump spread over mixed samples, needs this. The largest
//!   deviation is the triangle's error as a cut (`cut_errors.rs`).
//! - **A wholly segmented triangle** may be cut too, where a cut draws a
//!   valid corner it holds (at a padded border); otherwise it is dropped.

use glam::DVec3;

use super::flags::Flags;
use super::grid::{cell_half, Grid, Pt};

/// How far from the cut, in samples, a sample may lie on the side that is
/// not its own: an outline's position is kept to within this.
pub(crate) const BAND: f64 = 1.0;

/// How far, as a share of its last sample's depth, a side's depth may move
/// from that sample to its crossing ([`Samples::side_depth`]).
const MAX_REACH: f64 = 0.05;

/// The samples a cut reads: the grid, its depths (0 where invalid) and
/// the segmentation flags.
#[derive(Clone, Copy)]
pub(crate) struct Samples<'a> {
    pub grid: Grid,
    pub z: &'a [f32],
    pub flags: &'a [Flags],
}

/// What one edge of a triangle holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Crossing {
    None,
    /// One run of consecutive jumping steps, `first..=last` counted from
    /// the edge's first end.
    One(u32, u32),
    Many,
}

/// A triangle drawn as two parts separated by one straight cut, as
/// protocol 7 carries it: both ends place its crossings and parts by one
/// function.
pub use dmesh_proto::compact::CutTriangle;

/// A cut of one hierarchy triangle and its largest deviation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fit {
    pub cut: CutTriangle,
    /// The largest `|z - z_part|` over the valid samples of the drawn parts.
    pub deviation: f64,
}

#[inline]
fn valid(z: f32) -> bool {
    z > 0.0
}

impl Samples<'_> {
    #[inline]
    fn depth(&self, p: Pt) -> f32 {
        self.z[self.grid.index(p)]
    }

    /// True when the unit step `s-t` (adjacent along a row, a column or a
    /// cell diagonal) jumps: validity changes, or both are valid and every
    /// full-resolution triangle with `s-t` as an edge is segmented.
    fn jumps(&self, s: Pt, t: Pt) -> bool {
        let (vs, vt) = (valid(self.depth(s)), valid(self.depth(t)));
        if vs != vt {
            return true;
        }
        if !vs {
            return false;
        }
        let g = &self.grid;
        let seg = |c: Pt, h: usize| self.flags[g.index(c)].cell(h);
        let (x0, y0) = (s.0.min(t.0), s.1.min(t.1));
        if s.0 != t.0 && s.1 != t.1 {
            // A cell diagonal: both halves of that cell share it.
            return seg((x0, y0), 0) && seg((x0, y0), 1);
        }
        // A row or column step: one half of each cell on either side.
        let cells: [Option<Pt>; 2] = if s.1 == t.1 {
            [
                y0.checked_sub(1).map(|y| (x0, y)),
                (y0 + 1 < g.gh()).then_some((x0, y0)),
            ]
        } else {
            [
                x0.checked_sub(1).map(|x| (x, y0)),
                (x0 + 1 < g.gw()).then_some((x0, y0)),
            ]
        };
        // A side belongs to the half whose apex is its corner off the
        // cell's diagonal.
        let apex = if on_diagonal(s) { t } else { s };
        cells.into_iter().flatten().all(|c| seg(c, cell_half(c, apex)))
    }

    /// The crossings on the lattice edge `p-q`, counted from `p`: a run of
    /// consecutive jumping steps (a jump spread over mixed samples) is one.
    fn crossing(&self, p: Pt, q: Pt) -> Crossing {
        let (n, step) = steps(p, q);
        let mut found = Crossing::None;
        let mut s = p;
        for k in 0..n {
            let t = offset(s, step);
            if self.jumps(s, t) {
                found = match found {
                    Crossing::None => Crossing::One(k, k),
                    Crossing::One(first, last) if last + 1 == k => Crossing::One(first, k),
                    _ => return Crossing::Many,
                };
            }
            s = t;
        }
        found
    }

    /// The depths at a crossing of the steps `first..=last` of the edge
    /// `p-q`: on `p`'s side and on `q`'s. Computed from the edge's
    /// canonical direction (the smaller grid index first), so both
    /// triangles sharing the edge get the same bits.
    fn crossing_depths(&self, p: Pt, q: Pt, (first, last): (u32, u32)) -> (f32, f32) {
        let (n, _) = steps(p, q);
        if self.grid.index(p) > self.grid.index(q) {
            let (zq, zp) = self.crossing_depths(q, p, (n - 1 - last, n - 1 - first));
            return (zp, zq);
        }
        let at = crossing_at((first, last));
        (
            self.side_depth(p, q, first, at - 2 * first),
            self.side_depth(q, p, n - 1 - last, 2 * (last + 1) - at),
        )
    }

    /// True when every full-resolution triangle with `s` as a corner is
    /// segmented: the sample lies in a jump, on no surface.
    fn in_jump(&self, (x, y): Pt) -> bool {
        let g = &self.grid;
        let cells = [
            (x.wrapping_sub(1), y.wrapping_sub(1)),
            (x, y.wrapping_sub(1)),
            (x.wrapping_sub(1), y),
            (x, y),
        ];
        let seg = |c: Pt, h: usize| self.flags[g.index(c)].cell(h);
        cells
            .into_iter()
            .filter(|&(cx, cy)| cx < g.gw() - 1 && cy < g.gh() - 1)
            .all(|c| {
                // A corner on the cell's diagonal is in both halves, an
                // apex in its own.
                if on_diagonal((x, y)) {
                    seg(c, 0) && seg(c, 1)
                } else {
                    seg(c, cell_half(c, (x, y)))
                }
            })
    }

    /// The depth on `p`'s side of a crossing `half` half steps past the
    /// last sample on its side, `k` steps from `p` along `p-q`: the line
    /// from `p` through that sample, continued to the crossing, moving at
    /// most [`MAX_REACH`] of that sample's depth: a surface seen at a
    /// grazing angle (a floor towards its horizon) continues no further in
    /// depth than a part's samples can vouch for, since the samples within
    /// [`BAND`] of the cut do not hold its crossings. 0 when that side is
    /// invalid.
    fn side_depth(&self, p: Pt, q: Pt, k: u32, half: u32) -> f32 {
        let (_, step) = steps(p, q);
        let zp = self.depth(p);
        let zk = self.depth(offset_by(p, step, k));
        if !(valid(zp) && valid(zk)) {
            return 0.0;
        }
        if k == 0 || half == 0 {
            return zk;
        }
        let (zp, zk) = (f64::from(zp), f64::from(zk));
        let z = zk + 0.5 * f64::from(half) * (zk - zp) / f64::from(k);
        z.clamp(zk * (1.0 - MAX_REACH), zk * (1.0 + MAX_REACH)) as f32
    }

    /// The cut of the triangle `tri` (lattice corners), if its edges allow
    /// one, with its largest deviation; `None` when it cannot be cut, or a
    /// cut would drop a valid sample, draw over an invalid one, or draw a
    /// segmented full-resolution triangle whole.
    pub(crate) fn fit(&self, tri: [Pt; 3]) -> Option<Fit> {
        // Orient as the extraction emits: negative 2D cross product.
        let tri = if cross2(tri[0], tri[1], tri[2]) > 0 {
            [tri[1], tri[0], tri[2]]
        } else {
            tri
        };
        let edges = [0, 1, 2].map(|e| self.crossing(tri[e], tri[(e + 1) % 3]));
        if edges.contains(&Crossing::Many) {
            return None;
        }
        // The lone corner `l` sits between the two crossed edges: edge
        // `l-1 -> l` and edge `l -> l+1`.
        let crossed: Vec<usize> = (0..3).filter(|&e| edges[e] != Crossing::None).collect();
        let &[e0, e1] = crossed.as_slice() else {
            return None;
        };
        let lone = if (e0 + 1) % 3 == e1 { e1 } else { e0 };
        let (p0, p1, p2) = (tri[lone], tri[(lone + 1) % 3], tri[(lone + 2) % 3]);
        // The runs from the lone corner: along its outgoing edge as found,
        // along its incoming one reversed.
        let run = |e: usize| match edges[e] {
            Crossing::One(first, last) => Some((first, last)),
            _ => None,
        };
        let ka = run(lone)?;
        let (n2, _) = steps(p0, p2);
        let kb = run((lone + 2) % 3).map(|(first, last)| (n2 - 1 - last, n2 - 1 - first))?;
        let (za0, za1) = self.crossing_depths(p0, p1, ka);
        let (zb0, zb2) = self.crossing_depths(p0, p2, kb);
        let (z0, z1, z2) = (self.depth(p0), self.depth(p1), self.depth(p2));
        // Orientation is kept by a lone corner's rotation; the other
        // corners' sides are valid alike (no jump along p1-p2).
        let cut = CutTriangle {
            corners: [p0, p1, p2].map(|(x, y)| [x as u16, y as u16]),
            at: [crossing_at(ka) as u16, crossing_at(kb) as u16],
            lone: valid(z0).then_some([z0, za0, zb0]),
            other: (valid(z1) && valid(z2)).then_some([za1, z1, z2, zb2]),
        };
        if cut.drawn() == 0 {
            return None;
        }
        let deviation = self.check(&cut, [p0, p1, p2])?;
        Some(Fit { cut, deviation })
    }

    /// The largest deviation of the valid samples under `cut`'s parts, or
    /// `None` when the cut breaks a rule (see [`Self::fit`]).
    fn check(&self, cut: &CutTriangle, [p0, p1, p2]: [Pt; 3]) -> Option<f64> {
        let [a, b] = cut.crossings().map(|[x, y]| (x, y));
        let f = |p: Pt| (f64::from(p.0), f64::from(p.1));
        // Which side of the line a-b a point is on, as the lone corner's
        // (> 0), the other's (< 0) or on it (0).
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let lone_sign = side(a, b, f(p0)).signum() / len;
        // Signed distance from the cut in samples, positive on the lone side.
        let which = |q: (f64, f64)| side(a, b, q) * lone_sign;
        let parts: Vec<[DVec3; 3]> = cut.all_parts().map(|t| t.map(DVec3::from_array)).collect();
        let lone_part = cut.lone.map(|_| parts[0]);
        let other_parts = cut.other.map(|_| {
            let o = usize::from(cut.lone.is_some());
            [parts[o], parts[o + 1]]
        });
        let mut worst = 0.0f64;
        let mut ok = true;
        for_each_sample([p0, p1, p2], |s| {
            if !ok {
                return;
            }
            let q = f(s);
            let z = self.depth(s);
            let on_lone = |z: f32| match lone_part {
                Some(t) => valid(z).then(|| (f64::from(z) - interpolate(t, q)).abs()),
                None => (!valid(z)).then_some(0.0),
            };
            let on_other = |z: f32| match other_parts {
                Some([t0, t1]) => valid(z).then(|| {
                    // The quadrilateral's diagonal runs from crossing a to
                    // p2; a crossing on a corner leaves one of its
                    // triangles without area, and the other holds it all.
                    let t = if area2(t0) == 0.0 {
                        t1
                    } else if area2(t1) == 0.0 || side(a, f(p2), q) * side(a, f(p2), f(p1)) >= 0.0 {
                        t0
                    } else {
                        t1
                    };
                    (f64::from(z) - interpolate(t, q)).abs()
                }),
                None => (!valid(z)).then_some(0.0),
            };
            let w = which(q);
            let d = if w > BAND {
                on_lone(z)
            } else if w < -BAND {
                on_other(z)
            } else {
                match (on_lone(z), on_other(z)) {
                    (Some(x), Some(y)) => Some(x.min(y)),
                    // Near the cut, a sample in the jump (a mixed sample,
                    // a one-sample hole) belongs to neither surface.
                    (None, None) if self.in_jump(s) => Some(0.0),
                    (x, y) => x.or(y),
                }
            };
            match d {
                Some(d) => worst = worst.max(d),
                None => ok = false,
            }
        });
        if !ok {
            return None;
        }
        // No segmented full-resolution triangle wholly on a drawn side.
        let g = &self.grid;
        let (x0, y0) = (p0.0.min(p1.0).min(p2.0), p0.1.min(p1.1).min(p2.1));
        let (x1, y1) = (p0.0.max(p1.0).max(p2.0), p0.1.max(p1.1).max(p2.1));
        for cy in y0..y1 {
            for cx in x0..x1 {
                let fl = self.flags[g.index((cx, cy))];
                for h in 0..2 {
                    if !fl.cell(h) {
                        continue;
                    }
                    let t = g.cell_triangle((cx, cy), h);
                    let centre = (
                        (f64::from(t[0].0) + f64::from(t[1].0) + f64::from(t[2].0)) / 3.0,
                        (f64::from(t[0].1) + f64::from(t[1].1) + f64::from(t[2].1)) / 3.0,
                    );
                    if !inside([f(p0), f(p1), f(p2)], centre) {
                        continue;
                    }
                    let sides = t.map(|c| which(f(c)));
                    let drawn_lone = cut.lone.is_some() && sides.iter().all(|&w| w > BAND);
                    let drawn_other = cut.other.is_some() && sides.iter().all(|&w| w < -BAND);
                    if drawn_lone || drawn_other {
                        return None;
                    }
                }
            }
        }
        Some(worst)
    }

    /// The largest `|z - z_lin|` over the samples of the triangle `tri`,
    /// its corners' depths interpolated affinely over the pixel grid (an
    /// unflagged triangle: every sample valid).
    pub(crate) fn plane_deviation(&self, tri: [Pt; 3]) -> f64 {
        let f = |p: Pt| DVec3::new(f64::from(p.0), f64::from(p.1), f64::from(self.depth(p)));
        let t = tri.map(f);
        let mut worst = 0.0f64;
        for_each_sample(tri, |s| {
            let q = (f64::from(s.0), f64::from(s.1));
            worst = worst.max((f64::from(self.depth(s)) - interpolate(t, q)).abs());
        });
        worst
    }
}

/// True when the lattice point is on the diagonal of every cell it is a
/// corner of: a cell's diagonal joins its corners whose coordinates are both
/// odd or both even (`Grid::cell`).
fn on_diagonal((x, y): Pt) -> bool {
    x % 2 == y % 2
}

/// Where a crossing of the steps `first..=last` of an edge lies, in half
/// steps from the edge's first end: the run's middle.
fn crossing_at((first, last): (u32, u32)) -> u32 {
    first + last + 1
}

/// The unit steps of the lattice edge `p-q`: how many, and each one's
/// `(dx, dy)` in -1..=1.
fn steps(p: Pt, q: Pt) -> (u32, (i32, i32)) {
    let (dx, dy) = (i64::from(q.0) - i64::from(p.0), i64::from(q.1) - i64::from(p.1));
    let n = dx.abs().max(dy.abs()).max(1);
    (n as u32, (dx.signum() as i32, dy.signum() as i32))
}

fn offset(s: Pt, (dx, dy): (i32, i32)) -> Pt {
    (s.0.wrapping_add_signed(dx), s.1.wrapping_add_signed(dy))
}

fn offset_by(s: Pt, (dx, dy): (i32, i32), k: u32) -> Pt {
    let k = k as i32;
    (s.0.wrapping_add_signed(dx * k), s.1.wrapping_add_signed(dy * k))
}

/// Twice the signed area of `a b c` in grid coordinates.
fn cross2(a: Pt, b: Pt, c: Pt) -> i64 {
    let (ax, ay) = (i64::from(a.0), i64::from(a.1));
    (i64::from(b.0) - ax) * (i64::from(c.1) - ay) - (i64::from(b.1) - ay) * (i64::from(c.0) - ax)
}

/// Which side of the line `a-b` the point `q` is on (signed, unnormalised).
fn side(a: (f64, f64), b: (f64, f64), q: (f64, f64)) -> f64 {
    (b.0 - a.0) * (q.1 - a.1) - (b.1 - a.1) * (q.0 - a.0)
}

/// Twice the signed area of a part in `(u, v)`.
fn area2(t: [DVec3; 3]) -> f64 {
    (t[1].x - t[0].x) * (t[2].y - t[0].y) - (t[1].y - t[0].y) * (t[2].x - t[0].x)
}

/// True when `q` lies inside or on the triangle `t`.
fn inside(t: [(f64, f64); 3], q: (f64, f64)) -> bool {
    let s = [side(t[0], t[1], q), side(t[1], t[2], q), side(t[2], t[0], q)];
    s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0)
}

/// The depth at `q` of the triangle `t` (points `(u, v, z)`), affine over
/// the pixel grid; its corners' mean on a degenerate triangle.
fn interpolate(t: [DVec3; 3], q: (f64, f64)) -> f64 {
    let (a, b, c) = (t[0], t[1], t[2]);
    let det = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if det == 0.0 {
        return (a.z + b.z + c.z) / 3.0;
    }
    let wb = ((q.0 - a.x) * (c.y - a.y) - (q.1 - a.y) * (c.x - a.x)) / det;
    let wc = ((b.x - a.x) * (q.1 - a.y) - (b.y - a.y) * (q.0 - a.x)) / det;
    a.z + wb * (b.z - a.z) + wc * (c.z - a.z)
}

/// Calls `f` for every lattice point inside or on the triangle `tri`.
pub(crate) fn for_each_sample(tri: [Pt; 3], mut f: impl FnMut(Pt)) {
    let (x0, y0) = (
        tri[0].0.min(tri[1].0).min(tri[2].0),
        tri[0].1.min(tri[1].1).min(tri[2].1),
    );
    let (x1, y1) = (
        tri[0].0.max(tri[1].0).max(tri[2].0),
        tri[0].1.max(tri[1].1).max(tri[2].1),
    );
    let sign = cross2(tri[0], tri[1], tri[2]).signum();
    for y in y0..=y1 {
        for x in x0..=x1 {
            let p = (x, y);
            let inside = (0..3).all(|e| cross2(tri[e], tri[(e + 1) % 3], p) * sign >= 0);
            if inside {
                f(p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::mesh::grid::Grid;

    /// The parity rule of `jumps` and `in_jump` names the halves of a cell
    /// that have a side, or a corner, as the grid's cells lay them out.
    #[test]
    fn a_sides_half_is_its_odd_corners() {
        let g = Grid::for_image(37, 21);
        for cy in 0..g.gh() - 1 {
            for cx in 0..g.gw() - 1 {
                let c = (cx, cy);
                let corners = [(cx, cy), (cx + 1, cy), (cx + 1, cy + 1), (cx, cy + 1)];
                for k in 0..4 {
                    let (s, t) = (corners[k], corners[(k + 1) % 4]);
                    let apex = if super::on_diagonal(s) { t } else { s };
                    let tri = g.cell_triangle(c, super::cell_half(c, apex));
                    assert!(tri.contains(&s) && tri.contains(&t), "cell {c:?} side {s:?}-{t:?}");
                    // A corner on the diagonal is in both halves, an apex
                    // in the half `cell_half` names only.
                    for p in [s, t] {
                        let halves: Vec<usize> = (0..2).filter(|&h| g.cell_triangle(c, h).contains(&p)).collect();
                        let expected = if super::on_diagonal(p) {
                            vec![0, 1]
                        } else {
                            vec![super::cell_half(c, p)]
                        };
                        assert_eq!(halves, expected, "cell {c:?} corner {p:?}");
                    }
                }
            }
        }
    }
}
