//! dmesh: the service around the engine (`dmesh-engine`, named as such
//! wherever it is used, so the crate boundary shows): the HTTP service and
//! the durable store of uploaded views.
//!
//! - [`http`]: the axum service;
//! - [`service`]: between the two: the cache of built views, ingest, metrics;
//! - [`store`]: durable storage of uploaded views (the only module here that does I/O);

pub mod http;
pub mod service;
pub mod store;
