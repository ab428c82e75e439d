//! The top-down traversal of an extraction (DMesh Sec. 4.3, 5.3): from the
//! root diamonds down, a triangle is split where the selection (Eq. 3 or
//! Eq. 4) or an outline asks; culled triangles are recorded as spheres for
//! the [`Reach`](crate::mesh::reach::Reach); segmented ones are dropped.

use glam::DVec3;

use crate::mesh::cut::{for_each_sample, CutTriangle};
use crate::mesh::cut_errors::CutErrors;
use crate::mesh::error_metric::norm_bound;
use crate::mesh::grid::{cell_half, half_of, Pt};
use crate::mesh::hierarchy::Hierarchy;
use crate::mesh::outline::bit;
use crate::mesh::select::{PlaneMask, Select, ALL_PLANES};
use crate::mesh::strips::BREAK;

struct Walk<'a, S> {
    mesh: &'a Hierarchy,
    sel: &'a S,
    /// The saturated squared errors the selection reads: the build's, or
    /// a cutting extraction's (`cut_errors.rs`).
    err2: &'a [f32],
    /// Cuts the triangles a discontinuity crosses (`cut.rs`) instead of
    /// dropping them.
    cutting: bool,
    /// The cuts fitted with the cutting errors, taken instead of fitting
    /// again.
    fitted: Option<&'a CutErrors>,
    cuts: Vec<CutTriangle>,
    /// Scratch of [`Self::valid_left_out`]: a triangle's valid samples'
    /// positions, kept between calls.
    valid: Vec<DVec3>,
    /// Vertices split whatever `sel` says (one bit per grid vertex; empty
    /// for none): the outlines' (`outline.rs`).
    forced: &'a [u64],
    tris: Vec<[u32; 3]>,
    dropped: usize,
    /// Smallest [`Select::left_out`] over the left-out vertices with an error.
    clearance: f64,
    /// Culled triangles' spheres in the reference frame.
    culled: Vec<(DVec3, f64)>,
}

/// What a walk found besides its triangles.
pub(super) struct Walked {
    pub(super) dropped: usize,
    /// The triangles drawn as cuts (a cutting walk's only).
    pub(super) cuts: Vec<CutTriangle>,
    pub(super) clearance: f64,
    pub(super) culled: Vec<(DVec3, f64)>,
}

