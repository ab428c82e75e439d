//! Scene simulator with ground truth (no HTTP): analytic scenes, camera rigs,
//! ray-cast reference views (depth and colour) and ground-truth novel views.
//!
//! Scenes are plain data ([`SceneSpec`], JSON) so users can write their own.
//! Colour is the procedural albedo at the hit point, with no lighting unless
//! the scene asks for specular highlights, so a view-independent scene is
//! reproduced exactly by warping. Sensor effects (noise, disparity
//! quantisation, holes, flying pixels, highlights) are applied only when the
//! scene lists them: a scene without effects renders exact depth.

pub mod effects;
pub mod objects;
pub mod render;
pub mod rig;
pub mod spec;

pub use render::{render_view, RenderedView};
pub use spec::{SceneSpec, SWAY_M, SWAY_PERIOD_S};
