//! The render plan of a request (DMesh Sec. 6.2): what a client asks for, in
//! one place, and the steps that answer it. A request names a level of
//! detail and a depth coding ([`Ask`]); a novel view selects reference views
//! ([`select`]), shares a budget out by view weight ([`Ask::share`]), and
//! each view's hierarchy resolves its share ([`Ask::lod`]) and is extracted
//! and encoded ([`extract`]). The server's `/render` and `/strips`, the
//! `dmesh mesh` command and `dmesh-client report` all run these steps, so a
//! report measures what the server serves.

use dmesh_proto::{Lod as WireLod, RawGrid, StripResponse};

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::mesh::{Hierarchy, Lod, Outlines, StripOrder};
use crate::scene::{select_views, SelectionRule, Weighted};
use crate::wire::{strip_response, DepthCoding};

/// Views a render answers with unless asked otherwise.
pub const MAX_VIEWS: usize = 5;
/// DMesh's selection limit between view directions, degrees, unless asked otherwise.
pub const MAX_ANGLE_DEG: f64 = 135.0;

/// A level of detail with the camera it is meant for, so that `tau`
/// without a camera, or `epsilon` with one, cannot be stated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Detail {
    /// Object-space tolerance in metres; static, for no camera.
    Epsilon(f64),
    /// Image-space tolerance in pixels of the requesting camera.
    Tau {
        /// Pixels.
        tau: f64,
        /// The requesting camera.
        camera: Camera,
    },
    /// At most this many triangles, view-dependent when a camera is given.
    MaxTriangles {
        /// Triangles.
        max: u32,
        /// The requesting camera, if any.
        camera: Option<Camera>,
    },
    /// At most this many milliseconds of extraction (aimed at, not proven),
    /// view-dependent when a camera is given.
    BudgetMs {
        /// Milliseconds, finite and > 0.
        ms: f64,
        /// The requesting camera, if any.
        camera: Option<Camera>,
    },
}

/// What a request asks for: a level of detail with the requesting camera
/// it is meant for, and the depth coding. Only [`Ask::new`] makes one, and
/// it checks the combination, so every `Ask` is one the engine can answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ask {
    detail: Detail,
    bits: Option<u8>,
}

impl Ask {
    /// Checks the combination: bits at most 16, a camera with `tau` and
    /// none with `epsilon`, a positive finite time budget.
    pub fn new(lod: WireLod, camera: Option<Camera>, bits: Option<u8>) -> Result<Self> {
        if let Some(b) = bits.filter(|&b| b > dmesh_proto::residual::MAX_BITS) {
            return Err(Error::invalid(format!("bits is {b}; it must be 0..=16")));
        }
        let detail = match (lod, camera) {
            (WireLod::Epsilon(_), Some(_)) => {
                return Err(Error::invalid(
                    "camera is not used with epsilon; give tau or a budget, or drop camera",
                ))
            }
            (WireLod::Epsilon(e), None) => Detail::Epsilon(e),
            (WireLod::Tau(tau), Some(camera)) => Detail::Tau { tau, camera },
            (WireLod::Tau(_), None) => return Err(Error::invalid("tau needs the requesting camera (camera)")),
            (WireLod::MaxTriangles(max), camera) => Detail::MaxTriangles { max, camera },
            (WireLod::BudgetMs(ms), _) if !(ms.is_finite() && ms > 0.0) => {
                return Err(Error::invalid(format!(
                    "budget_ms is {}; it must be a finite number of milliseconds > 0",
                    crate::error::Shown(ms)
                )))
            }
            (WireLod::BudgetMs(ms), camera) => Detail::BudgetMs { ms, camera },
        };
        Ok(Self { detail, bits })
    }

    /// The level of detail with its camera.
    pub fn detail(&self) -> Detail {
        self.detail
    }

    /// The level of detail as the wire states it.
    pub fn wire_lod(&self) -> WireLod {
        match self.detail {
            Detail::Epsilon(e) => WireLod::Epsilon(e),
            Detail::Tau { tau, .. } => WireLod::Tau(tau),
            Detail::MaxTriangles { max, .. } => WireLod::MaxTriangles(max),
            Detail::BudgetMs { ms, .. } => WireLod::BudgetMs(ms),
        }
    }

    /// The requesting camera, if the request has one.
    pub fn camera(&self) -> Option<&Camera> {
        match &self.detail {
            Detail::Epsilon(_) => None,
            Detail::Tau { camera, .. } => Some(camera),
            Detail::MaxTriangles { camera, .. } | Detail::BudgetMs { camera, .. } => camera.as_ref(),
        }
    }

    /// Residual bit-depth of the depths, `None` for exact `f32`.
    pub fn bits(&self) -> Option<u8> {
        self.bits
    }

    /// The request one view of weight `weight` gets: budgets are shared out
    /// by weight (triangles rounded down), tolerances are not.
    pub fn share(&self, weight: f64) -> Self {
        let detail = match self.detail {
            Detail::MaxTriangles { max, camera } => Detail::MaxTriangles {
                max: (f64::from(max) * weight).floor() as u32,
                camera,
            },
            Detail::BudgetMs { ms, camera } => Detail::BudgetMs {
                ms: ms * weight,
                camera,
            },
            other => other,
        };
        Self { detail, ..*self }
    }

