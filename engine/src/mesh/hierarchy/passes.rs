//! The passes of one build over its depths, and which thread runs what
//! (DMesh Sec. 4.2 and 5.3; what each pass computes is `hierarchy.rs`'s):
//! the leaf segmentation, the finest level, the levels above it with their
//! exact deviations, and the normals and quality.
//!
//! On one thread they run in that order (the normals first), the
//! deviations of levels 1 to 3 swept whole before the pass comes to them.
//! On two (issue 27), a helper thread flags the lower half of the rows,
//! computes the deviations of the levels above the finest while this
//! thread builds the finest level, on large grids takes the lower band of
//! level 1 (`level_one_shared.rs`), and then both threads share the
//! normals a band of rows at a time. The schedule never changes the bytes:
//! one thread and two build the same hierarchy, which the tests check.

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{mpsc, OnceLock};
use std::time::Instant;

use tracing::trace_span;

use super::{Stages, Threads};
use crate::camera::Camera;
use crate::mesh::backproject::BackProject;
use crate::mesh::flags::Flags;
use crate::mesh::grid::Grid;
use crate::mesh::level_deviations::{coarse_deviations, small_deviations};
use crate::mesh::level_one_shared::{self, lend, Lender};
use crate::mesh::levels::{run_coarse, run_finest, Levels};
use crate::mesh::normals::{normals_and_quality, NormalBands};
use crate::mesh::segmentation::{
    leaf_flag_rows, leaf_flags, rows_split, segmented_count, Method, Samples, Segmentation,
};
use crate::mesh::split_order::split_count;
use crate::mesh::{coarse_rows, small_half_sweep};

/// Grids of this many vertices or more share level 1 of the pass with the
/// helper on two threads, where the helper would otherwise idle at the
/// end. Medians on the Zen 3 VM, six alternations (docs/live-journal.md): 1920 x
/// 1080 (2.2 million grid vertices) 35.6 -> 32.2 ms, Books (1.6 million)
/// 26.6 -> 24.7; 1025 x 1025 (1.05 million), where the two threads'
/// chains are nearly even, lost (14.8 -> 15.8).
const SHARE_LEVEL_ONE_FROM: usize = 3 << 19;

/// What the passes of a build compute from the depths.
pub(super) struct Passes {
    pub normal: Vec<[u8; 2]>,
    pub rho: Vec<u8>,
    pub flags: Vec<Flags>,
    pub err2: Vec<f32>,
    pub radius: Vec<f32>,
    /// Full-resolution triangles of the image that are segmented.
    pub segmented: usize,
    /// Bytes held only while the passes ran (the helper's deviations).
    pub scratch_bytes: usize,
    /// Stage times.
    pub stages: Stages,
}

