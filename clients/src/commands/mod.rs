//! The subcommands of `dmesh-client`, a file each.

pub mod compare;
pub mod decode;
mod detail;
pub mod ingest;
pub mod loadtest;
pub mod render;
pub mod report;
pub mod stream;
pub mod walkthrough;
