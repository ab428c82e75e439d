//! Budgeted level of detail: the finest tolerance whose mesh provably has at
//! most `max_triangles` triangles, chosen from error statistics gathered on
//! a hierarchy's first budgeted request (Qu et al. Sec. 3.4 keep frame
//! times stable with a per-frame work budget; here the budget caps one
//! extraction).
//!
//! The bound. Extraction starts from two triangles per root quad and every
//! selected split vertex adds at most two (it splits the one or two halves of
//! its diamond), so `triangles <= 2 m n + 2 * selected`. Selection is
//! monotone (`select.rs`), so the selected set is exactly the vertices that
//! pass the test, with nothing added for conformity.
//!
//! - Static, `e^2 > epsilon^2`: a histogram of the saturated squared errors
//!   (bucketed by the top bits of their f32 pattern, which orders
//!   non-negative floats) counts the vertices above any bucket boundary, so
//!   the smallest boundary whose count fits gives `epsilon`.
//! - View-dependent (Eq. 4 with nested spheres), perspective: a vertex is
//!   selected only if `|p - E| - r <= 0` or `e > tau (|p - E| - r) / f`. The
//!   spheres nest, so `|p - E| - r` of any vertex is at least the smallest
//!   value `d` over a *frontier* (the centres of one level, ancestors of
//!   every finer vertex). Counting every vertex down to the frontier as
//!   selected and the finer ones when `e > tau d / f`, the histogram of the
//!   finer ones gives `tau = f sqrt(boundary) / d`. Coarse frontiers count
//!   few vertices outright but give a small `d`; fine ones the reverse, so
//!   every level from the root down to ~1,000 centres is kept and the finest
//!   tau over them wins. When the eye is inside every frontier's spheres no
//!   such bound exists and the budget falls back to the static bound (the
//!   response then says epsilon).
//! - View-dependent, orthographic: `e > tau s`, the static case in pixels.
//!
//! The bound is conservative: it counts far vertices as if they were as near
//! as the nearest frontier sphere and ignores culling and segmentation, so the
//! mesh usually has fewer triangles than allowed. The cost per request is one
//! pass over the frontier and two over 4,096 buckets.

use super::border::FORCED;
use super::grid::{Grid, Pt};
use super::lod::Lod;
use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};

/// Right shift of an f32 bit pattern to its bucket: sign, exponent and 4
/// mantissa bits, 6 % apart in value.
const SHIFT: u32 = 19;
/// Buckets of non-negative finite f32 values (and one past them).
const BUCKETS: usize = (0x7f80_0000u32 >> SHIFT) as usize + 1;
/// Vertices from which the histogram is counted on two threads.
const MANY: usize = 1 << 20;
/// Frontier vertices aimed at.
const FRONTIER: usize = 1024;

/// Error statistics of a hierarchy, gathered once, on its first budgeted
/// request.
#[derive(Clone, Debug, Default)]
pub(crate) struct ErrorStats {
    /// `all[k]`: split vertices whose squared-error bucket is `>= k`.
    all: Vec<u32>,
    /// Frontiers, coarsest first.
    frontiers: Vec<Frontier>,
    /// Triangles of the coarsest mesh: two per root quad, and two per
    /// vertex every mesh selects (along a padded border).
    base: u64,
}

/// The centres of one level and what lies above and below them.
#[derive(Clone, Debug, Default)]
struct Frontier {
    /// The centres.
    centres: Vec<Pt>,
    /// Split vertices down to this level, the centres included.
    coarse: u32,
    /// `fine[k]`: vertices finer than the centres whose bucket is `>= k`.
    fine: Vec<u32>,
}

/// Centres of half-side `h`: odd multiples of `h` in both coordinates.
fn centre_count(grid: Grid, h: u32) -> usize {
    let odd = |n: u32| if n > h { ((n - 1 - h) / (2 * h) + 1) as usize } else { 0 };
    odd(grid.gw()) * odd(grid.gh())
}

