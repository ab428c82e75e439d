//! Building the multiresolution depth-mesh: DMesh Sec. 4.2 and 5.3.
//!
//! One bottom-up pass over the levels of the 4-8 hierarchy (see `grid.rs`),
//! finest first, computes for every split vertex `v`:
//!
//! - **segmentation flags** of the two halves of its diamond, OR- and
//!   AND-combined from the two child triangles of each half (Sec. 5.3, Fig. 11-12:
//!   a triangle is segmented when any full-resolution triangle inside it is;
//!   it is *fully* segmented when all of them are). DMesh's eight flags of a
//!   quadtree node are the half-flags of the four edge midpoints and the
//!   centre of that node;
//! - its **own error**, the larger of
//!   - Eq. 1 (centres) or Eq. 2 (edge midpoints): distance of `v` to the edge it bisects;
//!   - the exact depth deviation of each unsegmented half: the largest
//!     `|z - z_lin|` over its samples, `z_lin` interpolating the half's three
//!     corner depths affinely over the grid (`deviation.rs`). This is what
//!     makes the static tolerance hold at every sample, not only at the
//!     refinement points that Eq. 1-2 measure. The build scans it in f32 and
//!     stores an upper bound, never below the exact value and above it by
//!     at most `2^-22` of it plus `2^-20` of the half's largest corner depth
//!     (`deviation_f32.rs`, `small_half_sweep.rs`; issue 16's decision);
//!   - for a half that is segmented but not fully (dropping it would drop
//!     valid, unsegmented samples), its footprint: hypotenuse length in pixels
//!     times the pixel size at its deepest valid corner. Refining it shrinks
//!     the hole towards the full-resolution flagged triangles (DESIGN.md);
//! - the **saturated error** `e(v) = max(own(v), e(children))` (nested, as in
//!   Lindstrom and Pascucci), so a vertex's error is at least every dependent's
//!   and the selection `e > threshold` always brings a vertex's dependencies;
//! - the **nested bounding radius** `r(v) = max(|p_v - p_c| + r(c))` over children
//!   (the distance bounded from above without a square root), which keeps the
//!   view-dependent test of Eq. 4 monotone.
//!
//! The pass itself is in `levels.rs`, in straight loops per kind of vertex
//! and row (the finest level, three quarters of all vertices, in those of
//! `finest.rs`; the levels above, with each kind's results kept for the
//! kind that reads them, in those of `coarse_rows.rs`). The deviations of
//! the levels above it (levels 1 to 3 swept a level at a time, sixteen
//! vertices a step, on one thread too) and the normals and quality read
//! only the depths, so with
//! [`Threads::Parallel`] a helper thread computes them meanwhile (the
//! normals first when the segmentation needs them: connectedness), and on
//! large grids then shares level 1 of the pass (`level_one_shared.rs`).
//!
//! Errors are stored squared (Eq. 3) in f32, rounded up, saturated at `f32::MAX`.
//!
//! Each step of a build is a `trace` span (`leaf_flags`, `deviations_1_3`,
//! `deviations g`, `finest`, `level g` and, when level 1 is shared,
//! `level_1_upper`, `level_1_lower`, `level_1_meet`, `normals`), so a
//! subscriber can show which thread ran what when
//! (`examples/build_timeline.rs`).

mod budgets;
mod passes;

use std::sync::OnceLock;
use std::time::Instant;

use glam::DVec3;

use super::backproject::BackProject;
use super::budget::ErrorStats;
use super::cut_errors::CutErrors;
use super::flags::Flags;
use super::grid::{Grid, Pt};
use super::outline::OutlineCache;
use super::segmentation::Segmentation;
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::image::DepthImage;
use passes::Passes;

