//! dmesh's thin client: talks to the server only through HTTP and
//! `dmesh-proto`, and blends the served strips into novel views on the CPU.
//! It links the engine (`dmesh-engine`: decoding, cameras, the simulator,
//! the render plan the report runs in process), never the server
//! (`tests/dependencies.rs` checks the tree).
//!
//! - [`blend`]: the two-pass epsilon-z-buffer blend of DMesh Sec. 6.3-6.4 and
//!   Verlani Sec. 3, with perspective-correct interpolation;
//! - [`holes`]: filling the seams of at most a few pixels a blend leaves,
//!   depth-aware;
//! - [`compare`]: PSNR on the valid mask and inverse-depth RMSE;
//! - [`http`]: the server calls (upload, render, colour with an ETag cache);
//! - [`novel`]: a novel view end to end (render request, textures, blend);
//! - [`loadtest`]: a bounded load generator for `/render`.

pub mod blend;
pub mod compare;
pub mod holes;
pub mod http;
pub mod loadtest;
pub mod novel;
pub mod report;
pub mod walkthrough;
