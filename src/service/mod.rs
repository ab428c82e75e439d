//! The service layer between HTTP and the engine: what the server keeps
//! (the store, the cache of built views with their revalidation, metrics),
//! and ingest, the upload pipeline. The HTTP handlers (`http/`) and
//! `dmesh serve --demo` call it; the render plan it serves is the engine's
//! (`dmesh_engine::render_plan`), which the report runs too. It knows
//! nothing of axum.
//!
//! - [`state`]: the store, the cache, revalidation, changes;
//! - [`ingest`]: decode, mask, check, build and store one view;
//! - [`render`]: strip and render requests answered (selection, loading,
//!   budget shares, extraction, encoding, timings);
//! - [`views`]: a view loaded, its summary and colour URL;
//! - [`metrics`]: Prometheus counters and the extraction-rate estimate;
//! - [`stream_tag`]: the self-describing ETags of compact responses;
//! - [`error`]: the one error type.

pub mod error;
pub mod ingest;
pub mod metrics;
pub mod render;
pub mod state;
pub mod stream_tag;
pub mod views;

pub use error::AppError;
pub use state::{AppState, Loaded, Settings, DEFAULT_REVALIDATE};
