//! dmesh: the service around the engine (`dmesh-engine`, re-exported here
//! so that `dmesh::mesh` and friends keep their paths): the HTTP service and
//! the durable store of uploaded views.
//!
//! - [`http`]: the axum service;
//! - [`service`]: between the two: the cache of built views, ingest, metrics;
//! - [`store`]: durable storage of uploaded views (the only module here that does I/O);
//! - [`camera`], [`image`], [`mesh`], [`ply`], [`render_plan`], [`scene`], [`sim`],
//!   [`synthetic`], [`wire`]: the engine's modules.

pub mod http;
pub mod service;
pub mod store;

pub use dmesh_engine::{camera, image, mesh, ply, render_plan, scene, sim, synthetic, wire, Error, Result};