    /// The level of detail `hierarchy` extracts. A time budget becomes a
    /// triangle budget through `triangles_for_ms` (the caller's measured
    /// extraction rate); a triangle budget stays one, for the hierarchy to
    /// resolve. Also returns the triangles a time budget allowed.
    pub fn lod(&self, hierarchy: &Hierarchy, triangles_for_ms: impl FnOnce(f64) -> f64) -> (Lod<'_>, Option<u64>) {
        match &self.detail {
            Detail::Epsilon(e) => (Lod::Epsilon(*e), None),
            Detail::Tau { tau, camera } => (
                Lod::Tau {
                    tau: *tau,
                    view: camera,
                },
                None,
            ),
            Detail::MaxTriangles { max, camera } => (
                Lod::Triangles {
                    max: *max,
                    view: camera.as_ref(),
                },
                None,
            ),
            Detail::BudgetMs { ms, camera } => {
                // A time budget needs no proof, so it never asks for less
                // than the coarsest mesh.
                let allowed = (triangles_for_ms(*ms).max(0.0) as u64)
                    .max(hierarchy.coarsest_triangles())
                    .min(u64::from(u32::MAX));
                (
                    Lod::Triangles {
                        max: allowed as u32,
                        view: camera.as_ref(),
                    },
                    Some(allowed),
                )
            }
        }
    }

    /// The ETag suffix of a cacheable answer (static: no requesting camera).
    pub fn cache_key(&self) -> Option<String> {
        let bits = self.bits.map_or(String::new(), |b| format!("-b{b}"));
        match self.detail {
            Detail::Epsilon(e) => Some(format!("{:016x}{bits}", e.to_bits())),
            Detail::MaxTriangles { max, camera: None } => Some(format!("t{max}{bits}")),
            _ => None,
        }
    }
}

/// The reference views of `cameras` a novel camera uses, with weights
/// summing to 1: DMesh's rule within `max_angle_deg` (default
/// [`MAX_ANGLE_DEG`]) or Verlani et al.'s limited set, at most `max_views`
/// (default [`MAX_VIEWS`]).
pub fn select(
    novel: &Camera,
    cameras: &[Camera],
    selection: dmesh_proto::Selection,
    max_views: Option<u32>,
    max_angle_deg: Option<f64>,
) -> Result<Vec<Weighted>> {
    let dmesh = SelectionRule::Dmesh {
        max_angle_deg: max_angle_deg.unwrap_or(MAX_ANGLE_DEG),
    };
    // Checked whichever rule selects: a request naming an angle out of
    // range is refused even when the limited set does not use it.
    crate::scene::selection::limit_deg(dmesh)?;
    let rule = match selection {
        dmesh_proto::Selection::Dmesh => dmesh,
        dmesh_proto::Selection::Limited => SelectionRule::Limited,
    };
    select_views(novel, cameras, rule, max_views.map_or(MAX_VIEWS, |m| m as usize))
}

/// The views of a selection a triangle budget can pay for. Each view gets
/// `budget * weight` triangles, weights renormalised over the views kept
/// ([`Ask::share`]); a view whose share is below `coarsest[i]`, the fewest
/// triangles it can be meshed with, is left out, the lightest first, and
/// the rest share again. (Weights that fall to 0 continuously as a view
/// leaves the selection would otherwise give a leaving view a share no mesh
/// fits.) The heaviest view is always kept: if the budget cannot pay even
/// for it, its extraction says so. Returns the new weights, 0 for the views
/// left out, summing to 1 over the rest.
pub fn afford(weights: &[f64], coarsest: &[u64], budget: f64) -> Vec<f64> {
    let mut kept: Vec<bool> = weights.iter().map(|&w| w > 0.0).collect();
    loop {
        let total: f64 = weights.iter().zip(&kept).filter(|(_, &k)| k).map(|(w, _)| w).sum();
        let short = (0..weights.len())
            .filter(|&i| kept[i] && (budget * weights[i] / total).floor() < coarsest[i] as f64)
            .min_by(|&a, &b| weights[a].total_cmp(&weights[b]));
        match short {
            Some(i) if kept.iter().filter(|&&k| k).count() > 1 => kept[i] = false,
            _ => {
                return weights
                    .iter()
                    .zip(&kept)
                    .map(|(&w, &k)| if k { w / total } else { 0.0 })
                    .collect()
            }
        }
    }
}

/// One view's answer: the encoded response, and what a time budget allowed.
#[derive(Clone, Debug)]
pub struct Extracted {
    /// The response (its `triangles` are the mesh's).
    pub response: StripResponse,
    /// What a time budget allowed, if the request had one.
    pub allowed: Option<u64>,
}

