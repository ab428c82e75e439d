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
}

impl Lod<'_> {
    /// Its kind and tolerance, for logs: `epsilon=E` or `tau=T`.
    pub fn kind(&self) -> String {
        match self {
            Self::Epsilon(e) => format!("epsilon={e}"),
            Self::Tau { tau, .. } => format!("tau={tau}"),
        }
    }
}

/// The level of detail a budget resolved to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budgeted {
    /// Static tolerance in metres.
    Epsilon(f64),
    /// View-dependent tolerance in pixels of the requesting camera.
    Tau(f64),
}

impl Budgeted {
    /// The level of detail to extract: `view` is the requesting camera the
    /// budget was resolved for (unused for a static answer).
    pub fn lod(self, view: &Camera) -> Lod<'_> {
        match self {
            Self::Epsilon(e) => Lod::Epsilon(e),
            Self::Tau(tau) => Lod::Tau { tau, view },
        }
    }
}
