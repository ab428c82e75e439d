//! `dmesh-client stream`: one view's depth replaced as a live sequence at a
//! fixed rate (a depth camera's video), with the achieved rate and the
//! upload times (DMesh Sec. 1: depth images "updated dynamically at
//! run-time"; issue 27).
//!
//! Frames come from a folder (depth files in name order, one camera and one
//! colour image) or from a simulated scene whose objects move
//! (`SceneSpec::swayed`), seen from the scene's first reference camera. Each frame is sent at its due
//! time, or at once when the previous upload ended after it: a late frame is
//! sent late, never skipped, so the achieved rate says whether the server
//! keeps up.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use dmesh_client::http::Server;

use crate::{png, read, scene_spec};

use dmesh_engine::sim::SWAY_PERIOD_S as PERIOD_S;
/// Distinct frames of a simulated scene rendered before sending (a period
/// at most; the sequence repeats them).
const MAX_SIMULATED: u32 = 120;

/// Options of `dmesh-client stream`.
#[derive(clap::Args, Debug)]
pub struct StreamArgs {
    /// Server base URL.
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub server: String,
    /// Scene id.
    #[arg(long)]
    pub scene: String,
    /// View id the frames replace.
    #[arg(long, default_value = "live")]
    pub view: String,
    /// Simulate frames from this scene file (or `demo`), its objects swaying.
    #[arg(long, conflicts_with = "dir")]
    pub simulate: Option<String>,
    /// Frames from a folder: depth files (PFM, PGM, PNG or EXR) in name
    /// order, `camera.json`, and `color.png` (or `.jpg`).
    #[arg(long)]
    pub dir: Option<PathBuf>,
    /// Frames per second offered.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f64,
    /// Frames to send (default: every frame of --dir, or 10 s of --simulate).
    #[arg(long)]
    pub frames: Option<u32>,
    /// Depth container of simulated frames: pfm (f32 metres) or pgm
    /// (16-bit millimetres, `scale` 0.001; the lattice is kept).
    #[arg(long, default_value = "pfm")]
    pub format: String,
    /// Send frames as a live view's (`?live=true`): visible at once, made
    /// durable by the server within its `--live-persist-secs`.
    #[arg(long)]
    pub live: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// One frame to send: depth bytes and the form fields that read them.
struct Frame {
    depth: Vec<u8>,
    fields: Vec<(&'static str, String)>,
}

/// The sequence: camera JSON, colour image, and the distinct frames.
struct Sequence {
    camera: String,
    color: Vec<u8>,
    frames: Vec<Frame>,
}

/// What a run measured.
#[derive(Debug, serde::Serialize)]
pub struct Summary {
    /// Frames per second offered.
    pub offered_fps: f64,
    /// Frames stored per second: the frames after the first over the time
    /// from the first send to the last frame stored (the offered rate when
    /// the server keeps up).
    pub achieved_fps: f64,
    /// Frames sent.
    pub frames: u32,
    /// Frames the server refused or that failed.
    pub failed: u32,
    /// Frames sent after their due time.
    pub late: u32,
    /// Upload round trip, median and 99th percentile, milliseconds.
    pub upload_p50_ms: f64,
    /// 99th percentile.
    pub upload_p99_ms: f64,
    /// The server's build time per frame, median, milliseconds.
    pub build_p50_ms: f64,
    /// Seconds the run took.
    pub seconds: f64,
}

fn simulated(name: &str, fps: f64, count: u32, format: &str) -> Result<Sequence> {
    let spec = scene_spec(name)?;
    let camera = *spec
        .rig
        .cameras(spec.width, spec.height, spec.fov_deg)?
        .first()
        .context("the scene's rig has no camera")?;
    let distinct = count.min(MAX_SIMULATED).min((fps * PERIOD_S).ceil() as u32).max(1);
    let mut color = Vec::new();
    let mut frames = Vec::with_capacity(distinct as usize);
    for k in 0..distinct {
        let moved = spec.swayed(f64::from(k) / fps);
        let view = dmesh_engine::sim::render_view(&moved, &camera, true, u64::from(k))?;
        if k == 0 {
            color = png(view.color.width, view.color.height, &view.color.rgb)?;
        }
        let (w, h) = (view.depth.width, view.depth.height);
        frames.push(match format {
            "pfm" => Frame {
                depth: dmesh_engine::image::encode_pfm(w, h, &view.depth.z),
                fields: Vec::new(),
            },
            "pgm" => {
                // Millimetres; 0 (no return) and depths past 65.535 m are invalid samples.
                let mm: Vec<u16> = view
                    .depth
                    .z
                    .iter()
                    .map(|&z| {
                        let v = (f64::from(z) * 1000.0).round();
                        if v > 0.0 && v <= 65535.0 {
                            v as u16
                        } else {
                            0
                        }
                    })
                    .collect();
                Frame {
                    depth: dmesh_engine::image::pgm::encode16(w, h, &mm),
                    fields: vec![("scale", "0.001".to_string())],
                }
            }
            other => bail!("--format is {other}; use pfm or pgm"),
        });
    }
    Ok(Sequence {
        camera: serde_json::to_string(&dmesh_proto::Camera::from(&camera))?,
        color,
        frames,
    })
}

fn from_dir(dir: &Path) -> Result<Sequence> {
    let camera = String::from_utf8(read(&dir.join("camera.json"))?)?;
    let color = ["color.png", "color.jpg", "color.jpeg"]
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.exists())
        .with_context(|| format!("no color.png or color.jpg in {}", dir.display()))?;
    let mut depths: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
            let ext = p.extension().and_then(|s| s.to_str()).unwrap_or_default();
            !stem.starts_with("color") && ["pfm", "pgm", "png", "exr"].contains(&ext)
        })
        .collect();
    depths.sort();
    if depths.is_empty() {
        bail!("no depth frames (.pfm, .pgm, .png, .exr) in {}", dir.display());
    }
    let frames = depths
        .iter()
        .map(|p| {
            Ok(Frame {
                depth: read(p)?,
                fields: Vec::new(),
            })
        })
        .collect::<Result<_>>()?;
    Ok(Sequence {
        camera,
        color: read(&color)?,
        frames,
    })
}

