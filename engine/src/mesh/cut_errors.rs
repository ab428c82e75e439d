//! The saturated errors of an extraction that cuts outlines (`cut.rs`):
//! per split vertex, the largest deviation its diamond's halves would have
//! if drawn whole or cut, nested over the hierarchy so that selection stays
//! monotone (DMesh Sec. 4.2-4.3 with Lindstrom and Pascucci's saturation).
//!
//! The build's errors (`levels.rs`) count a partly segmented half's
//! footprint, and the border's vertices are forced (`border.rs`): both
//! make an extraction refine along outlines down to single cells, which is
//! what a cut replaces. Here a vertex's own error is, over its halves:
//! - a fully segmented half: the largest deviation of its cut, when one
//!   draws a valid corner it holds (at a padded border), else 0 (nothing
//!   of it is drawn);
//! - an unflagged half: the largest `|z - z_lin|` over its samples;
//! - a partly segmented half: the largest deviation of its cut
//!   ([`Samples::fit`]), or [`FORCED`] when it has no cut (always split,
//!   as the outline refinement splits it).
//!
//! and its saturated error the largest of its own and those of the
//! vertices that depend on it (the midpoints of its halves' legs), so a
//! vertex left out leaves both halves drawable within the tolerance. Only
//! vertices whose subtree holds a segmented triangle or the border are
//! computed this way ("dirty"); everywhere else the build's saturated error is
//! already the geometric one, and is kept. A vertex below which some half
//! has no cut is forced without computing its own error: the saturation
//! would force it anyway.

use super::border::FORCED;
use super::cut::{CutTriangle, Samples};
use super::grid::{Kind, Pt};
use super::levels::round_up;

/// What a cutting extraction selects and cuts by.
#[derive(Clone, Debug)]
pub(crate) struct CutErrors {
    /// The saturated squared errors, one per grid vertex (root corners 0).
    pub err2: Vec<f32>,
    /// Every segmented half fitted here, by `2 * vertex index + half`,
    /// sorted, with its cut's place in `cuts` (`NO_CUT`: it has none): the
    /// walk takes a left-out half's cut from here instead of fitting it
    /// again. Most halves have none, so the cuts are kept apart.
    fitted: Vec<(u32, u32)>,
    cuts: Vec<CutTriangle>,
}

/// [`CutErrors::fitted`]'s place of a half without a cut.
const NO_CUT: u32 = u32::MAX;

impl CutErrors {
    /// The cut of half `half` of split vertex `vi`'s diamond, when it was
    /// fitted here.
    pub(crate) fn fit(&self, vi: usize, half: usize) -> Option<Option<CutTriangle>> {
        let key = (2 * vi + half) as u32;
        let k = self.fitted.binary_search_by_key(&key, |f| f.0).ok()?;
        Some(self.cuts.get(self.fitted[k].1 as usize).copied())
    }

    /// Heap bytes kept.
    pub(crate) fn heap_bytes(&self) -> usize {
        4 * self.err2.capacity() + 8 * self.fitted.capacity() + Self::CUT_BYTES * self.cuts.capacity()
    }

    /// Heap bytes of one segmented half fitted, with its cut.
    pub(crate) const CUT_BYTES: usize = 8 + std::mem::size_of::<CutTriangle>();
}

/// The saturated squared errors of a cutting extraction, one per grid
/// vertex (root corners 0), with the cuts fitted on the way. A partly
/// segmented half that has no cut is forced, unless its hypotenuse spans
/// at most `drop_span` samples: then its own error is 0 and, left
/// unsplit, it is dropped whole.
pub(crate) fn cut_errors(samples: Samples<'_>, err2: &[f32], drop_span: u32) -> CutErrors {
    let g = samples.grid;
    let (mut fitted, mut cuts): (Vec<(u32, u32)>, Vec<CutTriangle>) = (Vec::new(), Vec::new());
    let (gw, gh) = (g.gw(), g.gh());
    // `out` holds the dependents' largest error until a vertex is done.
    let mut out = vec![0.0f32; g.len()];
    let mut dirty = vec![false; g.len()];
    let mut visit = |v: Pt| {
        let vi = g.index(v);
        let Some(d) = g.diamond(v) else {
            return;
        };
        let fl = samples.flags[vi];
        // Any segmented half: a partial one's cut, or a wholly segmented
        // one's (at a border), decides its error, not the build's.
        let segmented = fl.half(0).any || fl.half(1).any;
        let is_dirty = dirty[vi] || segmented || err2[vi] == FORCED;
        let e = if !is_dirty {
            err2[vi]
        } else if out[vi] == FORCED {
            FORCED
        } else {
            let mut e = out[vi];
            for (h, apex) in d.apex.into_iter().enumerate() {
                if e == FORCED || !g.contains(apex.0, apex.1) {
                    continue;
                }
                let tri = [d.a, d.b, apex].map(|(x, y)| (x as u32, y as u32));
                let half = fl.half(h);
                let mut fit = || {
                    let fit = samples.fit(tri);
                    let place = fit.as_ref().map_or(NO_CUT, |f| {
                        cuts.push(f.cut);
                        (cuts.len() - 1) as u32
                    });
                    fitted.push(((2 * vi + h) as u32, place));
                    fit
                };
                let own = if half.all {
                    // Dropped, unless a cut draws a valid corner of it.
                    fit().map_or(0.0, |fit| round_up(fit.deviation.powi(2)))
                } else if !half.any {
                    round_up(samples.plane_deviation(tri).powi(2))
                } else {
                    let span = d.a.0.abs_diff(d.b.0).max(d.a.1.abs_diff(d.b.1));
                    let none = if span <= u64::from(drop_span) { 0.0 } else { FORCED };
                    fit().map_or(none, |fit| round_up(fit.deviation.powi(2)))
                };
                e = e.max(own);
            }
            e
        };
        out[vi] = e;
        for (x, y) in d.apex {
            if g.contains(x, y) {
                let p = (x as u32, y as u32);
                if g.kind(p) != Kind::Root {
                    let pi = g.index(p);
                    out[pi] = out[pi].max(e);
                    dirty[pi] |= is_dirty;
                }
            }
        }
    };
    // Finest first: at each scale h the edge midpoints, then the centres
    // (a centre's dependents are the edge midpoints of its scale).
    for t in 0..g.k {
        let h = 1u32 << t;
        for y in (0..gh).step_by(2 * h as usize) {
            for x in (h..gw).step_by(2 * h as usize) {
                visit((x, y));
            }
        }
        for y in (h..gh).step_by(2 * h as usize) {
            for x in (0..gw).step_by(2 * h as usize) {
                visit((x, y));
            }
        }
        for y in (h..gh).step_by(2 * h as usize) {
            for x in (h..gw).step_by(2 * h as usize) {
                visit((x, y));
            }
        }
    }
    fitted.sort_unstable_by_key(|f| f.0);
    fitted.shrink_to_fit();
    cuts.shrink_to_fit();
    CutErrors {
        err2: out,
        fitted,
        cuts,
    }
}
