//! What a triangle budget resolves to on a built hierarchy: the smallest
//! budget any request can be given, and the finest level of detail provably
//! within a budget, with outlines dropped or kept (Qu et al. Sec. 3.4, from
//! the error statistics of `budget.rs`; DMesh Sec. 5.3 for the outlines).

use super::Hierarchy;
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
        self.stats.coarsest_triangles()
    }

    /// The finest level of detail whose mesh, extracted dropping outlines
    /// ([`crate::mesh::Outlines::Dropped`]), has at most
    /// `max_triangles` triangles, for the requesting camera `view`
    /// (view-dependent) or none (static), from the error statistics
    /// gathered at build time (`budget.rs`): `Tau` for `view` or `Epsilon`,
    /// never `Triangles`. Fails when even the coarsest mesh has more, and
    /// only then does a budget given to an extraction that keeps outlines
    /// fail. Such an extraction resolves a [`Lod::Triangles`] itself, with
    /// its refinement counted.
    pub fn lod_for_triangles<'v>(&self, max_triangles: u64, view: Option<&'v Camera>) -> Result<Lod<'v>> {
        self.resolve_budget(&self.stats, max_triangles, view)
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
        let arrays = (&self.z[..], &self.flags[..], &self.err2[..]);
        self.outlines.get(rung, self.grid, arrays, &self.stats)
    }

    /// Triangles of the coarsest mesh with the coarse triangles that a
    /// discontinuity crosses treated as `outlines` says (`Kept` as for a
    /// tolerance: refined down to the segmented cells): twice this is the
    /// smallest budget an extraction keeps such outlines in.
    pub fn coarsest_triangles_with_outlines(&self, outlines: Outlines) -> u64 {
        match outlines.rung() {
            Some(rung) => self.outline(rung).stats.coarsest_triangles(),
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
            if outline.stats.coarsest_triangles() as f64 <= OUTLINE_SHARE * max_triangles as f64 {
                let lod = self.resolve_budget(&outline.stats, max_triangles, view)?;
                return Ok((lod, Some(outline)));
            }
        }
        Ok((self.lod_for_triangles(max_triangles, view)?, None))
    }
}
