//! `dmesh-client report`: the accuracy-against-time sweeps, or with
//! `--baselines` the thesis's comparison of meshers
//! (`dmesh_client::report`).

use std::path::PathBuf;

use anyhow::Result;

/// The options of `dmesh-client report` (their help is the subcommand's).
#[derive(clap::Args, Debug)]
pub struct ReportArgs {
    /// Output folder [default: docs/report, docs/baselines with --baselines].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Folder of the Middlebury scenes (cones, teddy; with --baselines art,
    /// aloe, reindeer, cones); left out of the sweeps when not given.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Naik's comparison: every baseline mesher and the RQT at reduction
    /// rates on Middlebury scenes (needs --data): baselines.md,
    /// baselines.json, PSNR and time against rate per scene.
    #[arg(long)]
    pub baselines: bool,
    /// Scenes of --baselines, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "art,aloe,reindeer,cones")]
    pub scenes: Vec<String>,
    /// Reduction rates of --baselines, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "5,10,20,30,45,70")]
    pub rates: Vec<f64>,
    /// With --baselines: redraw the tables and plots from the output
    /// folder's baselines.json without meshing again.
    #[arg(long)]
    pub replot: bool,
    /// Timings are the median of this many runs.
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// A few settings on the exact simulated scene only.
    #[arg(long)]
    pub quick: bool,
}

/// Runs the sweeps or the comparison and writes their files.
pub fn run(args: ReportArgs) -> Result<()> {
    let ReportArgs {
        out,
        data,
        baselines,
        scenes,
        rates,
        replot,
        repeats,
        quick,
    } = args;
    if replot {
        anyhow::ensure!(
            baselines,
            "--replot redraws a --baselines comparison: give --baselines too"
        );
        let out = out.unwrap_or_else(|| PathBuf::from("docs/baselines"));
        let rows = dmesh_client::report::baselines::read(&out)?;
        dmesh_client::report::baselines::write(&rows, &out)?;
        print!("{}", dmesh_client::report::baselines::markdown(&rows));
        eprintln!("redrew {}", out.display());
        return Ok(());
    }
    if baselines {
        let data = data.ok_or_else(|| {
            anyhow::anyhow!(
                "--baselines needs --data, the folder of the Middlebury scenes (art, aloe, reindeer, cones)"
            )
        })?;
        anyhow::ensure!(
            rates.iter().all(|r| r.is_finite() && *r >= 1.0),
            "--rates must be numbers of at least 1 (full-resolution triangles over triangles kept)"
        );
        let out = out.unwrap_or_else(|| PathBuf::from("docs/baselines"));
        let options = dmesh_client::report::baselines::Options { scenes, rates, repeats };
        let rows = dmesh_client::report::baselines::run(&data, &options)?;
        dmesh_client::report::baselines::write(&rows, &out)?;
        print!("{}", dmesh_client::report::baselines::markdown(&rows));
        eprintln!("wrote {}", out.display());
        return Ok(());
    }
    let out = out.unwrap_or_else(|| PathBuf::from("docs/report"));
    let options = dmesh_client::report::Options { quick, data, repeats };
    let mut rows = Vec::new();
    for case in dmesh_client::report::cases(&options)? {
        eprintln!("sweeping {} ({} reference views)", case.name, case.references.len());
        rows.extend(dmesh_client::report::sweep(&case, &options)?);
    }
    dmesh_client::report::write(&rows, &out)?;
    print!("{}", dmesh_client::report::markdown(&rows));
    eprintln!("wrote {}", out.display());
    Ok(())
}