/// Extracts `hierarchy` (the view `scene/view`, stored at `raw_grid`) for
/// `ask` and encodes it; `triangles_for_ms` as in [`Ask::lod`].
pub fn extract(
    hierarchy: &Hierarchy,
    raw_grid: Option<RawGrid>,
    scene: &str,
    view: &str,
    ask: &Ask,
    triangles_for_ms: impl FnOnce(f64) -> f64,
) -> Result<Extracted> {
    let (mesh, allowed) = extract_mesh(hierarchy, ask, Outlines::Kept, triangles_for_ms)?;
    let coding = DepthCoding {
        bits: ask.bits(),
        root_side: hierarchy.grid().side(),
        raw_grid,
    };
    let response =
        strip_response(&mesh, scene, view, hierarchy.camera(), coding).map_err(|e| Error::invalid(e.to_string()))?;
    Ok(Extracted { response, allowed })
}

/// Extracts `hierarchy` for `ask` with the `outlines` of the answer's
/// wire (kept for protocol 5's strips, cut for the compact stream's), and
/// `triangles_for_ms` as in [`Ask::lod`]; with what a time budget allowed.
///
/// A time budget promises no triangle count, so with outlines cut it is
/// resolved as the outlines-dropped budget is, from the error statistics,
/// and extracted once: a counted cut budget (`cut_budget.rs`) bisects over
/// about 20 extractions, forty times the time it was given. The cut mesh
/// may draw more than the triangles the time allowed; the server's
/// measured fill of its budgets scales the next ones to match.
pub fn extract_mesh(
    hierarchy: &Hierarchy,
    ask: &Ask,
    outlines: Outlines,
    triangles_for_ms: impl FnOnce(f64) -> f64,
) -> Result<(crate::mesh::Mesh, Option<u64>)> {
    let (lod, allowed) = ask.lod(hierarchy, triangles_for_ms);
    let lod = match (lod, allowed, outlines) {
        (Lod::Triangles { max, view }, Some(_), Outlines::Cut | Outlines::CutOrDrop(_)) => {
            hierarchy.lod_for_triangles(u64::from(max), view)?
        }
        _ => lod,
    };
    Ok((hierarchy.extract_as(lod, StripOrder::Traversal, outlines)?, allowed))
}

#[cfg(test)]
mod tests {
    /// An angle out of range is refused under either rule, before any view
    /// is looked at; in range, the limited set still ignores it.
    #[test]
    fn an_angle_out_of_range_is_refused_under_either_rule() {
        use dmesh_proto::Selection;
        let cam = crate::camera::Camera::perspective(8, 8, 8.0, 8.0, 3.5, 3.5).unwrap();
        for selection in [Selection::Dmesh, Selection::Limited] {
            for bad in [-1.0, 180.5, 6.1e307, f64::NAN] {
                let err = super::select(&cam, &[cam], selection, None, Some(bad)).unwrap_err();
                let err = err.to_string();
                assert!(err.contains("max_angle_deg"), "{selection:?} {bad}: {err}");
                assert!(err.len() < 80, "the value is quoted short: {err}");
            }
            assert_eq!(
                super::select(&cam, &[cam], selection, None, Some(10.0)).unwrap().len(),
                1
            );
        }
    }

    #[test]
    fn a_budget_leaves_out_the_views_whose_share_no_mesh_fits() {
        // 1000 triangles over weights 0.6, 0.3995, 0.0005: the last gets
        // half a triangle, below its coarsest 8; the rest share again.
        let w = super::afford(&[0.6, 0.3995, 0.0005], &[8, 8, 8], 1000.0);
        assert_eq!(w[2], 0.0);
        assert!((w[0] - 0.6 / 0.9995).abs() < 1e-12 && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        // Everything affordable: unchanged.
        assert_eq!(super::afford(&[0.5, 0.5], &[8, 8], 1000.0), vec![0.5, 0.5]);
        // Not even the heaviest: it stays, alone, for its extraction to refuse.
        assert_eq!(super::afford(&[0.7, 0.3], &[800, 800], 1000.0), vec![1.0, 0.0]);
    }

    use super::*;

    fn cam() -> Camera {
        Camera::perspective(8, 6, 8.0, 8.0, 3.5, 2.5).unwrap()
    }

    #[test]
    fn asks_are_checked_and_budgets_shared_by_weight() {
        let c = cam();
        assert!(Ask::new(WireLod::Epsilon(0.01), Some(c), None).is_err());
        assert!(Ask::new(WireLod::Tau(1.0), None, None).is_err());
        assert!(Ask::new(WireLod::BudgetMs(0.0), None, None).is_err());
        assert!(Ask::new(WireLod::Epsilon(0.01), None, Some(17)).is_err());
        let a = Ask::new(WireLod::MaxTriangles(1001), Some(c), Some(8)).unwrap();
        assert_eq!(a.share(0.5).wire_lod(), WireLod::MaxTriangles(500));
        assert_eq!(a.share(0.5).bits(), Some(8));
        assert_eq!(a.share(0.5).camera(), Some(&c));
        let t = Ask::new(WireLod::Tau(2.0), Some(c), None).unwrap();
        assert_eq!(t.share(0.25).detail(), Detail::Tau { tau: 2.0, camera: c });
        assert!(t.cache_key().is_none() && a.cache_key().is_none());
        assert!(Ask::new(WireLod::MaxTriangles(9), None, None)
            .unwrap()
            .cache_key()
            .is_some());
    }
}