/// The multiresolution hierarchy of one reference view. 16 bytes per grid
/// vertex (see [`Hierarchy::heap_bytes`]); immutable once built, so many
/// extractions may read it at once.
#[derive(Clone, Debug)]
pub struct Hierarchy {
    pub(crate) grid: Grid,
    pub(crate) camera: Camera,
    pub(crate) bp: BackProject,
    /// Depth per grid vertex; 0 for invalid and padding.
    pub(crate) z: Vec<f32>,
    /// Saturated squared error.
    pub(crate) err2: Vec<f32>,
    /// Nested bounding radius.
    pub(crate) radius: Vec<f32>,
    /// Octahedron-encoded normal.
    pub(crate) normal: Vec<[u8; 2]>,
    /// Sampling quality rho in 1/255.
    pub(crate) rho: Vec<u8>,
    /// Segmentation flags (`flags.rs`).
    pub(crate) flags: Vec<Flags>,
    /// Error statistics of budgeted requests, gathered on the first one
    /// (`Hierarchy::error_stats`).
    pub(crate) stats: OnceLock<ErrorStats>,
    /// The threads the build had, which the statistics use too.
    pub(crate) threads: Threads,
    /// The outlines' forced vertices and statistics, per refinement depth,
    /// computed on first use (`outline.rs`).
    pub(crate) outlines: OutlineCache,
    segmented: usize,
    /// Valid samples of the image.
    valid_samples: usize,
    build_peak_bytes: usize,
    build_ms: f64,
    stages: Stages,
}

/// Wall-clock milliseconds of a build's stages (DMesh Table 1's split).
/// With [`Threads::Parallel`] the normals run beside the levels, so the
/// stages overlap and do not sum to the build.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stages {
    /// Depths onto the padded grid (back-projection is per row and column).
    pub depths_ms: f64,
    /// Normals and the sampling quality rho.
    pub normals_ms: f64,
    /// Segmentation of the full-resolution triangles.
    pub flags_ms: f64,
    /// The finest level: flags, errors, radii.
    pub finest_ms: f64,
    /// The levels above it, with the exact deviations.
    pub coarse_ms: f64,
    /// The border's forced vertices. (The error statistics of budgets are
    /// gathered on a hierarchy's first budgeted request, not here.)
    pub border_ms: f64,
}

/// Threads a build uses. The result does not depend on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Threads {
    /// Everything on the calling thread.
    Single,
    /// A helper thread flags the cells of the lower half of the rows
    /// (where the segmentation reads the depths alone) while the calling
    /// thread flags the upper half, then computes the exact deviations of
    /// the levels above the finest while the calling thread builds the
    /// finest level, then
    /// the normals and quality (unless the segmentation needs them first:
    /// connectedness) while the calling thread builds the rest.
    Parallel,
}

impl Threads {
    /// `Parallel` where this process may use more than one core.
    pub fn available() -> Self {
        if cores() > 1 {
            Self::Parallel
        } else {
            Self::Single
        }
    }
}

/// Cores available to this process, asked once (the answer reads cgroup
/// limits, which is too slow to repeat per build).
fn cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, usize::from))
}

/// Depths on the padded grid (invalid samples and padding are 0), and the
/// largest of them.
fn grid_depths(depth: &DepthImage, grid: &Grid) -> (Vec<f32>, f32, usize) {
    let mut z = Vec::with_capacity(grid.len());
    let (zmax, valid) = depth_rows(&depth.z, depth.width as usize, grid.gw() as usize, &mut z);
    z.resize(grid.len(), 0.0);
    (z, zmax, valid)
}

crate::simd::dispatch! {
    /// The rows `w` long of `src` appended to `z` as rows `gw` long,
    /// invalid samples and padding 0; the largest depth and how many are
    /// valid (counted here, where the rows are in cache: a scan of its own
    /// took 1.2 ms of a 1920 x 1080 live frame). Each value is written
    /// once (filled with zeros first, the grid was written twice: 1 ms at
    /// 1920 x 1080 on a 2 GHz Zen 1). With AVX2 where the CPU has it.
    fn depth_rows(src: &[f32], w: usize, gw: usize, z: &mut Vec<f32>) -> (f32, usize) = depth_rows_body;
}