/// The half-sides of the frontiers kept, coarsest first: from the root
/// quads' centres down to the finest level or about [`FRONTIER`] centres.
fn frontier_halves(grid: Grid) -> impl Iterator<Item = u32> {
    let last = move |h: u32| h == 1 || grid.len() / (h as usize * h as usize) > FRONTIER;
    std::iter::successors(Some(grid.side() / 2), move |&h| (!last(h)).then_some(h / 2))
}

#[inline]
fn bucket(err2: f32) -> usize {
    ((err2.clamp(0.0, f32::MAX).to_bits() >> SHIFT) as usize).min(BUCKETS - 1)
}

/// Smallest squared error in bucket `k` (`k < BUCKETS`).
fn boundary(k: usize) -> f64 {
    f64::from(f32::from_bits((k as u32) << SHIFT))
}

/// The bucket counts of the squared errors `err2[range]` but the
/// `forced`, and how many are forced.
fn histogram(err2: &[f32], range: std::ops::Range<usize>, forced: &impl Fn(usize) -> bool) -> (Vec<u32>, u64) {
    // Two counts per bucket, one per sample of each pair, so that
    // neighbours with the same bucket (a flat region's) do not wait for
    // each other's increment. Two, not four: the counts (32 KB) then stay
    // in a 48 KB L1 cache, and the statistics stage at 1920 x 1080 took
    // 2.56-2.62 ms against 2.73-2.80 with four (AVX-512 Xeon VM, three
    // alternations).
    let mut counts = vec![[0u32; 2]; BUCKETS];
    let mut forced_count = 0u64;
    for (i, &e) in err2[range.clone()].iter().enumerate() {
        if forced(range.start + i) {
            forced_count += 1;
        } else {
            counts[bucket(e)][i % 2] += 1;
        }
    }
    (counts.iter().map(|c| c.iter().sum()).collect(), forced_count)
}

fn suffix(mut counts: Vec<u32>) -> Vec<u32> {
    // Exactly one more, so that the heap is what `heap_bytes_for` says.
    counts.reserve_exact(1);
    counts.push(0);
    for k in (0..counts.len() - 1).rev() {
        counts[k] += counts[k + 1];
    }
    counts
}

impl ErrorStats {
    /// Gathers the statistics of a built hierarchy from its saturated
    /// squared errors: one pass over them.
    /// With `two_threads`, on grids of a million vertices or more, the
    /// histogram's second half is counted on a second thread (at 1920 x
    /// 1080, 2.3 ms instead of 3.2 for the statistics; at 513 x 513 the
    /// thread cost what it saved).
    pub(crate) fn gather(grid: Grid, err2: &[f32], two_threads: bool) -> Self {
        Self::gather_with(grid, err2, |i| err2[i] == FORCED, two_threads)
    }

