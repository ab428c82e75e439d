//! The depth-mesh: a multiresolution restricted-quadtree triangulation of one
//! depth image (DMesh Sec. 3-5).
//!
//! - [`grid`]: the forest grid and the 4-8 hierarchy's geometry (Sec. 3, Fig. 1-3);
//! - [`border`]: a padded grid's image border, always refined so that the
//!   padding never eats into the image;
//! - [`error_metric`]: Eq. 1 and Eq. 2, squared and division-safe;
//! - `deviation`: the exact depth deviation of a hierarchy triangle;
//! - [`normals`]: per-vertex normals and quality rho (Sec. 4.2);
//! - [`derived_normals`]: the same, derived from a decoded mesh where the compact stream lands;
//! - [`segmentation`]: orthogonality, disparity, connectedness, gated by lambda (Sec. 5.2);
//! - `flags`: segmentation flags and their OR/AND propagation (Sec. 5.3);
//! - [`hierarchy`]: the build, on one thread or two (Sec. 4.2, 5.3);
//! - `levels`: its bottom-up pass: saturated errors, nested radii and
//!   propagated segmentation flags (Sec. 4.2, 5.3), with `finest`: the
//!   finest level in branch-free row sweeps;
//! - [`lod`]: the level of detail of an extraction, and what a budget resolves to;
//! - `select`: static (Eq. 3) and view-dependent (Eq. 4) selection;
//! - [`extract`]: the top-down traversal emitting a conforming mesh (Sec. 4.3-4.4);
//! - `outline`: outlines kept at any level of detail, refining the coarse
//!   triangles a discontinuity crosses, with the budget counting them (Sec. 5.3);
//! - [`cut`]: outlines as cuts, a triangle that a discontinuity crosses
//!   drawn as two parts on either side of one straight cut, with
//!   `cut_errors`: the saturated errors of an extraction that cuts, and
//!   `cut_budget`: a triangle budget met with cuts counted;
//! - `surface_side`: which of those triangles hold the near surface, so a
//!   refinement may spare the far side;
//! - [`strips`]: generalised strips with primitive restart (Fig. 13): the
//!   traversal's order, greedy strips over the adjacency, and tunnels
//!   joining them weighed by their index count.

mod backproject;
pub mod border;
pub mod budget;
mod coarse_rows;
pub mod cut;
mod cut_budget;
mod cut_errors;
pub mod derived_normals;
mod deviation;
mod deviation_bound;
mod deviation_f32;
pub mod error_metric;
pub mod extract;
mod finest;
mod flags;
pub mod grid;
pub mod hierarchy;
mod level_deviations;
mod level_one_shared;
mod level_row_scan;
mod levels;
pub mod lod;
pub mod normals;
pub(crate) mod outline;
pub mod reach;
pub mod segmentation;
pub mod segmentation_spec;
mod select;
mod small_half_sweep;
mod split_order;
pub mod strips;
mod surface_side;

pub use cut::CutTriangle;
pub use extract::{Mesh, MeshVertex, Outlines};
pub use grid::Grid;
pub use hierarchy::{BuildStats, Hierarchy, Stages, Threads};
pub use lod::Lod;
pub use reach::{Reach, MAX_CULLED};
pub use segmentation::{Method, Segmentation};
pub use segmentation_spec::{SegmentMethod, SegmentationSpec};
pub use strips::{decode_strips, StripOrder, RESTART};