impl<S: Select> Walk<'_, S> {
    fn skip(&mut self) {
        if self.tris.last().is_some_and(|t| *t != BREAK) {
            self.tris.push(BREAK);
        }
    }

    fn emit(&mut self, l: Pt, r: Pt, a: Pt) {
        let g = &self.mesh.grid;
        // Orient so that the 2D cross product in (x right, y down) is negative:
        // the 3D normal then points towards the reference camera.
        let cross = (i64::from(r.0) - i64::from(l.0)) * (i64::from(a.1) - i64::from(l.1))
            - (i64::from(r.1) - i64::from(l.1)) * (i64::from(a.0) - i64::from(l.0));
        let (l, r) = if cross > 0 { (r, l) } else { (l, r) };
        self.tris.push([l, r, a].map(|p| g.index(p) as u32));
    }

    /// Triangle with hypotenuse `l-r` (entered at `l`, left at `r`) and apex
    /// `a`, with their positions; `mask` holds the frustum planes it may cross.
    fn tri(&mut self, (l, pl): (Pt, DVec3), (r, pr): (Pt, DVec3), (a, pa): (Pt, DVec3), mask: PlaneMask) {
        let g = self.mesh.grid;
        if l.0.abs_diff(r.0) == 1 && l.1.abs_diff(r.1) == 1 {
            let cell = (l.0.min(r.0), l.1.min(r.1));
            if self.mesh.flags[g.index(cell)].cell(cell_half(cell, a)) {
                // A full-resolution triangle's samples are its corners,
                // which its cut's parts pass through: any cut is exact.
                self.cut_or_drop([l, r, a], None);
            } else if mask != 0 && {
                let c = 0.5 * (pl + pr);
                let radius = norm_bound(pl - c).max(norm_bound(pa - c));
                let culled = self.sel.cull(c, radius, mask).is_none();
                if culled {
                    self.culled.push((c, radius));
                }
                culled
            } {
                self.skip();
            } else {
                self.emit(l, r, a);
            }
            return;
        }
        let m = ((l.0 + r.0) / 2, (l.1 + r.1) / 2);
        let mi = g.index(m);
        let flags = self.mesh.flags[mi].half(half_of(m, a));
        // A cutting walk goes on into a wholly segmented triangle: a cut
        // may still draw the valid corner it holds (at a padded border).
        if flags.all && !self.cutting {
            self.dropped += 1;
            self.skip();
            return;
        }
        let pm = self.mesh.position(m);
        let radius = self.mesh.radius[mi];
        // Culling stops at triangles 8 samples across: below that a
        // straddling triangle's fringe outside the view costs less to send
        // than to test (the client clips it).
        let mask = if mask == 0 || l.0.abs_diff(r.0).max(l.1.abs_diff(r.1)) < CULL_MIN_SPAN {
            0
        } else {
            let reach = split_sphere(radius, pm, [pl, pr, pa]);
            match self.sel.cull(pm, reach, mask) {
                Some(left) => left,
                None => {
                    self.record_culled((l, pl), (r, pr), (a, pa), (m, pm), reach);
                    self.skip();
                    return;
                }
            }
        };
        let err2 = self.err2[mi];
        if self.sel.active(err2, pm, radius) || bit(self.forced, mi) {
            self.tri((l, pl), (a, pa), (m, pm), mask);
            self.tri((a, pa), (r, pr), (m, pm), mask);
            return;
        }
        if err2 > 0.0 {
            // The nearer of the nested sphere and the valid samples' sphere
            // bounds where the error lies; a cutting walk leaves coarse
            // triangles beside missing samples, whose nested spheres take in
            // their placeholder positions at the reference eye.
            // The valid samples' sphere matters only where the nested one
            // would shorten the clearance: the larger of the two does.
            let nested = self.sel.left_out(pm, radius);
            let left_out = if self.cutting && nested < self.clearance {
                nested.max(self.valid_left_out([l, r, a]))
            } else {
                nested
            };
            self.clearance = self.clearance.min(left_out);
        }
        if flags.any {
            self.cut_or_drop([l, r, a], Some((mi, half_of(m, a))));
        } else {
            self.emit(l, r, a);
        }
    }

    /// A segmented triangle left unsplit: cut when the walk cuts and it has
    /// a cut (the cutting errors make every unsplit one within the
    /// tolerance), else dropped as DMesh Sec. 5.3 drops it.
    /// [`Select::left_out`] of a triangle `tri` a cutting walk leaves
    /// unsplit, from a sphere round its valid samples: where its split
    /// vertex's error lies (the triangle's samples are its subtree's
    /// vertices, and a missing one has none). Either this or the nested
    /// sphere bounds the error's distance from the eye, so the larger
    /// distance does; the nested sphere may take in the placeholder
    /// positions of missing samples, at the reference eye, which would tell
    /// a reach that any camera near the reference eye is upon it.
    fn valid_left_out(&mut self, tri: [Pt; 3]) -> f64 {
        let h = self.mesh;
        let valid = &mut self.valid;
        valid.clear();
        for_each_sample(tri, |p| {
            if h.z[h.grid.index(p)] > 0.0 {
                valid.push(h.position(p));
            }
        });
        if valid.is_empty() {
            return f64::INFINITY;
        }
        let (lo, hi) = valid
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &q| {
                (lo.min(q), hi.max(q))
            });
        let centre = 0.5 * (lo + hi);
        let radius = valid.iter().map(|&q| (q - centre).length()).fold(0.0, f64::max);
        self.sel
            .left_out(centre, radius as f32 * (1.0 + f32::EPSILON) + f32::EPSILON)
    }

    /// `half` names the triangle as half `.1` of split vertex `.0`'s
    /// diamond (cells have none), whose cut the cutting errors fitted.
    fn cut_or_drop(&mut self, tri: [Pt; 3], half: Option<(usize, usize)>) {
        self.skip();
        let cut = if self.cutting {
            let fitted = half.and_then(|(vi, h)| self.fitted?.fit(vi, h));
            fitted.unwrap_or_else(|| self.mesh.samples().fit(tri).map(|f| f.cut))
        } else {
            None
        };
        match cut {
            Some(cut) => self.cuts.push(cut),
            None => self.dropped += 1,
        }
    }

    /// Records the culled triangle `l r a` (split vertex `m`, its sphere's
    /// radius `reach`) for the [`Reach`]: its sphere, or, while that sphere is
    /// large against its distance from the eye (a camera beside it could not
    /// be told apart from one looking at it), its children's.
    fn record_culled(
        &mut self,
        (l, pl): (Pt, DVec3),
        (r, pr): (Pt, DVec3),
        (a, pa): (Pt, DVec3),
        (m, pm): (Pt, DVec3),
        reach: f64,
    ) {
        let span = l.0.abs_diff(r.0).max(l.1.abs_diff(r.1));
        if span < CULL_MIN_SPAN || reach <= NEAR_CULLED * self.sel.left_out(pm, 0.0) {
            self.culled.push((pm, reach));
            return;
        }
        for (x, y) in [((l, pl), (a, pa)), ((a, pa), (r, pr))] {
            let c = ((x.0 .0 + y.0 .0) / 2, (x.0 .1 + y.0 .1) / 2);
            let pc = self.mesh.position(c);
            let reach = split_sphere(self.mesh.radius[self.mesh.grid.index(c)], pc, [x.1, y.1, pm]);
            self.record_culled(x, y, (m, pm), (c, pc), reach);
        }
    }
}