    /// [`Self::gather`] with the vertices every mesh selects named by
    /// `forced` (the border's, and `outline.rs`'s), counted in the base.
    pub(crate) fn gather_with(
        grid: Grid,
        err2: &[f32],
        forced: impl Fn(usize) -> bool + Sync,
        two_threads: bool,
    ) -> Self {
        let s = grid.side();
        // Vertices along a padded border are always selected (`border.rs`):
        // they belong to the base, not to any threshold's count.
        let (mut all, mut base_vertices) = if two_threads && err2.len() >= MANY {
            let half = err2.len() / 2;
            std::thread::scope(|scope| {
                let second = scope.spawn(|| histogram(err2, half..err2.len(), &forced));
                let (mut all, forced_first) = histogram(err2, 0..half, &forced);
                let (counts, forced_second) = second.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic));
                for (a, c) in all.iter_mut().zip(counts) {
                    *a += c;
                }
                (all, forced_first + forced_second)
            })
        } else {
            histogram(err2, 0..err2.len(), &forced)
        };
        // Root corners are no split vertices (and never forced).
        for y in (0..grid.gh()).step_by(s as usize) {
            for x in (0..grid.gw()).step_by(s as usize) {
                let i = grid.index((x, y));
                if forced(i) {
                    base_vertices -= 1;
                } else {
                    all[bucket(err2[i])] -= 1;
                }
            }
        }
        // Frontiers: centres of half-side h, from the root quads' down to
        // about FRONTIER of them.
        let mut frontiers = Vec::new();
        for h in frontier_halves(grid) {
            let mut fine = all.clone();
            let mut centres = Vec::with_capacity(centre_count(grid, h));
            let mut coarse = 0;
            for y in (0..grid.gh()).step_by(h as usize) {
                for x in (0..grid.gw()).step_by(h as usize) {
                    let is_root = x % s == 0 && y % s == 0;
                    let (odd_x, odd_y) = (x % (2 * h) == h, y % (2 * h) == h);
                    // Multiples of h are down to this level, except the edge
                    // midpoints of half-length h, which come after it.
                    if is_root || odd_x != odd_y {
                        continue;
                    }
                    let i = grid.index((x, y));
                    let e = err2[i];
                    // A forced vertex is counted in the base already (but
                    // stays a frontier centre: the spheres below nest in it).
                    if !forced(i) {
                        coarse += 1;
                        fine[bucket(e)] -= 1;
                    }
                    if odd_x {
                        centres.push((x, y));
                    }
                }
            }
            debug_assert_eq!(centres.len(), centres.capacity(), "centre_count is exact");
            frontiers.push(Frontier {
                centres,
                coarse,
                fine: suffix(fine),
            });
        }
        Self {
            all: suffix(all),
            frontiers,
            base: 2 * u64::from(grid.m) * u64::from(grid.n) + 2 * base_vertices,
        }
    }

    /// These statistics (gathered with the border's vertices forced) with
    /// the vertices of `forced` (one bit per grid vertex, as `outline.rs`
    /// keeps them) counted in the base as well: what [`Self::gather_with`]
    /// gives with both forced, bit for bit, from a visit of each vertex
    /// `forced` adds instead of a pass over the grid (an outline's first
    /// extraction took a second histogram of every vertex; on a view
    /// without discontinuities it now takes nothing).
    pub(crate) fn with_forced(&self, grid: Grid, err2: &[f32], forced: &[u64]) -> Self {
        let (s, gw) = (grid.side(), grid.gw() as usize);
        let mut out = self.clone();
        // The buckets of the vertices moved to the base: of all of them,
        // and per frontier of those finer than its centres.
        let mut all = vec![0u32; BUCKETS];
        let mut fine = vec![vec![0u32; BUCKETS]; out.frontiers.len()];
        let mut added = 0u64;
        for (w, &word) in forced.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let i = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (x, y) = ((i % gw) as u32, (i / gw) as u32);
                // Root corners are in no count; the border's are in the base.
                if (x % s == 0 && y % s == 0) || err2.get(i).is_none_or(|&e| e == FORCED) {
                    continue;
                }
                added += 1;
                let k = bucket(err2[i]);
                all[k] += 1;
                // Frontier `j` holds centres of half-side `s / 2^(j + 1)`.
                for (j, (frontier, fine)) in out.frontiers.iter_mut().zip(&mut fine).enumerate() {
                    let h = (s / 2) >> j;
                    let (odd_x, odd_y) = (x % (2 * h) == h, y % (2 * h) == h);
                    if x % h == 0 && y % h == 0 && odd_x == odd_y {
                        frontier.coarse -= 1;
                    } else {
                        fine[k] += 1;
                    }
                }
            }
        }
        let remove = |counts: &mut Vec<u32>, moved: Vec<u32>| {
            for (c, m) in counts.iter_mut().zip(suffix(moved)) {
                *c -= m;
            }
        };
        if added > 0 {
            remove(&mut out.all, all);
            for (frontier, fine) in out.frontiers.iter_mut().zip(fine) {
                remove(&mut frontier.fine, fine);
            }
            out.base += 2 * added;
        }
        out
    }

    /// The bytes [`Self::gather`] keeps for `grid`, known before it runs
    /// (a cache charges them when the hierarchy arrives).
    pub(crate) fn heap_bytes_for(grid: Grid) -> usize {
        let counts = 4 * (BUCKETS + 1);
        counts
            + frontier_halves(grid)
                .map(|h| counts + 8 * centre_count(grid, h))
                .sum::<usize>()
    }

    /// Bytes kept.
    pub(crate) fn heap_bytes(&self) -> usize {
        4 * self.all.capacity()
            + self
                .frontiers
                .iter()
                .map(|f| 4 * f.fine.capacity() + 8 * f.centres.capacity())
                .sum::<usize>()
    }

    /// Smallest bucket `k` with `base + 2 * (extra + counts[k]) <= max`
    /// (`counts` is non-increasing, so the fits form a suffix).
    fn first_fit(&self, counts: &[u32], extra: u64, max: u64) -> Option<usize> {
        let k = counts.partition_point(|&c| self.base + 2 * (extra + u64::from(c)) > max);
        (k < counts.len()).then_some(k)
    }

    /// The threshold for squared errors whose selected count fits: `None`
    /// means everything (tolerance 0) fits.
    fn threshold(&self, counts: &[u32], extra: u64, max: u64) -> Option<Option<f64>> {
        let k = self.first_fit(counts, extra, max)?;
        Some(match k {
            0 => None,
            k if k < BUCKETS => Some(boundary(k)),
            _ => Some(f64::from(f32::MAX)),
        })
    }
}

