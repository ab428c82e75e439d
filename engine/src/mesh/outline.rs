//! Outlines kept at any level of detail: the coarse triangles that a
//! discontinuity crosses are refined instead of dropped whole, and the
//! triangle budget's bound counts what that refinement forces.
//!
//! DMesh Sec. 5.3 skips a segmented triangle at the extracted resolution,
//! so a coarse triangle that holds one segmented cell is lost with all its
//! valid samples: the foreground's outline erodes by the triangle's size.
//! Here every split vertex at least `finest` samples from its hypotenuse's
//! ends is *forced* when its diamond holds a segmented cell in a half that
//! is not wholly segmented, and so is every vertex it depends on (the
//! apexes of its diamond, up to the roots). The forced set is closed under
//! dependency, and the selection of any tolerance is monotone (`select.rs`),
//! so the selected-or-forced set is monotone too and the mesh conforming.
//! With `finest = 1` the only triangles left out are the segmented cells
//! themselves and the wholly segmented triangles above them; a larger
//! `finest` stops at triangles `2 * finest` samples across, dropped whole
//! as Sec. 5.3 drops them.
//!
//! Refining only the near side (`surface_side.rs`) seeds only the halves
//! that hold the near surface: the far surface's triangles beside an
//! outline are dropped as Sec. 5.3 drops them, and the near surface keeps
//! its outline as finely for fewer triangles. A budget tries each depth on
//! both sides, then on the near side, before the next coarser depth
//! ([`ladder`]).
//!
//! The set does not depend on the level of detail. It is computed once per
//! hierarchy and depth, on the first extraction that asks for it, with the
//! budget's statistics (`budget.rs`) counting the forced vertices in the
//! base as they count the always-refined border: the mesh of any tolerance
//! has at most `2 m n + 2 |forced or border| + 2 |selected, not forced|`
//! triangles, so a budget resolved from these statistics is met with the
//! outlines kept.

use std::sync::OnceLock;

use super::budget::ErrorStats;
use super::cut::Samples;
use super::cut_errors::{cut_errors, CutErrors};
use super::flags::Flags;
use super::grid::{Grid, Kind};
use super::surface_side::surface_halves;

/// The refinement depths kept: triangles 2, 4, ..., 64 samples across.
pub(crate) const DEPTHS: [u32; 6] = [1, 2, 4, 8, 16, 32];

/// One outline refinement: its depth, and whether it refines only the
/// near side of a discontinuity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rung {
    /// Triangles no finer than `2 * finest` samples across are refined.
    pub finest: u32,
    /// Only those that hold the near surface.
    pub near_side: bool,
}

/// The refinements a budget tries, from the most triangles to the fewest:
/// each depth on both sides, then on the near side only (the near surface's
/// outline kept as finely, the far surface beside it dropped in coarser
/// triangles), then the next coarser depth.
pub(crate) fn ladder() -> impl Iterator<Item = Rung> {
    DEPTHS
        .into_iter()
        .flat_map(|finest| [false, true].map(|near_side| Rung { finest, near_side }))
}

/// The refinement after `rung` on the [`ladder`]; `None` after the last
/// (or for a depth not in [`DEPTHS`]): the comparison's fallback.
#[cfg(feature = "baselines")]
pub(crate) fn next_rung(rung: Rung) -> Option<Rung> {
    ladder().skip_while(|&r| r != rung).nth(1)
}

/// The largest share of a triangle budget that forced outline triangles
/// may take: a budget picks the finest depth whose forced triangles fit in
/// it, so that at least the rest is left for the surfaces' interiors.
pub(crate) const OUTLINE_SHARE: f64 = 0.5;

/// One refinement depth's forced vertices and budget statistics.
#[derive(Clone, Debug)]
pub(crate) struct Outline {
    /// Triangles no finer than `2 * finest` samples across are refined.
    pub finest: u32,
    /// Only those that hold the near surface (`surface_side.rs`).
    pub near_side: bool,
    /// One bit per grid vertex: forced.
    pub forced: Vec<u64>,
    /// The budget's statistics with the forced vertices in the base,
    /// derived from the hierarchy's on the first budgeted request
    /// (`Hierarchy::outline_stats`).
    pub stats: OnceLock<ErrorStats>,
}

impl From<&Outline> for Rung {
    fn from(o: &Outline) -> Self {
        Self {
            finest: o.finest,
            near_side: o.near_side,
        }
    }
}

/// The outlines of a hierarchy, one per depth in [`DEPTHS`] and side, each
/// computed on first use.
#[derive(Clone, Debug, Default)]
pub(crate) struct OutlineCache {
    /// Per depth, both sides, then the near side only.
    depths: [OnceLock<Outline>; 2 * DEPTHS.len()],
    /// Which halves hold the surface (`surface_side.rs`), for every depth.
    surface: OnceLock<Vec<u8>>,
    /// The saturated errors of an extraction that cuts outlines instead
    /// (`cut_errors.rs`).
    cut: OnceLock<CutErrors>,
}

