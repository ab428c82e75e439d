//! `dmesh`: command-line front end of the depth-mesh engine.
//!
//! - `dmesh demo`: meshes a built-in synthetic scene, no files needed;
//! - `dmesh serve`: the service;
//! - `dmesh mesh`: meshes one depth image (EXR, PNG, PFM) for a camera and
//!   writes a summary, JSON figures and optionally a binary PLY.
//!
//! Every failure exits non-zero with one line naming the problem.

use dmesh_cli as cli;
mod commands {
    pub mod demo;
    pub mod demo_live;
    pub mod mesh;
    pub mod serve;
}

/// mimalloc rather than the system allocator: freed build arrays stay with
/// the process instead of being faulted in again by the next build (the
/// root `Cargo.toml` says what it saves).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use commands::mesh::MeshArgs;
use commands::serve::ServeArgs;

#[derive(Parser)]
#[command(
    name = "dmesh",
    version,
    about = "Multiresolution depth-meshes from depth images (DMesh)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Mesh one depth image.
    Mesh(Box<MeshArgs>),
    /// Serve views over HTTP from the embedded store or an object store.
    Serve(ServeArgs),
    /// Mesh a built-in synthetic scene (terrain with boxes) at several tolerances.
    Demo {
        /// Image width and height of the scene.
        #[arg(long, default_value_t = 513)]
        size: u32,
        /// Write the epsilon = 0.01 mesh to this binary PLY file.
        #[arg(long)]
        ply: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    let cli = match cli::parse::<Cli>() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    cli::init_logging();
    cli::finish(match &cli.command {
        Command::Mesh(a) => commands::mesh::run(a),
        Command::Demo { size, ply } => commands::demo::run(*size, ply.as_deref()),
        Command::Serve(a) => commands::serve::run(a),
    })
}
