//! `dmesh-client walkthrough`: a camera path drawn from held meshes, with
//! the fetching strategies compared (`dmesh_client::walkthrough`).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use dmesh_client::http::Server;

use crate::{progress, read, scene_spec};

/// The options of `dmesh-client walkthrough` (their help is the subcommand's).
#[derive(clap::Args, Debug)]
pub struct WalkthroughArgs {
    /// Server base URL.
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub server: String,
    /// Scene id.
    #[arg(long)]
    pub scene: String,
    /// The path file (JSON: key cameras and a frame count).
    #[arg(long)]
    pub path: PathBuf,
    /// Strategies, comma separated: full, keyframe, balanced (or all).
    #[arg(long, default_value = "all")]
    pub strategy: String,
    /// Frames between keyframes of the keyframe strategy.
    #[arg(long, default_value_t = 10)]
    pub keyframe_every: u32,
    /// Balanced refresh budget per frame in triangles (default: one held view's worth).
    #[arg(long, conflicts_with_all = ["budget_ms", "budget_bytes"])]
    pub budget_triangles: Option<f64>,
    /// Balanced refresh budget per frame in request milliseconds.
    #[arg(long, conflicts_with = "budget_bytes")]
    pub budget_ms: Option<f64>,
    /// Balanced refresh budget per frame in response bytes.
    #[arg(long)]
    pub budget_bytes: Option<f64>,
    /// View-dependent tolerance, pixels.
    #[arg(long, default_value_t = dmesh_client::walkthrough::policy::DEFAULT_TAU)]
    pub tau: f64,
    /// A held mesh is refetched once its error bound passes tau times this.
    #[arg(long, default_value_t = dmesh_client::walkthrough::policy::DEFAULT_STALE_FACTOR)]
    pub stale_factor: f64,
    /// Balanced: a held mesh older than this many frames is refreshed
    /// before any younger one, past the budget if need be (Qu et al.'s age
    /// threshold); 0 for no cap.
    #[arg(long, default_value_t = dmesh_client::walkthrough::policy::DEFAULT_MAX_AGE)]
    pub max_age: u32,
    /// Guard band: request a frustum wider by this fraction of the image on each side.
    #[arg(long, default_value_t = 0.15)]
    pub guard: f64,
    /// Residual bit-depth of the depths (0-16; default exact).
    #[arg(long)]
    pub bits: Option<u8>,
    /// How meshes travel: the compact stream (protocol 7, zstd) or protocol 5 bincode.
    #[arg(long, value_enum, default_value = "compact")]
    pub wire: dmesh_client::http::Wire,
    /// Refresh held meshes whole, not by the change from the held one (compact wire).
    #[arg(long)]
    pub whole: bool,
    /// Most views a frame draws.
    #[arg(long, default_value_t = 5)]
    pub max_views: usize,
    /// Write every frame's image under DIR/STRATEGY/.
    #[arg(long)]
    pub frames_out: Option<PathBuf>,
    /// The scene file (or `demo`) to render ground truth from: PSNR, inverse-depth RMSE, coverage per frame.
    #[arg(long)]
    pub truth: Option<String>,
    /// Write NAME.csv, NAME.json and the frame-time and PSNR plots here (NAME: the path file's stem).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the summaries as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Walks the path with every strategy asked for and prints their comparison.
pub fn run(args: WalkthroughArgs, rt: &tokio::runtime::Runtime) -> Result<()> {
    let WalkthroughArgs {
        server,
        scene,
        path,
        strategy,
        keyframe_every,
        budget_triangles,
        budget_ms,
        budget_bytes,
        tau,
        stale_factor,
        max_age,
        guard,
        bits,
        wire,
        whole,
        max_views,
        frames_out,
        truth,
        out,
        json,
    } = args;
    use dmesh_client::walkthrough::{self, policy};
    if !(tau.is_finite() && tau > 0.0) {
        bail!("--tau is {tau}; it must be a positive number of pixels");
    }
    if !(stale_factor.is_finite() && stale_factor >= 1.0) {
        bail!("--stale-factor is {stale_factor}; it must be at least 1");
    }
    if !(guard.is_finite() && (0.0..=1.0).contains(&guard)) {
        bail!("--guard is {guard}; it must be between 0 and 1");
    }
    if keyframe_every == 0 {
        bail!("--keyframe-every must be at least 1");
    }
    if bits.is_some_and(|b| b > 16) {
        bail!("--bits must be 0 to 16");
    }
    let budget = match (budget_triangles, budget_ms, budget_bytes) {
        (Some(n), _, _) => policy::Budget::Triangles(n),
        (_, Some(ms), _) => policy::Budget::Millis(ms),
        (_, _, Some(b)) => policy::Budget::Bytes(b),
        _ => policy::Budget::OneView,
    };
    if let policy::Budget::Triangles(v) | policy::Budget::Millis(v) | policy::Budget::Bytes(v) = budget {
        if !(v.is_finite() && v >= 0.0) {
            bail!("the budget is {v}; it must be a number >= 0");
        }
    }
    let strategies = policy::Strategy::parse_list(&strategy, keyframe_every)?;
    let walk_path = walkthrough::path::Path::from_json(&String::from_utf8(read(&path)?)?)
        .with_context(|| format!("path {}", path.display()))?;
    let truth = truth.as_deref().map(scene_spec).transpose()?;
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("walk").to_string();
    let walks = rt.block_on(async {
        let s = Server::new(&server, None).with_wire(wire);
        let loaded = walkthrough::Scene::load(&s, &scene).await?;
        let mut walks = Vec::new();
        for strategy in strategies {
            let policy = policy::Policy {
                strategy,
                budget,
                tau,
                stale_factor,
                max_age: (max_age > 0).then_some(max_age),
            };
            let options = walkthrough::Options {
                guard,
                bits,
                max_views,
                frames_out: frames_out.as_ref().map(|d| d.join(strategy.name())),
                truth: truth.clone(),
                changes: !whole,
                ..walkthrough::Options::default()
            };
            let total = walk_path.frames;
            let frames = walkthrough::run(&s, &loaded, &walk_path, &policy, &options, |f| {
                progress(strategy.name(), f.frame + 1, total, f.frame_ms);
            })
            .await?;
            if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
                eprintln!();
            }
            walks.push((strategy.name().to_string(), frames));
        }
        anyhow::Ok(walks)
    })?;
    let summaries = match &out {
        Some(dir) => {
            let written = walkthrough::summary::write(dir, &name, &name, &walks)?;
            eprintln!("wrote {}/{name}.{{csv,json}} and plots", dir.display());
            written
        }
        None => walks
            .iter()
            .map(|(s, f)| walkthrough::summary::Summary::of(s, f))
            .collect(),
    };
    if json {
        println!("{}", serde_json::to_string_pretty(&summaries)?);
    } else {
        print!("{}", walkthrough::summary::markdown(&name, &summaries));
    }
    Ok(())
}
