//! Extracting a conforming, segmented mesh from the hierarchy: DMesh Sec. 4.3
//! (static, Eq. 3), Sec. 4.4 (view-dependent, Eq. 4) and Sec. 5.3 (segmented
//! triangles skipped while the strip is generated).
//!
//! A recursive top-down traversal of the bintree (Lindstrom and Pascucci)
//! visits every root quad (in boustrophedon order), splits a triangle when
//! its split vertex is selected, and emits the unsplit ones in Sierpinski
//! order. A triangle is skipped, breaking the strip, when it is segmented or
//! outside the requesting view; a fully segmented one is skipped without
//! descending into it. A coarse triangle that is partly segmented is split
//! further, down to the segmented cells, when the extraction keeps outlines
//! ([`Outlines::Kept`], the default: the vertices this forces are
//! `outline.rs`'s), and dropped whole as Sec. 5.3 drops it otherwise. With
//! [`Outlines::Cut`] it is drawn as the two parts of its cut (`cut.rs`),
//! selected by the cutting errors (`cut_errors.rs`) instead of the build's.
//! Because selection is monotone (`select.rs`) and the forced set closed
//! under dependency, the emitted triangles form a conforming triangulation:
//! no cracks, no T-junctions.
//!
//! What the static tolerance guarantees (checked over every sample by the
//! tests): for every emitted triangle and every grid sample inside or on it,
//! `|z_sample - z_lin| <= epsilon`, where `z_lin` interpolates the triangle's
//! corner depths affinely over the pixel grid (for an orthographic camera,
//! the vertical distance of the sample from the mesh surface), and every
//! vertex that was left out lies within `epsilon` of the edge it would
//! bisect (Eq. 1/2). Samples under emitted triangles are all valid and
//! unsegmented.

mod walk;

use std::time::Instant;

use glam::DVec3;

use super::cut::{CutTriangle, Samples};
use super::cut_errors::{cut_errors, CutErrors};
use super::hierarchy::{Hierarchy, Threads};
use super::lod::Lod;
use super::outline::Rung;
use super::reach::{merge_spheres, Reach, MAX_CULLED};
use super::select::{Select, Static, ViewDependent, ALL_PLANES};
use super::strips::{stripify, stripify_greedy, stripify_tunnelled, StripOrder, BREAK};
use crate::camera::Camera;
use crate::error::{Error, Result};
use walk::{Walked, NEAR_CULLED};

/// One vertex of an extracted mesh, as it goes on the wire.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshVertex {
    /// Grid column (pixel u).
    pub i: u16,
    /// Grid row (pixel v).
    pub j: u16,
    /// Depth `z` in metres (always finite and positive).
    pub depth: f32,
    /// Octahedron-encoded unit normal facing the reference camera.
    pub normal: [u8; 2],
    /// Sampling quality rho in 1/255.
    pub rho: u8,
}

/// An extracted mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertices in coarse-to-fine order.
    pub vertices: Vec<MeshVertex>,
    /// Generalised strips with [`super::RESTART`] between them.
    pub strips: Vec<u32>,
    /// The same triangles as an indexed list; `(p1 - p0) x (p2 - p0)` faces
    /// the reference camera for a surface that does.
    pub triangles: Vec<[u32; 3]>,
    /// Triangles skipped because they are segmented, at the extracted resolution.
    pub dropped_triangles: usize,
    /// Wall-clock time of the extraction.
    pub extract_ms: f64,
    /// The tolerance it was extracted at: `Epsilon` or `Tau` (a budget's
    /// resolution), as the wire states it.
    pub lod: dmesh_proto::Lod,
    /// For a view-dependent mesh, how far the requesting camera may move
    /// before the mesh stops meeting its tolerance or misses culled parts.
    pub reach: Option<Reach>,
    /// Triangles a discontinuity crosses, drawn as the parts on either
    /// side of one straight cut ([`Outlines::Cut`] and
    /// [`Outlines::CutOrDrop`] only; `cut.rs`). They
    /// are not in `triangles` or `strips`.
    pub cuts: Vec<CutTriangle>,
}

impl Mesh {
    /// The strips as 16-bit indices with `u16::MAX` as the restart marker, when
    /// the mesh has fewer than 65,535 vertices (so no index collides with it).
    pub fn strips_u16(&self) -> Option<Vec<u16>> {
        (self.vertices.len() < usize::from(u16::MAX)).then(|| {
            self.strips
                .iter()
                .map(|&i| if i == super::RESTART { u16::MAX } else { i as u16 })
                .collect()
        })
    }

    /// Triangles drawn: `triangles` and the parts of the `cuts`.
    pub fn drawn_triangles(&self) -> usize {
        self.triangles.len() + self.cuts.iter().map(CutTriangle::drawn).sum::<usize>()
    }