impl Passes {
    /// Normals, leaf segmentation and the bottom-up pass over the levels,
    /// from the depths `z` on `grid`, of which `zmax` is the largest.
    ///
    /// The exact deviations of the levels above the finest and the normals
    /// read only the depths. With [`Threads::Parallel`] a helper thread
    /// computes the deviations while this thread builds the finest level
    /// and the levels above it, then both compute the normals, a band of
    /// rows at a time, whichever comes first ([`NormalBands`]); with a
    /// segmentation that needs the normals first (connectedness compares
    /// them across triangle legs) this thread computes them at the start.
    ///
    /// The helper computes a level's deviations of levels 4 and up only
    /// while the pass is at least two levels below it: otherwise the pass
    /// would wait for it, and the pass scans each half as it comes to it
    /// (sparing the scans its children's bound shows needless) while the
    /// helper goes on to the normals. Either way a level's deviations are
    /// the same bits, so the result does not depend on the schedule.
    ///
    /// On grids of [`SHARE_LEVEL_ONE_FROM`] vertices or more the helper,
    /// done with its deviations, lends itself to level 1 of the pass
    /// before the normals: a thread of the pass's takes the lower band of
    /// level 1's rows once it is lent, unless this thread got there first
    /// (`level_one_shared.rs`). The bytes are the same either way.
    pub(super) fn run(
        grid: &Grid,
        camera: &Camera,
        bp: &BackProject,
        (z, zmax): (&[f32], f32),
        seg: &Segmentation,
        threads: Threads,
    ) -> Self {
        let grid = *grid;
        let helper = threads == Threads::Parallel;
        let normals_first = !helper || matches!(seg.method, Method::Connectedness { .. });
        // With a helper and a segmentation that reads the depths alone, the
        // helper flags the cells of the lower half of the rows first
        // (`split..`; it then computes the deviations and the normals) and
        // this thread the upper half.
        let gw = grid.gw() as usize;
        let split = if helper && rows_split(seg) {
            grid.gh() / 2
        } else {
            grid.gh()
        };
        // The normals computed after the pass, shared out in bands: their
        // arrays are filled by this thread once the helper is under way
        // (a few megabytes at 1920 x 1080, which held up its start).
        let (mut late_normal, mut late_rho) = (Vec::new(), Vec::new());
        let late = (&mut late_normal, &mut late_rho);
        let bands = OnceLock::new();
        let claims = Claims::default();
        // On a large grid the helper lends itself to level 1 of the pass
        // once its deviations are done (`level_one_shared.rs`).
        let (share, lender) = if helper && grid.len() >= SHARE_LEVEL_ONE_FROM {
            let (share, lender) = lend();
            (Some(share), Some(lender))
        } else {
            (None, None)
        };
        let scoped = std::thread::scope(|scope| {
            let (send, receive) = mpsc::channel();
            let (send_band, receive_band) = mpsc::channel();
            let (bands, claims) = (&bands, &claims);
            let job = helper.then(|| {
                // The helper's arrays are allocated here: this thread's
                // allocator hands out memory it has used before, where a new
                // thread's would take fresh pages and fault each one in.
                let levels: Vec<Vec<[f32; 2]>> =
                    (1..grid.k).map(|g| Vec::with_capacity(split_count(grid, g))).collect();
                let band = vec![0u8; (grid.gh() - split) as usize * gw];
                let samples = Samples {
                    grid: &grid,
                    camera,
                    bp,
                    z,
                    normals: &[],
                };
                let to_pass = ToPass {
                    band: send_band,
                    levels: send,
                };
                scope.spawn(move || help(samples, (seg, split, band), levels, to_pass, claims, lender, bands))
            });
            if !normals_first {
                let (normal, rho) = late;
                *normal = vec![[0u8; 2]; grid.len()];
                *rho = vec![0u8; grid.len()];
                // Set once, here: it cannot be full.
                let _ = bands.set(NormalBands::new(&grid, normal, rho));
            }
            let ms = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
            let mut stages = Stages::default();
            let t = Instant::now();
            let early =
                normals_first.then(|| trace_span!("normals").in_scope(|| normals_and_quality(&grid, camera, bp, z)));
            if early.is_some() {
                stages.normals_ms = ms(t);
            }
            let t = Instant::now();
            let samples = Samples {
                grid: &grid,
                camera,
                bp,
                z,
                normals: early.as_ref().map_or(&[][..], |(n, _)| n),
            };
            // The pass's squared errors and radii, allocated once the
            // helper is under way, as is anything it does not read.
            let pass_arrays = || (vec![0f32; grid.len()], vec![0f32; grid.len()]);
            let (cells, made) = if split < grid.gh() {
                let mut cells = vec![0u8; grid.len()];
                let (upper, lower) = cells.split_at_mut(split as usize * gw);
                trace_span!("leaf_flags").in_scope(|| leaf_flag_rows(&samples, seg, 0..split, upper));
                // Made while the helper (which started later) flags its
                // rows: 2 ms of zero fill at 1920 x 1080.
                let made = pass_arrays();
                // If the helper panicked, the rows are flagged here (and the
                // join below passes the panic on).
                match receive_band.recv() {
                    Ok(band) => lower.copy_from_slice(&band),
                    Err(_) => leaf_flag_rows(&samples, seg, split..grid.gh(), lower),
                }
                (cells, Some(made))
            } else {
                (trace_span!("leaf_flags").in_scope(|| leaf_flags(&samples, seg)), None)
            };
            let segmented = segmented_count(&grid, &cells);
            let mut flags: Vec<Flags> = cells.into_iter().map(Flags::of_cell).collect();
            stages.flags_ms = ms(t);
            let (mut err2, mut radius) = made.unwrap_or_else(pass_arrays);
            let mut levels = Levels {
                grid,
                camera,
                bp,
                z,
                err2: &mut err2,
                radius: &mut radius,
                row0: 0,
            };
            let t = Instant::now();
            trace_span!("finest").in_scope(|| run_finest(&mut levels, &mut flags, zmax));
            stages.finest_ms = ms(t);
            let t = Instant::now();
            let join = |job: std::thread::ScopedJoinHandle<'_, _>| {
                job.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
            };
            // The helper sends the deviations a level at a time (if it
            // panicked, the pass computes the rest and the join below passes
            // the panic on). On one thread, levels 1 to 3 are swept whole
            // before the pass comes to them (sixteen vertices a step), and
            // each unsegmented half of the coarser levels is scanned as the
            // pass comes to it, where its children's bound leaves the
            // vertex's error open (`deviation_bound.rs`). Scratch: the
            // sweep's planes, on whichever thread, the levels' deviations,
            // the pass's kept rows, and the helper's band of leaf flags
            // (counted as if held as long), and the planes of level 1's
            // lower band if it is shared.
            // The helper reserves every level's deviations at its start (a
            // level the pass takes over is freed unused), so all count.
            let helper_levels: usize = if job.is_some() {
                (1..grid.k).map(|g| split_count(grid, g) * 8).sum()
            } else {
                0
            };
            let mut scratch_bytes = small_half_sweep::scratch_bytes(grid)
                + coarse_rows::scratch_bytes(grid)
                + (grid.gh() - split) as usize * gw
                + helper_levels
                + share.as_ref().map_or(0, |_| level_one_shared::scratch_bytes(grid));
            let mut later = [None, None];
            let mut given = |g: u32| {
                claims.pass_is_at(g);
                let level = match (&job, g) {
                    // Not claimed by the helper: scanned as the pass comes.
                    (Some(_), 4..) if claims.claim(g) => None,
                    (Some(_), _) => receive.recv().ok(),
                    (None, 1) => {
                        let out = [1, 2, 3].map(|g| Vec::with_capacity(split_count(grid, g)));
                        let [one, two, three] =
                            trace_span!("deviations_1_3").in_scope(|| small_deviations(grid, z, out));
                        later = [Some(two), Some(three)];
                        Some(one)
                    }
                    (None, 2 | 3) => later[g as usize - 2].take(),
                    (None, _) => None,
                };
                if job.is_none() {
                    scratch_bytes += level.as_ref().map_or(0, |d: &Vec<[f32; 2]>| d.capacity() * 8);
                }
                level
            };
            run_coarse(&mut levels, &mut flags, zmax, &mut given, share);
            stages.coarse_ms = ms(t);
            // The normals' bands the helper has not taken: the stage's
            // time is both threads' time in them.
            if let Some(bands) = bands.get() {
                let t = Instant::now();
                trace_span!("normals").in_scope(|| bands.work(&grid, camera, bp, z));
                stages.normals_ms = ms(t);
            }
            if let Some(helper_ms) = job.and_then(join) {
                stages.normals_ms += helper_ms;
            }
            (early, flags, err2, radius, segmented, scratch_bytes, stages)
        });
        let (early, flags, err2, radius, segmented, scratch_bytes, stages) = scoped;
        // Every band was computed: this thread took bands until none was
        // left, and the helper finished the one it held before the scope
        // ended (or its panic went on at the join).
        drop(bands);
        let (normal, rho) = early.unwrap_or((late_normal, late_rho));
        Self {
            normal,
            rho,
            flags,
            err2,
            radius,
            segmented,
            scratch_bytes,
            stages,
        }
    }
}

