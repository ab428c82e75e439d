//! Level 1 of the pass above the finest (DMesh Sec. 4.2 and 5.3; the pass
//! is `levels.rs`'s) on two threads: the calling thread takes the upper
//! band of its rows, a thread the helper lends once it is free takes the
//! lower band, and the rows where the bands meet are computed once both
//! are done.
//!
//! On two threads at 1920 x 1080 the build was the calling thread's chain
//! (the finest level, then the pass, whose level 1 is a third of it),
//! while the helper, done with its deviations and normals, idled for the
//! last 7-9 ms in the VM's quick state (docs/live-journal.md). Level 1 reads the
//! finest level's results, which no step writes any more, and writes only
//! its own rows, so it splits into bands of grid rows with little to
//! share.
//!
//! The bands meet at grid row `4t` (the `t`-th row of edge midpoints
//! along rows). Each kind reads the rows beside the ones it writes: an
//! edge midpoint the finest centres a row above and below, a centre the
//! edge midpoints of its level above, below and beside it. So the upper
//! band takes the edge midpoints of rows `0..t` (both kinds) and the
//! centres of rows `0..t - 1`; the lower band, whose slices of the grid
//! start at row `4t`, the edge midpoints along rows from `t + 1`, along
//! columns from `t` and the centres from `t + 1`, into planes of its own.
//! Neither reads a row the other writes. Then the lower band's planes
//! join the level's, and the edge midpoints along rows of row `t` and the
//! centres of rows `t - 1` and `t` are computed. Every vertex's results
//! are its own, so the bytes are those of one thread over the whole
//! level.

use std::ops::Range;
use std::sync::{mpsc, Mutex, PoisonError};

use super::coarse_rows::{Planes, Scratch, PLANE_BYTES};
use super::flags::Flags;
use super::grid::Grid;
use super::levels::{level_size, Levels};

/// Level 1 is shared when it has this many rows of centres or more: the
/// two-thread builds of large grids take a lent thread (`hierarchy/passes.rs`),
/// so this only keeps the meeting rows apart.
pub(crate) const SHARED_ROWS: usize = 4;

/// Where the bands of a level with `ny` rows of centres meet: at row `t`
/// of edge midpoints along rows. The lent thread comes once the helper is
/// done with its deviations, a millisecond or two into the level at 1920
/// x 1080 in the VM's quick state, of eleven or so: the calling thread
/// takes the larger band.
fn meeting_row(ny: usize) -> usize {
    (ny * 9 / 16).clamp(1, ny - 2)
}

/// The lower band's planes for a level of `nx` by `ny` centres meeting at
/// row `t`: the first row and the rows of its edge midpoints along rows,
/// along columns (one more lane) and its centres, and their lanes.
fn lower_plane_shapes(nx: usize, ny: usize, t: usize) -> [(usize, usize, usize); 3] {
    [(t + 1, ny - t, nx), (t, ny - t, nx + 1), (t + 1, ny - t - 1, nx)]
}

/// The lower band's planes, in bytes (as `coarse_rows::scratch_bytes`
/// counts the level's): held beside the level's while it is shared.
pub(crate) fn scratch_bytes(grid: Grid) -> usize {
    let (nx, ny) = level_size(grid, 1);
    if ny < SHARED_ROWS {
        return 0;
    }
    let planes = lower_plane_shapes(nx, ny, meeting_row(ny));
    planes.iter().map(|&(_, rows, lanes)| rows * lanes).sum::<usize>() * PLANE_BYTES
}

/// The pass's end of a thread lent to level 1: the lending thread says on
/// `go` when it is free, and hears on `back` when the band it took (if
/// any) is done; `wake` ends the wait when the calling thread has taken
/// the band itself.
pub(crate) struct Share {
    go: mpsc::Receiver<()>,
    wake: mpsc::Sender<()>,
    back: mpsc::Sender<()>,
    /// The tests' way: both bands on the calling thread, meeting at row
    /// `t` of edge midpoints along rows.
    #[cfg(test)]
    pub in_turn: Option<usize>,
}

/// The lending thread's end of a [`Share`].
pub(crate) struct Lender {
    free: mpsc::Sender<()>,
    done: mpsc::Receiver<()>,
}

/// A thread to lend to level 1, its two ends.
pub(crate) fn lend() -> (Share, Lender) {
    let ((free, go), (back, done)) = (mpsc::channel(), mpsc::channel());
    let wake = free.clone();
    let share = Share {
        go,
        wake,
        back,
        #[cfg(test)]
        in_turn: None,
    };
    (share, Lender { free, done })
}

impl Lender {
    /// Lends this thread to level 1, once it is free, until the band it
    /// takes is done: at once if the calling thread took the band itself,
    /// or if the pass shared nothing (its [`Share`] is gone).
    pub(crate) fn lend(self) {
        let _ = self.free.send(());
        let _ = self.done.recv();
    }
}

/// The lower band: its slices of the grid, and its own planes and
/// scratch (made by the calling thread).
struct Lower<'a> {
    levels: Levels<'a>,
    flags: &'a mut [Flags],
    planes: Planes,
    scratch: Scratch,
}

