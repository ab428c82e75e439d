//! What a triangle budget resolves to on a built hierarchy: the smallest
//! budget any request can be given, and the finest level of detail provably
//! within a budget, with outlines dropped or kept (Qu et al. Sec. 3.4, from
//! the error statistics of `budget.rs`; DMesh Sec. 5.3 for the outlines).

use super::{Hierarchy, Threads};
use crate::camera::Camera;
use crate::error::Result;
use crate::mesh::budget::ErrorStats;
use crate::mesh::lod::Lod;
use crate::mesh::outline::{ladder, Outline, Rung, OUTLINE_SHARE};
use crate::mesh::Outlines;

impl Hierarchy {
    /// Triangles of the coarsest mesh before segmentation: two per root quad,
    /// the smallest budget any request can be given.
    pub fn coarsest_triangles(&self) -> u64 {
        self.error_stats().coarsest_triangles()
    }

    /// The error statistics of budgeted requests (`budget.rs`), gathered
    /// on the first one: one pass over the errors (6 % of a 513 x 513
    /// build), which tolerances never need.
    pub(crate) fn error_stats(&self) -> &ErrorStats {
        self.stats
            .get_or_init(|| ErrorStats::gather(self.grid, &self.err2, self.threads == Threads::Parallel))
    }

    /// An outline's statistics: the hierarchy's, with its forced vertices
    /// moved into the base, derived on the first budgeted request that
    /// keeps it.
    pub(crate) fn outline_stats<'a>(&'a self, outline: &'a Outline) -> &'a ErrorStats {
        outline
            .stats
            .get_or_init(|| self.error_stats().with_forced(self.grid, &self.err2, &outline.forced))
    }

    /// The finest level of detail whose mesh, extracted dropping outlines
    /// ([`crate::mesh::Outlines::Dropped`]), has at most
    /// `max_triangles` triangles, for the requesting camera `view`
    /// (view-dependent) or none (static), from the error statistics
    /// gathered on the first such request (`budget.rs`): `Tau` for `view`
    /// or `Epsilon`, never `Triangles`. Fails when even the coarsest mesh has more, and
    /// only then does a budget given to an extraction that keeps outlines
    /// fail. Such an extraction resolves a [`Lod::Triangles`] itself, with
    /// its refinement counted.
    pub fn lod_for_triangles<'v>(&self, max_triangles: u64, view: Option<&'v Camera>) -> Result<Lod<'v>> {
        self.resolve_budget(self.error_stats(), max_triangles, view)
    }

    /// The level of detail `stats` (the plain ones or an outline's) resolve
    /// a budget of `max_triangles` to, for `view`, with this hierarchy's
    /// eye and spheres.
    pub(crate) fn resolve_budget<'v>(
        &self,
        stats: &ErrorStats,
        max_triangles: u64,
        view: Option<&'v Camera>,
    ) -> Result<Lod<'v>> {
        stats.lod_for_triangles(
            max_triangles,
            view,
            |v| self.camera.to_camera(v.translation),
            |p| (self.position(p), self.radius(p)),
        )
    }

    /// The outline of one refinement (`outline.rs`), computed on first use.
    pub(crate) fn outline(&self, rung: Rung) -> &Outline {
        self.outlines.get(rung, self.grid, (&self.z, &self.flags))
    }

    /// Triangles of the coarsest mesh with the coarse triangles that a
    /// discontinuity crosses treated as `outlines` says (`Kept` as for a
    /// tolerance: refined down to the segmented cells): twice this is the
    /// smallest budget an extraction keeps such outlines in.
    pub fn coarsest_triangles_with_outlines(&self, outlines: Outlines) -> u64 {
        match outlines.rung() {
            Some(rung) => self.outline_stats(self.outline(rung)).coarsest_triangles(),
            None => self.coarsest_triangles(),
        }
    }

    /// [`Self::lod_for_triangles`] for an extraction that keeps outlines:
    /// the first refinement of [`ladder`] (each depth on both sides of a
    /// discontinuity, then on its near side, finest first) whose forced
    /// triangles take at most half of `max_triangles` (`outline.rs`), with
    /// the level of detail whose mesh, refined so, provably fits; or, when
    /// no refinement's do, none and [`Self::lod_for_triangles`].
    pub(crate) fn outline_lod_for_triangles<'v>(
        &self,
        max_triangles: u64,
        view: Option<&'v Camera>,
    ) -> Result<(Lod<'v>, Option<&Outline>)> {
        for rung in ladder() {
            let outline = self.outline(rung);
            let stats = self.outline_stats(outline);
            if stats.coarsest_triangles() as f64 <= OUTLINE_SHARE * max_triangles as f64 {
                let lod = self.resolve_budget(stats, max_triangles, view)?;
                return Ok((lod, Some(outline)));
            }
        }
        Ok((self.lod_for_triangles(max_triangles, view)?, None))
    }
}