/// What the helper sends the pass: its band of leaf flags, and the
/// deviations a level at a time.
struct ToPass {
    band: mpsc::Sender<Vec<u8>>,
    levels: mpsc::Sender<Vec<[f32; 2]>>,
}

/// Which thread computes the deviations of each level from 4 up: the level
/// the pass is at, and the first such level nobody has claimed. The helper
/// claims levels in order while the pass is two or more below them, then
/// the pass claims the rest.
struct Claims {
    pass_at: AtomicU32,
    unclaimed: AtomicU32,
}

impl Default for Claims {
    fn default() -> Self {
        Self {
            pass_at: AtomicU32::new(0),
            unclaimed: AtomicU32::new(4),
        }
    }
}

impl Claims {
    /// The pass has come to level `g`.
    fn pass_is_at(&self, g: u32) {
        self.pass_at.store(g, Ordering::Release);
    }

    /// Whether the helper takes level `g`: the pass is two levels below
    /// it or more, and nobody has taken it.
    fn helper_claims(&self, g: u32) -> bool {
        self.pass_at.load(Ordering::Acquire) + 2 <= g && self.claim(g)
    }

    /// Whether level `g` was the first unclaimed one, now claimed.
    fn claim(&self, g: u32) -> bool {
        self.unclaimed
            .compare_exchange(g, g + 1, Ordering::AcqRel, Ordering::Acquire)
            .is_ok()
    }
}

