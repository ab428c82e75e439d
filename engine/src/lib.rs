//! The dmesh engine: multiresolution depth-meshes from depth images
//! (Pajarola, Sainz and Meng, "DMesh: fast depth-image meshing and
//! warping", 2003), with no HTTP, no async and no store. The server
//! (`dmesh`) and the clients (`dmesh-client`, third parties) build on it.
//!
//! - `baselines` (feature `baselines`, which `qem` implies): the thesis's
//!   baseline meshers beside the restricted quadtree;
//! - [`camera`]: intrinsics, pose, projection and back-projection;
//! - [`image`]: decoding depth (EXR, PNG, PFM) and colour, conversion to `z`;
//! - [`mesh`]: the hierarchy, its error metric, segmentation and extraction;
//! - [`ply`]: binary PLY output of an extracted mesh;
//! - [`render_plan`]: what a request asks for and the steps that answer it
//!   (select, share, resolve, extract, encode), for the server and the report;
//! - [`scene`]: reference-view selection and weights for a novel camera;
//! - [`sim`]: the scene simulator with ground truth;
//! - [`simd`]: run-time dispatch of the build's hot loops to AVX2 or AVX-512;
//! - [`synthetic`]: built-in synthetic depth maps;
//! - [`wire`]: extracted meshes as `dmesh-proto` strip responses;
//! - [`wire_compact`]: extracted meshes as protocol 7, the compact stream, and back.
//!
//! ```
//! use dmesh_engine::{camera::Camera, image::DepthImage, mesh::{Hierarchy, Lod, Segmentation}};
//! let camera = Camera::perspective(64, 48, 60.0, 60.0, 31.5, 23.5)?;
//! let depth = DepthImage::from_z(64, 48, vec![2.0; 64 * 48])?;
//! let hierarchy = Hierarchy::build(&depth, &camera, &Segmentation::default())?;
//! let mesh = hierarchy.extract(Lod::Epsilon(0.001))?;
//! assert!(mesh.triangles.len() >= 2);
//! # Ok::<(), dmesh_engine::Error>(())
//! ```

#[cfg(feature = "baselines")]
pub mod baselines;
pub mod camera;
mod error;
pub mod image;
pub mod mesh;
pub mod ply;
pub mod render_plan;
pub mod scene;
pub mod sim;
#[allow(unsafe_code)]
pub mod simd;
pub mod synthetic;
pub mod wire;
pub mod wire_compact;

pub use error::{Error, Result};

/// The value `name` stands for in a table of names (an enum's `NAMES`, as
/// [`image::DepthKind::NAMES`]): the one lookup every `FromStr` of such an
/// enum makes.
pub fn by_name<T: Copy>(names: &[(&str, T)], name: &str) -> Option<T> {
    names.iter().find(|(n, _)| *n == name).map(|&(_, value)| value)
}