/// Relative margin on a chosen tau so that rounding in the selection test
/// cannot select a vertex the bound did not count.
const MARGIN: f64 = 1e-9;

impl ErrorStats {
    /// Triangles of the coarsest mesh before segmentation: two per root quad,
    /// the smallest budget any request can be given.
    pub(crate) fn coarsest_triangles(&self) -> u64 {
        self.base
    }

    /// The finest level of detail whose mesh has at most `max_triangles`
    /// triangles, for the requesting camera `view` (view-dependent) or none
    /// (static). `eye` is the view's eye in the reference camera's frame,
    /// `sphere` a vertex's position and nested radius there. Fails when
    /// even the coarsest mesh has more.
    pub(crate) fn lod_for_triangles<'v>(
        &self,
        max_triangles: u64,
        view: Option<&'v Camera>,
        eye: impl Fn(&Camera) -> glam::DVec3,
        sphere: impl Fn(Pt) -> (glam::DVec3, f32),
    ) -> Result<Lod<'v>> {
        let st = self;
        let coarsest = || {
            Error::unattainable(format!(
                "max_triangles is {max_triangles}; the coarsest mesh of this view may have up to {} triangles",
                st.base
            ))
        };
        let eps_from = |t: Option<f64>| t.map_or(0.0, |x| x.sqrt() * (1.0 + MARGIN));
        let fallback = || -> Result<Lod<'v>> {
            let t = st.threshold(&st.all, 0, max_triangles).ok_or_else(coarsest)?;
            Ok(Lod::Epsilon(eps_from(t)))
        };
        let Some(view) = view else {
            return fallback();
        };
        match (view.focal_pixels(), view.projection) {
            (Some(f), _) => {
                let eye = eye(view);
                let finest = st
                    .frontiers
                    .iter()
                    .filter_map(|fr| {
                        let d = fr
                            .centres
                            .iter()
                            .map(|&p| {
                                let (position, radius) = sphere(p);
                                (position - eye).length() - f64::from(radius)
                            })
                            .fold(f64::INFINITY, f64::min);
                        if !(d > 0.0 && d.is_finite()) {
                            return None;
                        }
                        let t = st.threshold(&fr.fine, u64::from(fr.coarse), max_triangles)?;
                        // Finite even for a huge focal length over a tiny distance.
                        Some((eps_from(t) * f / d).min(f64::MAX))
                    })
                    .fold(f64::INFINITY, f64::min);
                if finest.is_finite() {
                    Ok(Lod::Tau { tau: finest, view })
                } else {
                    fallback()
                }
            }
            (None, Projection::Orthographic { sx, sy, .. }) => {
                let t = st.threshold(&st.all, 0, max_triangles).ok_or_else(coarsest)?;
                Ok(Lod::Tau {
                    tau: (eps_from(t) / sx.min(sy)).min(f64::MAX),
                    view,
                })
            }
            (None, Projection::Perspective { .. }) => fallback(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bytes_kept_are_known_before_the_gathering() {
        for (w, h) in [(2, 2), (3, 700), (64, 65), (513, 513), (695, 555), (1920, 1080)] {
            let grid = Grid::for_image(w, h);
            let err2: Vec<f32> = (0..grid.len()).map(|i| (i % 1000) as f32).collect();
            let stats = ErrorStats::gather(grid, &err2, false);
            assert_eq!(stats.heap_bytes(), ErrorStats::heap_bytes_for(grid), "{w} x {h}");
            for f in &stats.frontiers {
                assert_eq!(
                    f.centres.len(),
                    f.centres.capacity(),
                    "{w} x {h}: centres counted exactly"
                );
            }
            // And an outline's, cloned from them.
            let forced = vec![u64::MAX; grid.len().div_ceil(64)];
            assert_eq!(stats.with_forced(grid, &err2, &forced).heap_bytes(), stats.heap_bytes());
        }
    }

    #[test]
    fn two_threads_gather_the_statistics_of_one() {
        let grid = Grid::for_image(1025, 1025);
        assert!(grid.len() >= MANY, "the grid takes the two-thread path");
        let mut state = 7u32;
        let err2: Vec<f32> = (0..grid.len())
            .map(|i| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                // Some forced vertices, in both halves.
                if i % 997 == 0 {
                    FORCED
                } else {
                    (state >> 8) as f32 / (1u32 << 24) as f32
                }
            })
            .collect();
        let [one, two] = [false, true].map(|two| format!("{:?}", ErrorStats::gather(grid, &err2, two)));
        assert_eq!(one, two);
        assert!(one.contains("base: "), "{}", &one[..100]);
    }

    #[test]
    fn forcing_more_vertices_gives_what_gathering_with_them_forced_gives() {
        let mut state = 11u32;
        let mut next = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state >> 8
        };
        // Square and oblong grids, several root quads.
        for (w, h) in [(65, 65), (200, 90), (33, 130)] {
            let grid = Grid::for_image(w, h);
            let err2: Vec<f32> = (0..grid.len())
                .map(|_| match next() % 50 {
                    0 => FORCED,
                    1 => 0.0,
                    r => (next() as f32 / 4096.0).powi(r as i32 % 5),
                })
                .collect();
            let plain = ErrorStats::gather(grid, &err2, false);
            for density in [0, 1, 30] {
                // Some vertices forced, roots and border vertices among them.
                let mut forced = vec![0u64; grid.len().div_ceil(64)];
                for i in 0..grid.len() {
                    if next() % 100 < density {
                        forced[i / 64] |= 1 << (i % 64);
                    }
                }
                let bit = |i: usize| forced[i / 64] >> (i % 64) & 1 == 1;
                let gathered = ErrorStats::gather_with(grid, &err2, |i| err2[i] == FORCED || bit(i), false);
                let derived = plain.with_forced(grid, &err2, &forced);
                assert_eq!(format!("{derived:?}"), format!("{gathered:?}"), "{w}x{h}, {density} %");
                if density > 0 {
                    assert!(derived.base > plain.base, "{w}x{h}: some vertices moved to the base");
                }
            }
        }
    }

    #[test]
    fn buckets_order_like_the_values_and_boundaries_start_them() {
        let values = [0.0f32, 1e-30, 1e-6, 0.5, 1.0, 1.06, 3.0, 1e30, f32::MAX];
        for w in values.windows(2) {
            assert!(bucket(w[0]) <= bucket(w[1]), "{w:?}");
        }
        for v in values {
            let k = bucket(v);
            assert!(boundary(k) <= f64::from(v), "{v}");
            if k + 1 < BUCKETS {
                assert!(f64::from(v) < boundary(k + 1), "{v}");
            }
        }
        assert_eq!(bucket(f32::INFINITY), bucket(f32::MAX));
    }

    #[test]
    fn suffix_counts_are_non_increasing() {
        assert_eq!(suffix(vec![1, 0, 2]), vec![3, 2, 2, 0]);
    }
}