/// The helper thread's part of a two-thread build, in order: the leaf
/// flags of the rows from `split` on into `band` (where the segmentation
/// reads the depths alone: else `split` is the grid's height), the
/// deviations of levels 1 to 3 and then of each coarser level it claims,
/// into `levels`, sent to the pass a level at a time so it can start on
/// one while the next is computed (it outlives this thread: sending cannot
/// fail); then, lent to level 1 of the pass until its lower band is done
/// (at once if the pass took the band itself); then the normals' bands
/// the pass has not taken. Gives the time it spent on the normals, if it
/// computed any.
fn help(
    samples: Samples<'_>,
    (seg, split, mut band): (&Segmentation, u32, Vec<u8>),
    levels: Vec<Vec<[f32; 2]>>,
    to_pass: ToPass,
    claims: &Claims,
    lender: Option<Lender>,
    bands: &OnceLock<NormalBands<'_>>,
) -> Option<f64> {
    let Samples {
        grid, camera, bp, z, ..
    } = samples;
    let grid = *grid;
    if split < grid.gh() {
        trace_span!("leaf_flags").in_scope(|| {
            leaf_flag_rows(&samples, seg, split..grid.gh(), &mut band);
        });
        let _ = to_pass.band.send(band);
    }
    let mut levels = levels.into_iter();
    let small = [(); 3].map(|()| levels.next().unwrap_or_default());
    let small = trace_span!("deviations_1_3").in_scope(|| small_deviations(grid, z, small));
    for level in small.into_iter().take(grid.k as usize - 1) {
        let _ = to_pass.levels.send(level);
    }
    for (g, out) in (4..grid.k).zip(levels) {
        if !claims.helper_claims(g) {
            break;
        }
        let level = trace_span!("deviations", g).in_scope(|| coarse_deviations(grid, z, g, out));
        let _ = to_pass.levels.send(level);
    }
    if let Some(lender) = lender {
        lender.lend();
    }
    bands.get().map(|bands| {
        let t = Instant::now();
        trace_span!("normals").in_scope(|| bands.work(&grid, camera, bp, z));
        t.elapsed().as_secs_f64() * 1e3
    })
}