#[inline(always)]
fn depth_rows_body(src: &[f32], w: usize, gw: usize, z: &mut Vec<f32>) -> (f32, usize) {
    // The depths written are finite and non-negative, where the order of
    // the bit patterns is that of the values: an integer maximum, which
    // the compiler widens (`f32::max` stays one chain); a depth is valid
    // when its bits are not 0.
    let (mut zmax, mut valid) = (0u32, 0usize);
    for src in src.chunks_exact(w) {
        let start = z.len();
        z.extend(src.iter().map(|&s| if s.is_finite() && s > 0.0 { s } else { 0.0 }));
        let row = &z[start..];
        zmax = row.iter().map(|v| v.to_bits()).fold(zmax, u32::max);
        valid += row.iter().map(|v| u32::from(v.to_bits() != 0)).sum::<u32>() as usize;
        z.resize(start + gw, 0.0);
    }
    (f32::from_bits(zmax), valid)
}

/// Figures of a built hierarchy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildStats {
    /// Vertices of the padded grid.
    pub grid_vertices: usize,
    /// Full-resolution triangles of the image that are segmented.
    pub segmented_triangles: usize,
    /// Valid samples of the image (finite and positive depths).
    pub valid_samples: usize,
    /// Bytes the hierarchy keeps.
    pub heap_bytes: usize,
    /// Largest heap the build itself held at once (kept arrays plus scratch).
    pub build_peak_bytes: usize,
    /// Wall-clock build time.
    pub build_ms: f64,
    /// Its stages.
    pub stages: Stages,
}

impl Hierarchy {
    /// Builds the hierarchy of `depth` seen by `camera` (same size),
    /// segmented with `seg`, on two threads where the machine has them
    /// ([`Threads::available`]).
    pub fn build(depth: &DepthImage, camera: &Camera, seg: &Segmentation) -> Result<Self> {
        Self::build_with(depth, camera, seg, Threads::available())
    }

    /// [`Self::build`] with a choice of threads; the result is the same.
    pub fn build_with(depth: &DepthImage, camera: &Camera, seg: &Segmentation, threads: Threads) -> Result<Self> {
        let _span = tracing::debug_span!("build", width = depth.width, height = depth.height, ?threads).entered();
        let start = Instant::now();
        if depth.width != camera.width || depth.height != camera.height {
            return Err(Error::invalid(format!(
                "depth image is {}x{} but the camera is {}x{}; they must match",
                depth.width, depth.height, camera.width, camera.height
            )));
        }
        if depth.width < 2 || depth.height < 2 {
            return Err(Error::invalid(format!(
                "depth image is {}x{}; width and height must be at least 2",
                depth.width, depth.height
            )));
        }
        seg.validate()?;
        let grid = Grid::for_image(depth.width, depth.height);
        let (gw, gh) = (grid.gw(), grid.gh());
        let bp = BackProject::new(camera, gw, gh);

        let t = Instant::now();
        let (z, zmax, valid_samples) = grid_depths(depth, &grid);
        let depths_ms = t.elapsed().as_secs_f64() * 1e3;
        let p = Passes::run(&grid, camera, &bp, (&z, zmax), seg, threads);
        let mut mesh = Self {
            grid,
            camera: *camera,
            bp,
            z,
            err2: p.err2,
            radius: p.radius,
            normal: p.normal,
            rho: p.rho,
            flags: p.flags,
            stats: OnceLock::new(),
            threads,
            outlines: OutlineCache::default(),
            segmented: p.segmented,
            valid_samples,
            build_peak_bytes: 0,
            build_ms: 0.0,
            stages: Stages { depths_ms, ..p.stages },
        };
        // Everything kept was allocated before the levels ran, and the leaf
        // flags became the node flags in place: the peak is what is kept
        // plus the deviations of the coarse levels (the statistics come
        // on the first budgeted request, and are counted in
        // `heap_bytes_bound`).
        mesh.build_peak_bytes = mesh.heap_bytes() + p.scratch_bytes;
        let t = Instant::now();
        super::border::force_border(&mesh.grid, &mut mesh.err2);
        mesh.stages.border_ms = t.elapsed().as_secs_f64() * 1e3;
        mesh.build_ms = start.elapsed().as_secs_f64() * 1e3;
        tracing::debug!(ms = mesh.build_ms, segmented = mesh.segmented, "built");
        Ok(mesh)
    }

