//! The longer subcommands of `dmesh-client`, a file each; the short ones
//! stay in `main.rs`.

pub mod decode;
pub mod report;
pub mod stream;
pub mod walkthrough;
