//! A triangle budget with cut outlines (`cut.rs`), after Qu et al. Sec. 3.4's
//! per-frame budget: the finest tolerance whose cut mesh draws at most the
//! budget, each cut triangle counted as the triangles it draws.
//!
//! The refined outlines' budget is resolved from error statistics
//! (`budget.rs`), which bound the triangles of every tolerance. A cut
//! triangle draws one to three triangles, and whether a triangle is cut or
//! split depends on its outline, so those statistics bound nothing here.
//! The budget is met by construction instead: the tolerance is bisected
//! over extractions, and only a mesh whose drawn triangles were counted
//! and found within the budget is returned. Where even the coarsest cut
//! mesh draws more, the uncut outline pieces are dropped up to 2, 4, ...,
//! 64 samples across ([`Outlines::CutOrDrop`]), and past that the outlines
//! are dropped whole ([`Outlines::Dropped`]), each bisected alike; a
//! budget below the coarsest of those is refused, naming what it draws.
//! Each bisection step is one extraction: a budgeted cut request costs
//! about [`STEPS`] of them.

use super::extract::{Mesh, Outlines};
use super::hierarchy::Hierarchy;
use super::lod::Lod;
use super::strips::StripOrder;
use crate::camera::Camera;
use crate::error::{Error, Result};

/// Bisection steps over the tolerance, in log space between [`FINEST`] and
/// [`COARSEST`]: after 20 the bracket spans a factor of 1.00004, finer than
/// the tolerances whose meshes differ.
pub(crate) const STEPS: usize = 20;

/// The finest tolerance tried (metres or pixels): below it a mesh is full
/// resolution in practice.
const FINEST: f64 = 1e-9;

/// The coarsest tolerance tried (metres or pixels): every error is below it.
const COARSEST: f64 = 1e9;

impl Hierarchy {
    /// The mesh of the finest tolerance (view-dependent for `view`, else
    /// static) whose cut mesh draws at most `max` triangles.
    pub(crate) fn cut_for_triangles(
        &self,
        max: u64,
        view: Option<&Camera>,
        strips: StripOrder,
        outlines: Outlines,
    ) -> Result<Mesh> {
        let lod = |t: f64| match view {
            Some(view) => Lod::Tau { tau: t, view },
            None => Lod::Epsilon(t),
        };
        let fits = |m: &Mesh| m.drawn_triangles() as u64 <= max;
        let coarsest = self.extract_as(lod(COARSEST), strips, outlines)?;
        if !fits(&coarsest) {
            let next = match (outlines, outlines.coarser_cut()) {
                (_, Some(next)) => next,
                (Outlines::CutOrDrop(_), None) => Outlines::Dropped,
                _ => {
                    return Err(Error::unattainable(format!(
                        "max_triangles is {max}; the coarsest mesh of this view draws {} triangles",
                        coarsest.drawn_triangles()
                    )))
                }
            };
            return self.cut_for_triangles(max, view, strips, next);
        }
        let finest = self.extract_as(lod(FINEST), strips, outlines)?;
        if fits(&finest) {
            return Ok(finest);
        }
        // `hi` always fits, `lo` never does.
        let (mut lo, mut hi, mut best) = (FINEST.ln(), COARSEST.ln(), coarsest);
        for _ in 0..STEPS {
            let mid = 0.5 * (lo + hi);
            let mesh = self.extract_as(lod(mid.exp()), strips, outlines)?;
            if fits(&mesh) {
                (hi, best) = (mid, mesh);
            } else {
                lo = mid;
            }
        }
        Ok(best)
    }
}