    #[inline]
    fn point(&self, (x, y): Pt) -> DVec3 {
        self.bp.point(x, y, self.z[self.grid.index((x, y))])
    }

    /// The grid layout.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The reference camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Depth of grid vertex `p` (0 for invalid or padding).
    pub fn depth(&self, p: Pt) -> f32 {
        self.z[self.grid.index(p)]
    }

    /// Saturated error of grid vertex `p` (not squared).
    pub fn error(&self, p: Pt) -> f32 {
        self.err2[self.grid.index(p)].sqrt()
    }

    /// Nested bounding radius of grid vertex `p`.
    pub fn radius(&self, p: Pt) -> f32 {
        self.radius[self.grid.index(p)]
    }

    /// Camera-frame position of grid vertex `p`.
    pub fn position(&self, p: Pt) -> DVec3 {
        self.point(p)
    }

    /// True when the full-resolution triangle half `h` of the unit cell with
    /// min corner `cell` is segmented.
    pub fn cell_segmented(&self, cell: Pt, h: usize) -> bool {
        self.flags[self.grid.index(cell)].cell(h)
    }

    /// Heap bytes the hierarchy keeps: 16 per grid vertex plus the per-row
    /// and per-column back-projection factors, and what requests have
    /// added: the error statistics of budgets (16 kB per frontier level
    /// plus one, about 100 kB at 513 x 513) and the outlines computed.
    pub fn heap_bytes(&self) -> usize {
        self.built_bytes() + self.stats.get().map_or(0, ErrorStats::heap_bytes) + self.outlines.heap_bytes()
    }

    /// Heap bytes of what the build made: the per-vertex arrays and the
    /// back-projection factors.
    fn built_bytes(&self) -> usize {
        self.z.capacity() * 4
            + self.err2.capacity() * 4
            + self.radius.capacity() * 4
            + self.normal.capacity() * 2
            + self.rho.capacity()
            + self.flags.capacity()
            + self.bp.heap_bytes()
    }

    /// The most heap bytes the hierarchy will keep: [`Self::heap_bytes`]
    /// with the budget's statistics and every outline computed (`outline.rs`:
    /// one bit per grid vertex and the budget's statistics per refinement,
    /// a byte per grid vertex for the near side, and the cutting errors
    /// with a cut per segmented half), which extractions add
    /// on first use. Constant, so a cache can charge it once.
    pub fn heap_bytes_bound(&self) -> usize {
        let stats = ErrorStats::heap_bytes_for(self.grid);
        // The cutting errors keep a cut per segmented half they fit.
        let segmented_halves: usize = self
            .flags
            .iter()
            .map(|f| usize::from(f.half(0).any) + usize::from(f.half(1).any))
            .sum();
        self.built_bytes()
            + stats
            + OutlineCache::heap_bytes_bound(self.grid, stats)
            + CutErrors::CUT_BYTES * segmented_halves
    }

    /// Figures of this build.
    pub fn stats(&self) -> BuildStats {
        BuildStats {
            grid_vertices: self.grid.len(),
            segmented_triangles: self.segmented,
            valid_samples: self.valid_samples,
            heap_bytes: self.heap_bytes(),
            build_peak_bytes: self.build_peak_bytes,
            build_ms: self.build_ms,
            stages: self.stages,
        }
    }
}
