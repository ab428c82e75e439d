//! `dmesh-client`: ingest views, render novel views by blending, compare
//! images, load, stream, walk through and report; a file per subcommand in
//! `commands/` (`dmesh-client --help` lists them). This file holds the
//! command line and the few helpers the subcommands share.
//!
//! Every failure exits non-zero with one line naming the problem.

// The command-line glue both binaries share (`dmesh-cli`).
use dmesh_cli as cli;
mod commands;

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "dmesh-client", version, about = "Thin client of a dmesh server")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Upload a simulated scene or a folder of views.
    Ingest(commands::ingest::IngestArgs),
    /// Render a novel view by blending the server's strips.
    Render(commands::render::RenderArgs),
    /// Load the server's /render with novel cameras on an orbit (bounded; loopback only by default).
    Loadtest(commands::loadtest::LoadtestArgs),
    /// Sweep tau, epsilon, residual bits and triangle budgets over scenes with
    /// ground truth (simulated, and Middlebury with --data): tables and curves.
    /// With --baselines, compare the thesis's meshers with the RQT instead.
    Report(commands::report::ReportArgs),
    /// Decode a compact body (protocol 7, `application/vnd.dmesh.mesh`) and
    /// print it as protocol 5 JSON: vertices, derived normals and rho, depths, triangles.
    Decode(commands::decode::DecodeArgs),
    /// Move along a camera path, drawing every frame from held meshes and
    /// fetching by strategy (Qu et al.'s workload balancing); prints the
    /// frame-time comparison of the strategies run.
    Walkthrough(commands::walkthrough::WalkthroughArgs),
    /// Replace one view's depth as a live sequence at a fixed rate (a folder
    /// of frames, or a simulated scene whose objects sway): progress, then
    /// the achieved rate and upload times.
    Stream(commands::stream::StreamArgs),
    /// PSNR (valid mask) and inverse-depth RMSE between two images.
    Compare(commands::compare::CompareArgs),
}

/// One progress line on stderr, redrawn in place on a terminal (every 50
/// frames and at the end otherwise, so a log stays readable).
fn progress(what: &str, done: u32, total: u32, last_ms: f64) {
    use std::io::IsTerminal;
    let tty = std::io::stderr().is_terminal();
    if !tty && done % 50 != 0 && done != total {
        return;
    }
    let width = 30usize;
    let filled = (width as u64 * u64::from(done) / u64::from(total.max(1))) as usize;
    let bar: String = "#".repeat(filled) + &"-".repeat(width - filled);
    let end = if tty { "\r" } else { "\n" };
    eprint!("{what:>9} [{bar}] {done}/{total} frames, last {last_ms:.1} ms{end}");
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))
}

fn png(width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    let img = image::RgbImage::from_raw(width, height, rgb.to_vec()).context("image buffer size")?;
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)?;
    Ok(out)
}

fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    dmesh_engine::image::decode_pfm(&read(path)?, &Default::default())
        .with_context(|| format!("depth {}", path.display()))
}

/// A scene file, or `demo` for the built-in box scene.
fn scene_spec(name: &str) -> Result<dmesh_engine::sim::SceneSpec> {
    Ok(if name == "demo" {
        dmesh_engine::sim::SceneSpec::demo()
    } else {
        dmesh_engine::sim::SceneSpec::from_json(&String::from_utf8(read(Path::new(name))?)?)?
    })
}

fn run(cli: Cli) -> Result<()> {
    // One thread: the client waits on the network, and a load test on the
    // server's machine should take as little of it as it can.
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    match cli.command {
        Command::Ingest(args) => commands::ingest::run(args, &rt),
        Command::Render(args) => commands::render::run(args, &rt),
        Command::Loadtest(args) => commands::loadtest::run(args, &rt),
        Command::Compare(args) => commands::compare::run(args),
        Command::Report(args) => commands::report::run(args),
        Command::Decode(args) => commands::decode::run(args),
        Command::Walkthrough(args) => commands::walkthrough::run(args, &rt),
        Command::Stream(args) => commands::stream::run(args, &rt),
    }
}

fn main() -> ExitCode {
    match cli::parse::<Cli>() {
        Ok(cli) => {
            cli::init_logging();
            cli::finish(run(cli))
        }
        Err(code) => code,
    }
}