    /// Number of strips in [`Mesh::strips`].
    pub fn strip_count(&self) -> usize {
        if self.strips.is_empty() {
            0
        } else {
            1 + self.strips.iter().filter(|&&i| i == super::RESTART).count()
        }
    }
}

/// What an extraction does with a coarse triangle that a discontinuity
/// crosses (it holds a segmented full-resolution triangle, but not only
/// those).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Outlines {
    /// Drops it whole at the extracted resolution, as DMesh Sec. 5.3 does:
    /// the foreground's outline erodes by up to the triangle's size.
    Dropped,
    /// Refines it down to triangles `2 * finest` samples across (`finest`
    /// rounded up to a power of two, at most 32), which are dropped whole;
    /// with 1, down to the segmented cells themselves.
    Refined(u32),
    /// The same, but only where the triangle holds the near surface
    /// (`surface_side.rs`): the near surface's outline is kept as finely,
    /// and the far surface beside it is dropped in triangles as large as
    /// the extracted resolution's, for fewer triangles.
    NearSide(u32),
    /// Cuts it along the discontinuity (`cut.rs`): a triangle that one
    /// straight cut separates into parts within the tolerance is drawn as
    /// those parts, nothing spanning the jump; any other is split, down to
    /// the full-resolution triangles, which are cut where they can be and
    /// dropped otherwise. Padded borders and the edges of missing samples
    /// are cut alike. A triangle budget counts a cut triangle as the
    /// triangles it draws (`cut_budget.rs`).
    Cut,
    /// [`Self::Cut`], but a triangle that a discontinuity crosses and no
    /// cut holds is dropped whole, as DMesh Sec. 5.3 drops it, when it is
    /// at most this many samples across (its hypotenuse's span), instead of
    /// refined: fewer triangles for an outline eroded by up to that much.
    /// Its errors are computed for each extraction (the comparison's
    /// fallback, not a served mode).
    CutOrDrop(u32),
    /// `Refined(1)` for a tolerance; for a triangle budget, the first of
    /// `Refined(1)`, `NearSide(1)`, `Refined(2)`, `NearSide(2)`, ... whose
    /// forced triangles take at most half the budget, or none when no
    /// refinement's do. What the service serves.
    #[default]
    Kept,
}

impl Outlines {
    /// The refinement it asks of a tolerance (`Kept`: `Refined(1)`).
    pub(crate) fn rung(self) -> Option<Rung> {
        match self {
            Self::Dropped | Self::Cut | Self::CutOrDrop(_) => None,
            Self::Refined(finest) => Some(Rung {
                finest,
                near_side: false,
            }),
            Self::NearSide(finest) => Some(Rung {
                finest,
                near_side: true,
            }),
            Self::Kept => Some(Rung {
                finest: 1,
                near_side: false,
            }),
        }
    }

    /// The next coarser way of cutting, for a budget or a rate the cuts
    /// cannot reach: dropping what no cut holds up to 2, 4, ..., 64
    /// samples across; `None` past that and for the modes that do not cut.
    pub(crate) fn coarser_cut(self) -> Option<Self> {
        match self {
            Self::Cut => Some(Self::CutOrDrop(2)),
            Self::CutOrDrop(span) if span < MAX_DROP_SPAN => Some(Self::CutOrDrop(2 * span)),
            _ => None,
        }
    }
}

/// The largest span [`Outlines::coarser_cut`] drops what no cut holds up to.
const MAX_DROP_SPAN: u32 = 64;

impl From<Option<Rung>> for Outlines {
    fn from(rung: Option<Rung>) -> Self {
        match rung {
            None => Self::Dropped,
            Some(Rung {
                finest,
                near_side: false,
            }) => Self::Refined(finest),
            Some(Rung {
                finest,
                near_side: true,
            }) => Self::NearSide(finest),
        }
    }
}

/// Per-thread buffers of [`Hierarchy::extract_with`].
struct Scratch {
    tris: Vec<[u32; 3]>,
    slot: Vec<u32>,
}

impl Hierarchy {
    /// Extracts the mesh at level of detail `lod`, strips in traversal
    /// order, keeping outlines ([`Outlines::Kept`]): the mesh the service
    /// serves.
    pub fn extract(&self, lod: Lod<'_>) -> Result<Mesh> {
        self.extract_with(lod, StripOrder::Traversal)
    }

    /// [`Self::extract`] with strips built in `strips` order.
    pub fn extract_with(&self, lod: Lod<'_>, strips: StripOrder) -> Result<Mesh> {
        self.extract_as(lod, strips, Outlines::Kept)
    }