/// Percentile `q` of `v` (sorted here); 0 when empty.
fn percentile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// Sends the sequence `args` names and reports what it measured.
pub async fn stream(args: &StreamArgs) -> Result<Summary> {
    if !(args.fps.is_finite() && args.fps > 0.0 && args.fps <= 1000.0) {
        bail!("--fps is {}; it must be between 0 and 1000", args.fps);
    }
    if args.frames == Some(0) {
        bail!("--frames must be at least 1");
    }
    let (sequence, count) = match (&args.simulate, &args.dir) {
        (Some(name), _) => {
            let count = args.frames.unwrap_or((10.0 * args.fps).ceil() as u32);
            (simulated(name, args.fps, count, &args.format)?, count)
        }
        (None, Some(dir)) => {
            let s = from_dir(dir)?;
            let count = args.frames.unwrap_or(s.frames.len() as u32);
            (s, count)
        }
        _ => bail!("give --simulate SCENE_FILE (or demo) or --dir DIR"),
    };
    let server = Server::new(&args.server, None);
    let interval = Duration::from_secs_f64(1.0 / args.fps);
    let (mut uploads, mut builds) = (Vec::new(), Vec::new());
    let (mut failed, mut late) = (0u32, 0u32);
    let start = Instant::now();
    let mut last_stored = start;
    for k in 0..count {
        let due = start + interval * k;
        let now = Instant::now();
        if now < due {
            tokio::time::sleep(due - now).await;
        } else if k > 0 && now > due + interval / 10 {
            late += 1;
        }
        let frame = &sequence.frames[k as usize % sequence.frames.len()];
        let sent = Instant::now();
        match server
            .put_frame(
                &args.scene,
                &args.view,
                &sequence.camera,
                &frame.depth,
                &sequence.color,
                &frame.fields,
                args.live,
            )
            .await
        {
            Ok(summary) => {
                uploads.push(sent.elapsed().as_secs_f64() * 1e3);
                builds.push(summary.build_ms);
                last_stored = Instant::now();
            }
            Err(e) => {
                failed += 1;
                if failed == 1 {
                    eprintln!("\nframe {k}: {e:#}");
                }
            }
        }
        let elapsed = start.elapsed().as_secs_f64();
        crate::progress("stream", k + 1, count, *uploads.last().unwrap_or(&0.0));
        if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            eprint!(" {:.1} fps", f64::from(k + 1) / elapsed.max(1e-9));
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        eprintln!();
    }
    if failed == count {
        bail!("every frame failed");
    }
    let stored = count - failed;
    let span = (last_stored - start).as_secs_f64();
    Ok(Summary {
        offered_fps: args.fps,
        achieved_fps: if stored > 1 {
            f64::from(stored - 1) / span
        } else {
            f64::from(stored) / span
        },
        frames: count,
        failed,
        late,
        upload_p50_ms: percentile(&mut uploads, 0.5),
        upload_p99_ms: percentile(&mut uploads, 0.99),
        build_p50_ms: percentile(&mut builds, 0.5),
        seconds,
    })
}

/// Runs `stream` and prints its summary.
pub fn run(args: StreamArgs, rt: &tokio::runtime::Runtime) -> Result<()> {
    let s = rt.block_on(stream(&args))?;
    if args.json {
        println!("{}", serde_json::to_string(&s)?);
    } else {
        println!(
            "| offered fps | achieved fps | frames | failed | late | upload p50 ms | upload p99 ms | build p50 ms |"
        );
        println!("|---|---|---|---|---|---|---|---|");
        println!(
            "| {:.1} | {:.1} | {} | {} | {} | {:.1} | {:.1} | {:.1} |",
            s.offered_fps, s.achieved_fps, s.frames, s.failed, s.late, s.upload_p50_ms, s.upload_p99_ms, s.build_p50_ms
        );
    }
    Ok(())
}