/// The radius of a sphere around a split vertex at `pm` with nested radius
/// `radius` that holds its triangle's `corners` and, by nesting, every sample
/// below.
fn split_sphere(radius: f32, pm: DVec3, corners: [DVec3; 3]) -> f64 {
    corners
        .iter()
        .fold(f64::from(radius), |r, &p| r.max(norm_bound(p - pm)))
}

/// A culled sphere is split while its radius exceeds this fraction of its
/// distance from the eye (so it subtends at most about 15 degrees), and
/// neighbours are merged while the merged one stays within it.
pub(crate) const NEAR_CULLED: f64 = 0.25;

/// Triangles whose hypotenuse spans fewer grid steps than this are not
/// tested against the frustum (their parent straddled it).
const CULL_MIN_SPAN: u32 = 8;

impl Hierarchy {
    /// Walks the hierarchy for `sel`, splitting the `forced` vertices too;
    /// with `cut`, selecting by its errors and cutting the
    /// segmented triangles left unsplit (`cut.rs`).
    pub(super) fn walk<S: Select>(
        &self,
        sel: &S,
        tris: &mut Vec<[u32; 3]>,
        forced: &[u64],
        cut: Option<&CutErrors>,
    ) -> Walked {
        let mut walk = Walk {
            mesh: self,
            sel,
            err2: cut.map_or(&self.err2, |c| &c.err2),
            cutting: cut.is_some(),
            fitted: cut,
            cuts: Vec::new(),
            valid: Vec::new(),
            forced,
            tris: std::mem::take(tris),
            dropped: 0,
            clearance: f64::INFINITY,
            culled: Vec::new(),
        };
        let g = self.grid;
        let s = g.side();
        for qy in 0..g.n {
            for k in 0..g.m {
                let qx = if qy % 2 == 0 { k } else { g.m - 1 - k };
                let c = (qx * s + s / 2, qy * s + s / 2);
                if let Some(d) = g.diamond(c) {
                    let p = (d.a.0 as u32, d.a.1 as u32);
                    let q = (d.b.0 as u32, d.b.1 as u32);
                    let a0 = (d.apex[0].0 as u32, d.apex[0].1 as u32);
                    let a1 = (d.apex[1].0 as u32, d.apex[1].1 as u32);
                    let at = |v: Pt| (v, self.position(v));
                    walk.tri(at(p), at(q), at(a0), ALL_PLANES);
                    walk.tri(at(q), at(p), at(a1), ALL_PLANES);
                }
            }
        }
        *tris = walk.tris;
        Walked {
            dropped: walk.dropped,
            cuts: walk.cuts,
            clearance: walk.clearance,
            culled: walk.culled,
        }
    }
}
