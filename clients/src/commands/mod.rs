//! The longer subcommands of `dmesh-client`, a file each; the short ones
//! stay in `main.rs`.

pub mod report;
pub mod walkthrough;