crate::simd::dispatch! {
    /// One band's rows, with AVX2 where the CPU has it: the bands run in
    /// the scope's closures and on the lent thread, outside the pass's
    /// dispatch, where the compiler would build them without it.
    #[allow(clippy::too_many_arguments)]
    fn band(levels: &mut Levels<'_>, flags: &mut [Flags], zmax: f32, rows: [Range<usize>; 3], given: Option<&[[f32; 2]]>, planes: &mut Planes, scratch: &mut Scratch) -> () = band_body;
}

#[inline(always)]
fn band_body(
    levels: &mut Levels<'_>,
    flags: &mut [Flags],
    zmax: f32,
    rows: [Range<usize>; 3],
    given: Option<&[[f32; 2]]>,
    planes: &mut Planes,
    scratch: &mut Scratch,
) {
    levels.level_rows(flags, zmax, 1, rows, given, planes, scratch);
}

/// Takes the lower band if nobody has, and computes it.
fn take_lower(
    lower: &Mutex<Option<Lower<'_>>>,
    zmax: f32,
    rows: [Range<usize>; 3],
    given: Option<&[[f32; 2]]>,
) -> Option<Planes> {
    let Lower {
        mut levels,
        flags,
        mut planes,
        mut scratch,
    } = lower.lock().unwrap_or_else(PoisonError::into_inner).take()?;
    let _span = tracing::trace_span!("level_1_lower").entered();
    band(&mut levels, flags, zmax, rows, given, &mut planes, &mut scratch);
    Some(planes)
}

impl Levels<'_> {
    /// Level 1 in two bands (see the module doc), the lower one on the
    /// thread `share` lends if it comes before the calling thread is done
    /// with the upper one, else on this thread; `planes` are the level's,
    /// reset for it.
    pub(super) fn level_one_shared(
        &mut self,
        flags: &mut [Flags],
        zmax: f32,
        given: Option<&[[f32; 2]]>,
        planes: &mut Planes,
        scratch: &mut Scratch,
        share: Share,
    ) {
        let gw = self.grid.gw() as usize;
        let (nx, ny) = level_size(self.grid, 1);
        debug_assert!(ny >= SHARED_ROWS && self.row0 == 0);
        let t = meeting_row(ny);
        #[cfg(test)]
        let t = share.in_turn.unwrap_or(t);
        let upper_rows = [0..t, 0..t, 0..t - 1];
        let lower_rows = [t + 1..ny + 1, t..ny, t + 1..ny];
        {
            let at = 4 * t * gw;
            let (err_up, err_low) = self.err2.split_at_mut(at);
            let (rad_up, rad_low) = self.radius.split_at_mut(at);
            let (flags_up, flags_low) = flags.split_at_mut(at);
            let mut lower_planes = Planes::default();
            let Planes {
                row_edges,
                column_edges,
                centres,
                ..
            } = &mut lower_planes;
            for (plane, (row0, rows, lanes)) in [row_edges, column_edges, centres]
                .into_iter()
                .zip(lower_plane_shapes(nx, ny, t))
            {
                plane.reset(row0, rows, lanes, false);
            }
            let lower = Mutex::new(Some(Lower {
                levels: Levels {
                    err2: err_low,
                    radius: rad_low,
                    row0: 4 * t as u32,
                    ..*self
                },
                flags: flags_low,
                planes: lower_planes,
                scratch: Scratch::default(),
            }));
            let mut upper = Levels {
                err2: err_up,
                radius: rad_up,
                ..*self
            };
            let lower_planes = std::thread::scope(|scope| {
                let lower = &lower;
                let rows = lower_rows.clone();
                #[cfg(test)]
                let in_turn = share.in_turn.is_some();
                #[cfg(not(test))]
                let in_turn = false;
                let Share { go, wake, back, .. } = share;
                let lent = (!in_turn).then(|| {
                    scope.spawn(move || {
                        // Err: the lending thread is gone (it panicked, and
                        // its join passes that on); the band is taken all
                        // the same, by whichever thread comes first.
                        let _ = go.recv();
                        take_lower(lower, zmax, rows, given)
                    })
                });
                tracing::trace_span!("level_1_upper")
                    .in_scope(|| band(&mut upper, flags_up, zmax, upper_rows, given, planes, scratch));
                let mine = take_lower(lower, zmax, lower_rows, given);
                let _ = wake.send(());
                let theirs = lent.and_then(|job| job.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)));
                // The helper goes back to its own work only now: woken by
                // the lent thread, it took that thread's core before the
                // thread had ended, and the join waited 2-5 ms for it.
                let _ = back.send(());
                mine.or(theirs)
            });
            // Taken by one thread or the other, which returned its planes.
            let lower_planes = lower_planes.unwrap_or_default();
            planes.row_edges.absorb(&lower_planes.row_edges);
            planes.column_edges.absorb(&lower_planes.column_edges);
            planes.centres.absorb(&lower_planes.centres);
        }
        // Where the bands meet.
        let _span = tracing::trace_span!("level_1_meet").entered();
        band(
            self,
            flags,
            zmax,
            [t..t + 1, t..t, t - 1..t + 1],
            given,
            planes,
            scratch,
        );
    }
}