    /// Extracts the mesh at level of detail `lod`, strips in `strips`
    /// order, treating the coarse triangles that a discontinuity crosses as
    /// `outlines` says. A triangle budget (`Lod::Triangles`) is resolved
    /// with the refinement counted (`outline.rs`), so it is met whatever
    /// `outlines` is.
    pub fn extract_as(&self, lod: Lod<'_>, strips: StripOrder, outlines: Outlines) -> Result<Mesh> {
        let _span = tracing::debug_span!("extract", lod = %lod.kind(), strips = ?strips, ?outlines).entered();
        let start = Instant::now();
        let finest = match (outlines, lod) {
            (_, Lod::Triangles { max, view }) => {
                let max = u64::from(max);
                // Resolved to `Epsilon` or `Tau` with the refinement it counted.
                let (lod, rung) = match (outlines, outlines.rung()) {
                    (Outlines::Cut | Outlines::CutOrDrop(_), _) => {
                        // Met by counting extractions (`cut_budget.rs`).
                        let mut mesh = self.cut_for_triangles(max, view, strips, outlines)?;
                        mesh.extract_ms = start.elapsed().as_secs_f64() * 1e3;
                        return Ok(mesh);
                    }
                    (Outlines::Kept, _) => {
                        let (lod, outline) = self.outline_lod_for_triangles(max, view)?;
                        (lod, outline.map(Rung::from))
                    }
                    (_, None) => (self.lod_for_triangles(max, view)?, None),
                    (_, Some(rung)) => {
                        let stats = self.outline_stats(self.outline(rung));
                        (self.resolve_budget(stats, max, view)?, Some(rung))
                    }
                };
                return self.extract_as(lod, strips, Outlines::from(rung));
            }
            _ => outlines.rung(),
        };
        let forced: &[u64] = finest.map_or(&[], |rung| &self.outline(rung).forced);
        let own;
        let cut = match outlines {
            Outlines::Cut => Some(self.cut_errors()),
            Outlines::CutOrDrop(span) => {
                own = cut_errors(self.samples(), &self.err2, span, self.threads == Threads::Parallel);
                Some(&own)
            }
            _ => None,
        };
        let mut mesh = match lod {
            Lod::Epsilon(eps) => {
                if !(eps.is_finite() && eps >= 0.0) {
                    return Err(Error::invalid(format!(
                        "epsilon is {}; it must be a finite number >= 0",
                        crate::error::Shown(eps)
                    )));
                }
                let eps2 = (eps * eps) as f32;
                let sel = Static {
                    eps2: if eps2.is_finite() { eps2 } else { f32::MAX },
                    all: eps == 0.0,
                };
                self.run(&sel, strips, forced, cut).0
            }
            Lod::Tau { tau, view } => {
                if !(tau.is_finite() && tau >= 0.0) {
                    return Err(Error::invalid(format!(
                        "tau is {}; it must be a finite number of pixels >= 0",
                        crate::error::Shown(tau)
                    )));
                }
                let sel = ViewDependent::new(&self.camera, view, tau);
                let (mut mesh, walked) = self.run(&sel, strips, forced, cut);
                mesh.reach = Some(self.reach(view, walked, &sel));
                mesh
            }
            Lod::Triangles { .. } => unreachable!("resolved above"),
        };
        mesh.extract_ms = start.elapsed().as_secs_f64() * 1e3;
        if let Some(wire) = lod.wire() {
            mesh.lod = wire;
        }
        tracing::debug!(triangles = mesh.triangles.len(), ms = mesh.extract_ms, "extracted");
        Ok(mesh)
    }

    /// Walks and assembles with this thread's scratch buffers: the triangle
    /// list of the walk and the grid-sized vertex map are kept between
    /// extractions, so a request allocates only what it returns.
    fn run<S: Select>(&self, sel: &S, strips: StripOrder, forced: &[u64], cut: Option<&CutErrors>) -> (Mesh, Walked) {
        thread_local! {
            static SCRATCH: std::cell::RefCell<Scratch> = const {
                std::cell::RefCell::new(Scratch { tris: Vec::new(), slot: Vec::new() })
            };
        }
        SCRATCH.with(|cell| {
            let mut scratch = cell.borrow_mut();
            let Scratch { tris, slot } = &mut *scratch;
            tris.clear();
            let mut walked = self.walk(sel, tris, forced, cut);
            let mut mesh = self.assemble(tris, strips, slot);
            mesh.dropped_triangles = walked.dropped;
            mesh.cuts = std::mem::take(&mut walked.cuts);
            (mesh, walked)
        })
    }

