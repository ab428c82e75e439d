//! The depth deviations of the halves of the levels above the finest, as
//! the pass over the levels takes them (DMesh Sec. 4.2; the deviation
//! term is `hierarchy.rs`'s): levels 1 to 3 swept a level at a time
//! (`small_half_sweep.rs`), levels 4 and 5 grid row by grid row
//! (`level_row_scan.rs`), the others half by half (`deviation_f32.rs`),
//! each in f32 within a stated margin above the exact f64 scan
//! (`deviation.rs`). They read only the depths, so a helper thread can
//! compute them ahead of the pass (`hierarchy/passes.rs`).

use super::deviation::{half_rows, max_deviation};
use super::deviation_f32::half_max_deviation_f32;
use super::grid::{Grid, Pt};
use super::level_row_scan::level_row_scan;
use super::levels::round_up;
use super::small_half_sweep::{small_half_deviation2, small_level_deviations};
use super::split_order::{for_each_split, split_count, Bisects, Split};

/// The levels whose halves [`coarse_deviations`] reads grid row by grid
/// row (`level_row_scan.rs`); the others half by half. Medians of twelve
/// builds at 1920 x 1080 on two threads, on a 2 GHz Zen 1, in ms per level
/// (half by half, then by rows): level 3 10.4, 10.5 (12.5 with it in the
/// rows' groups); level 4 8.7-9.0, 7.1-7.4; level 5 8.9-9.0, 5.8-6.3;
/// level 6 5.7-5.8, 6.1-6.2. Level 3's rows are too short to gain, and from
/// level 6 on a half's rows (65 samples and more) are long enough for the
/// prefetchers to follow half by half. At 513 x 513, whose depths stay in
/// cache, the two ways cost the same.
const ROW_SCAN_LEVELS: std::ops::Range<u32> = 4..6;

crate::simd::dispatch! {
    /// The depth deviation of each half of every split vertex of level `g`
    /// (at least 4: levels 1 to 3 come from [`small_deviations`]), squared
    /// and rounded up (0 where a half does not exist), in the order
    /// `Levels::run_coarse` takes them. It reads only the depths, so it
    /// can run on another thread, a level ahead of the pass. Halves that
    /// turn out segmented get a value too, which the pass ignores (it is
    /// finite: invalid samples are 0). Levels 4 and 5 grid row by grid
    /// row, the others half by half ([`ROW_SCAN_LEVELS`]), with AVX2 where
    /// the CPU has it. The deviations go into `out` (whatever it holds), so a build on two
    /// threads can hand the helper memory the calling thread has used.
    pub(crate) fn coarse_deviations(grid: Grid, z: &[f32], g: u32, out: Vec<[f32; 2]>) -> Vec<[f32; 2]> = coarse_deviations_body;
}

crate::simd::dispatch! {
    /// The deviations of levels 1 to 3 as [`coarse_deviations`] gives
    /// them, all from one set of phase planes (`small_half_sweep.rs`),
    /// into `out` (whatever they hold; empty where the grid has no such
    /// level). With AVX2 where the CPU has it.
    pub(crate) fn small_deviations(grid: Grid, z: &[f32], out: [Vec<[f32; 2]>; 3]) -> [Vec<[f32; 2]>; 3] = small_deviations_body;
}

#[inline(always)]
fn small_deviations_body(grid: Grid, z: &[f32], out: [Vec<[f32; 2]>; 3]) -> [Vec<[f32; 2]>; 3] {
    let [mut one, mut two, mut three] = out;
    small_level_deviations(grid, z, [&mut one, &mut two, &mut three]);
    [one, two, three]
}

#[inline(always)]
fn coarse_deviations_body(grid: Grid, z: &[f32], g: u32, mut out: Vec<[f32; 2]>) -> Vec<[f32; 2]> {
    out.clear();
    out.reserve(split_count(grid, g));
    if ROW_SCAN_LEVELS.contains(&g) {
        level_row_scan(grid, z, g, &mut out);
        return out;
    }
    let (gw, h) = (grid.gw() as usize, 1 << g);
    for_each_split(
        grid,
        g..g + 1,
        #[inline(always)]
        |s| {
            let mut pair = [0f32; 2];
            for (d, apex) in pair.iter_mut().zip(s.apex) {
                if let Some(apex) = apex {
                    *d = half_deviation2(z, gw, s, h, apex);
                }
            }
            out.push(pair);
        },
    );
    out
}

/// The squared deviation of the half of `s` with apex `apex`, rounded up:
/// in f32 within a stated margin above the exact value, for the two levels
/// just above the finest in straight code (`small_half_sweep.rs`, nine in
/// ten of these halves), for the coarser ones by rows
/// (`deviation_f32.rs`); the finest level's halves (only the tests' general
/// kernel scans them) exact, by rows.
#[inline(always)]
pub(super) fn half_deviation2(z: &[f32], gw: usize, s: Split, h: u32, apex: Pt) -> f32 {
    let rows = || half_rows(s.v, h, apex, s.bisects == Bisects::Row, s.bisects == Bisects::Diagonal);
    let v = s.v.1 as usize * gw + s.v.0 as usize;
    let dev = match h {
        1 => max_deviation(z, gw, [s.a, s.b, apex], rows()),
        2 => return small_half_deviation2::<2>(z, gw, v, s.small_shape(apex)),
        4 => return small_half_deviation2::<4>(z, gw, v, s.small_shape(apex)),
        8 => return small_half_deviation2::<8>(z, gw, v, s.small_shape(apex)),
        _ => half_max_deviation_f32(z, gw, [s.a, s.b, apex], rows()),
    };
    round_up(dev * dev)
}
