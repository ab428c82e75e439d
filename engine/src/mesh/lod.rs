//! The level of detail of an extraction: a static tolerance (DMesh Eq. 3)
//! or a view-dependent one (Eq. 4), and what a triangle budget resolves to
//! (`budget.rs`, after Qu et al. Sec. 3.4).

use crate::camera::Camera;

/// Level of detail of an extraction.
#[derive(Clone, Copy, Debug)]
pub enum Lod<'a> {
    /// Static: object-space tolerance `epsilon` in metres (Eq. 3); 0 is full resolution.
    Epsilon(f64),
    /// View-dependent: `tau` pixels in the requesting camera `view` (Eq. 4), whose
    /// pose is in the same world as the reference camera's; 0 is full
    /// resolution inside the view.
    Tau {
        /// Tolerance in pixels of `view`.
        tau: f64,
        /// The requesting camera.
        view: &'a Camera,
    },
    /// At most `max` triangles, view-dependent for `view` or static: the
    /// hierarchy resolves it to the finest `Epsilon` or `Tau` whose mesh
    /// provably fits ([`crate::mesh::Hierarchy::lod_for_triangles`]).
    Triangles {
        /// Most triangles (`u32`, as on the wire).
        max: u32,
        /// The requesting camera, if any.
        view: Option<&'a Camera>,
    },
}

impl Lod<'_> {
    /// Its kind and value, for logs: `epsilon=E`, `tau=T` or `max_triangles=N`.
    pub fn kind(&self) -> String {
        match self {
            Self::Epsilon(e) => format!("epsilon={e}"),
            Self::Tau { tau, .. } => format!("tau={tau}"),
            Self::Triangles { max, .. } => format!("max_triangles={max}"),
        }
    }

    /// The tolerance as the wire states it (`None` for an unresolved budget).
    pub fn wire(&self) -> Option<dmesh_proto::Lod> {
        match *self {
            Self::Epsilon(e) => Some(dmesh_proto::Lod::Epsilon(e)),
            Self::Tau { tau, .. } => Some(dmesh_proto::Lod::Tau(tau)),
            Self::Triangles { .. } => None,
        }
    }
}
