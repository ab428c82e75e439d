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
use super::cut::{CutTriangle, Fit, Samples};
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
///
/// The vertices go finest first in phases whose vertices depend on none
/// of the phase's own: at each scale the edge midpoints, then the centres
/// (a centre's dependents are its scale's edge midpoints). Each phase
/// first lists the segmented halves it will fit, fits them (on two
/// threads with `two_threads`: the fits are most of the time), then
/// saturates in order: the same errors and cuts either way.
pub(crate) fn cut_errors(samples: Samples<'_>, err2: &[f32], drop_span: u32, two_threads: bool) -> CutErrors {
    let g = samples.grid;
    let (mut fitted, mut cuts): (Vec<(u32, u32)>, Vec<CutTriangle>) = (Vec::new(), Vec::new());
    let (gw, gh) = (g.gw(), g.gh());
    // `out` holds the dependents' largest error until a vertex is done.
    let mut out = vec![0.0f32; g.len()];
    let mut dirty = vec![false; g.len()];
    // A vertex's diamond, flags, and whether it is computed here (dirty,
    // and not forced by a dependent).
    let state = |v: Pt, out: &[f32], dirty: &[bool]| {
        let vi = g.index(v);
        let d = g.diamond(v)?;
        let fl = samples.flags[vi];
        // Any segmented half: a partial one's cut, or a wholly segmented
        // one's (at a border), decides its error, not the build's.
        let segmented = fl.half(0).any || fl.half(1).any;
        let is_dirty = dirty[vi] || segmented || err2[vi] == FORCED;
        Some((vi, d, fl, is_dirty, is_dirty && out[vi] != FORCED))
    };
    let halves = |d: super::grid::Diamond| {
        d.apex
            .into_iter()
            .enumerate()
            .filter(move |(_, apex)| g.contains(apex.0, apex.1))
            .map(move |(h, apex)| (h, [d.a, d.b, apex].map(|(x, y)| (x as u32, y as u32))))
    };
    let mut jobs: Vec<[Pt; 3]> = Vec::new();
    for t in 0..g.k {
        for centres in [false, true] {
            let phase = || phase_points(gw, gh, t, centres);
            // The segmented halves this phase fits.
            jobs.clear();
            for v in phase() {
                // Only segmented halves are fitted: most vertices have none.
                let fl = samples.flags[g.index(v)];
                if !(fl.half(0).any || fl.half(1).any) {
                    continue;
                }
                if let Some((_, d, fl, _, true)) = state(v, &out, &dirty) {
                    jobs.extend(halves(d).filter(|&(h, _)| fl.half(h).any).map(|(_, tri)| tri));
                }
            }
            let mut fits = fit_all(samples, &jobs, two_threads).into_iter();
            for v in phase() {
                let Some((vi, d, fl, is_dirty, computed)) = state(v, &out, &dirty) else {
                    continue;
                };
                let e = if !is_dirty {
                    err2[vi]
                } else if !computed {
                    FORCED
                } else {
                    let mut e = out[vi];
                    for (h, tri) in halves(d) {
                        let half = fl.half(h);
                        let fit = if half.any {
                            let fit = fits.next().flatten();
                            let place = fit.as_ref().map_or(NO_CUT, |f| {
                                cuts.push(f.cut);
                                (cuts.len() - 1) as u32
                            });
                            fitted.push(((2 * vi + h) as u32, place));
                            fit
                        } else {
                            None
                        };
                        if e == FORCED {
                            continue;
                        }
                        let own = if half.all {
                            // Dropped, unless a cut draws a valid corner of it.
                            fit.map_or(0.0, |fit| round_up(fit.deviation.powi(2)))
                        } else if !half.any {
                            round_up(samples.plane_deviation(tri).powi(2))
                        } else {
                            let span = d.a.0.abs_diff(d.b.0).max(d.a.1.abs_diff(d.b.1));
                            let none = if span <= u64::from(drop_span) { 0.0 } else { FORCED };
                            fit.map_or(none, |fit| round_up(fit.deviation.powi(2)))
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
            }
            debug_assert!(fits.next().is_none(), "every planned fit is taken");
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

/// [`Samples::fit`] of each of `jobs`, in order; on two threads with
/// `two_threads` when there are enough of them to pay for one.
fn fit_all(samples: Samples<'_>, jobs: &[[Pt; 3]], two_threads: bool) -> Vec<Option<Fit>> {
    const WORTH_A_THREAD: usize = 512;
    let fit = |part: &[[Pt; 3]]| part.iter().map(|&t| samples.fit(t)).collect::<Vec<_>>();
    if !two_threads || jobs.len() < WORTH_A_THREAD {
        return fit(jobs);
    }
    let (first, second) = jobs.split_at(jobs.len() / 2);
    std::thread::scope(|scope| {
        let later = scope.spawn(|| fit(second));
        let mut fits = fit(first);
        fits.extend(later.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)));
        fits
    })
}

/// The vertices of scale `2^t`: its edge midpoints (rows, then columns), or
/// its centres, on a `gw x gh` grid.
fn phase_points(gw: u32, gh: u32, t: u32, centres: bool) -> impl Iterator<Item = Pt> {
    let h = 1u32 << t;
    let step = 2 * h as usize;
    let rows = move |y0: u32, x0: u32| {
        (y0..gh)
            .step_by(step)
            .flat_map(move |y| (x0..gw).step_by(step).map(move |x| (x, y)))
    };
    let (first, second) = if centres {
        (rows(h, h), None)
    } else {
        (rows(0, h), Some(rows(h, 0)))
    };
    first.chain(second.into_iter().flatten())
}