    /// What a cut reads of this hierarchy (`cut.rs`).
    pub(crate) fn samples(&self) -> Samples<'_> {
        Samples {
            grid: self.grid,
            z: &self.z,
            flags: &self.flags,
        }
    }

    /// The saturated squared errors of a cutting extraction, computed on
    /// the first one (`cut_errors.rs`).
    pub(crate) fn cut_errors(&self) -> &CutErrors {
        self.outlines
            .cut(self.samples(), &self.err2, self.threads == Threads::Parallel)
    }

    /// The [`Reach`] of a view-dependent mesh for `view` from its walk.
    fn reach(&self, view: &Camera, walked: Walked, sel: &ViewDependent) -> Reach {
        let eye = self.camera.to_camera(view.translation);
        let mut culled: Vec<(DVec3, f64)> = Vec::with_capacity(walked.culled.len());
        for s in walked.culled {
            match culled.last_mut() {
                Some(last) => {
                    let merged = merge_spheres(*last, s);
                    // Still small against its distance, and still outside the frustum.
                    if merged.1 <= NEAR_CULLED * (merged.0 - eye).length()
                        && sel.cull(merged.0, merged.1, ALL_PLANES).is_none()
                    {
                        *last = merged;
                    } else {
                        culled.push(s);
                    }
                }
                None => culled.push(s),
            }
        }
        while culled.len() > MAX_CULLED {
            culled = culled
                .chunks(2)
                .map(|pair| pair.iter().copied().reduce(merge_spheres).unwrap_or(pair[0]))
                .collect();
        }
        Reach {
            view: *view,
            clearance: walked.clearance.is_finite().then_some(walked.clearance),
            culled: culled
                .into_iter()
                .map(|(c, r)| {
                    let w = self.camera.to_world(c);
                    [w.x, w.y, w.z, r]
                })
                .collect(),
        }
    }

    /// Numbers the used vertices coarse to fine and rewrites the indices.
    /// `slot` is the grid-sized vertex map kept between extractions (0: not
    /// used, else the vertex's number plus one); only its touched entries
    /// are reset, so a small mesh from a big hierarchy does not pay for
    /// clearing the whole grid. It is made zeroed by the allocator, whose
    /// fresh pages are zero already: a fresh process touches only the pages
    /// its mesh's vertices lie on (filled with a marker, the 1 MB of a
    /// 513 x 513 grid took 0.3-0.4 ms of a first extraction).
    fn assemble(&self, tris: &[[u32; 3]], order_kind: StripOrder, slot: &mut Vec<u32>) -> Mesh {
        if slot.len() < self.grid.len() {
            *slot = vec![0; self.grid.len()];
        }
        let mesh = self.assemble_with(tris, order_kind, slot);
        for v in &mesh.vertices {
            slot[self.grid.index((u32::from(v.i), u32::from(v.j)))] = 0;
        }
        mesh
    }

    fn assemble_with(&self, tris: &[[u32; 3]], order_kind: StripOrder, slot: &mut [u32]) -> Mesh {
        let g = &self.grid;
        let gw = g.gw();
        // First sight of each vertex, then a counting sort by level (stable,
        // so traversal order is kept within a level).
        let mut used: Vec<(u32, u8)> = Vec::with_capacity(tris.len() / 2 + 8);
        let mut per_level = [0u32; 2 * 16 + 2];
        for &v in tris.iter().filter(|t| **t != BREAK).flatten() {
            if slot[v as usize] == 0 {
                slot[v as usize] = 1;
                let level = g.level((v % gw, v / gw)) as u8;
                per_level[usize::from(level) + 1] += 1;
                used.push((v, level));
            }
        }
        for l in 1..per_level.len() {
            per_level[l] += per_level[l - 1];
        }
        let mut order = vec![0u32; used.len()];
        for &(v, level) in &used {
            let at = &mut per_level[usize::from(level)];
            order[*at as usize] = v;
            *at += 1;
            slot[v as usize] = *at;
        }
        let vertices = order
            .iter()
            .map(|&v| {
                let (x, y) = (v % gw, v / gw);
                MeshVertex {
                    i: x as u16,
                    j: y as u16,
                    depth: self.z[v as usize],
                    normal: self.normal[v as usize],
                    rho: self.rho[v as usize],
                }
            })
            .collect();
        let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(tris.len());
        triangles.extend(
            tris.iter()
                .filter(|t| **t != BREAK)
                .map(|t| t.map(|i| slot[i as usize] - 1)),
        );
        let strips = if order_kind == StripOrder::Traversal {
            let mut s = stripify(tris);
            for i in s.iter_mut().filter(|i| **i != super::RESTART) {
                *i = slot[*i as usize] - 1;
            }
            s
        } else if order_kind == StripOrder::Greedy {
            stripify_greedy(&triangles, order.len())
        } else {
            stripify_tunnelled(&triangles, order.len())
        };

        Mesh {
            vertices,
            strips,
            triangles,
            dropped_triangles: 0,
            extract_ms: 0.0,
            lod: dmesh_proto::Lod::Epsilon(0.0),
            reach: None,
            cuts: Vec::new(),
        }
    }
}