/// True when bit `i` of `bits` is set (false past its end).
#[inline]
pub(crate) fn bit(bits: &[u64], i: usize) -> bool {
    bits.get(i / 64).is_some_and(|w| w >> (i % 64) & 1 == 1)
}

impl OutlineCache {
    /// The outline of refinement depth `finest` (rounded up to one of
    /// [`DEPTHS`], at most the coarsest), on both sides of a discontinuity
    /// or on its near side only, computing it on first use from the
    /// hierarchy's grid, depths and flags.
    pub(crate) fn get(&self, rung: Rung, grid: Grid, (z, flags): (&[f32], &[Flags])) -> &Outline {
        let k = DEPTHS
            .iter()
            .position(|&d| d >= rung.finest)
            .unwrap_or(DEPTHS.len() - 1);
        self.depths[2 * k + usize::from(rung.near_side)].get_or_init(|| {
            let surface = rung
                .near_side
                .then(|| &self.surface.get_or_init(|| surface_halves(grid, z, flags))[..]);
            Outline {
                finest: DEPTHS[k],
                near_side: rung.near_side,
                forced: forced_set(grid, flags, surface, DEPTHS[k]),
                stats: OnceLock::new(),
            }
        })
    }

    /// The saturated squared errors of a cutting extraction, computed on
    /// first use from the hierarchy's samples and errors (on two threads
    /// with `two_threads`).
    pub(crate) fn cut(&self, samples: Samples<'_>, err2: &[f32], two_threads: bool) -> &CutErrors {
        self.cut.get_or_init(|| cut_errors(samples, err2, 0, two_threads))
    }

    /// The most heap bytes the outlines of `grid` will keep, each with its
    /// statistics (`stats_bytes` each): every depth on both sides and on
    /// the near side, one bit per grid vertex, the near side's halves, and
    /// the cuts' errors (4 bytes per grid vertex).
    pub(crate) fn heap_bytes_bound(grid: Grid, stats_bytes: usize) -> usize {
        2 * DEPTHS.len() * (8 * grid.len().div_ceil(64) + stats_bytes) + grid.len() + 4 * grid.len()
    }

    /// Heap bytes of the outlines computed so far.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.depths
            .iter()
            .filter_map(OnceLock::get)
            .map(|o| 8 * o.forced.capacity() + o.stats.get().map_or(0, ErrorStats::heap_bytes))
            .sum::<usize>()
            + self.surface.get().map_or(0, Vec::capacity)
            + self.cut.get().map_or(0, CutErrors::heap_bytes)
    }
}

/// The forced vertices of refinement depth `finest`: one pass over the
/// flags for the seeds (with `surface`, only the halves that hold the near
/// surface seed), then their dependencies, each vertex visited once.
fn forced_set(grid: Grid, flags: &[Flags], surface: Option<&[u8]>, finest: u32) -> Vec<u64> {
    let gw = grid.gw() as usize;
    let mut forced = vec![0u64; grid.len().div_ceil(64)];
    // Partly segmented halves are rare (along discontinuities only): the
    // flags are first tested 64 at a time, in a loop the compiler widens.
    let mut stack: Vec<usize> = Vec::new();
    for (c, chunk) in flags.chunks(64).enumerate() {
        if chunk.iter().fold(0, |any, f| any | f.partial_halves()) == 0 {
            continue;
        }
        stack.extend((c * 64..c * 64 + chunk.len()).filter(|&i| {
            let partial = flags[i].partial_halves();
            let seeds = (0..2).any(|k| partial >> k & 1 == 1 && surface.is_none_or(|holds| holds[i] >> k & 1 == 1));
            seeds
                && match grid.kind(((i % gw) as u32, (i / gw) as u32)) {
                    Kind::Root => false,
                    Kind::Centre { h } | Kind::Edge { h, .. } => h >= finest,
                }
        }));
    }
    while let Some(v) = stack.pop() {
        if bit(&forced, v) {
            continue;
        }
        let pt = ((v % gw) as u32, (v / gw) as u32);
        let Some(d) = grid.diamond(pt) else {
            continue;
        };
        forced[v / 64] |= 1 << (v % 64);
        for (x, y) in d.apex {
            if grid.contains(x, y) {
                let p = (x as u32, y as u32);
                if grid.kind(p) != Kind::Root && !bit(&forced, grid.index(p)) {
                    stack.push(grid.index(p));
                }
            }
        }
    }
    forced
}
