//! `dmesh-client compare`: PSNR over the pixels both images cover, and the
//! inverse-depth RMSE when both depths are given.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use dmesh_client::compare::compare;

use crate::{read, read_pfm};

/// Options of `compare`.
#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// First image (PNG).
    pub a: PathBuf,
    /// Second image (PNG).
    pub b: PathBuf,
    /// Depth of the first (PFM); with --depth-b the valid mask is where both are positive.
    #[arg(long, requires = "depth_b")]
    pub depth_a: Option<PathBuf>,
    /// Depth of the second (PFM).
    #[arg(long, requires = "depth_a")]
    pub depth_b: Option<PathBuf>,
    /// Print JSON: psnr, valid_fraction, inverse_depth_rmse.
    #[arg(long)]
    pub json: bool,
}

/// Compares the two images and prints the figures (one line, or JSON).
pub fn run(args: CompareArgs) -> Result<()> {
    let CompareArgs {
        a,
        b,
        depth_a,
        depth_b,
        json,
    } = args;
    let load = |p: &Path| -> Result<image::RgbImage> {
        Ok(image::load_from_memory(&read(p)?)
            .with_context(|| format!("image {}", p.display()))?
            .to_rgb8())
    };
    let (ia, ib) = (load(&a)?, load(&b)?);
    if ia.dimensions() != ib.dimensions() {
        bail!(
            "{} is {:?} but {} is {:?}",
            a.display(),
            ia.dimensions(),
            b.display(),
            ib.dimensions()
        );
    }
    let depths = match (depth_a, depth_b) {
        (Some(da), Some(db)) => Some((read_pfm(&da)?.2, read_pfm(&db)?.2)),
        _ => None,
    };
    let c = compare(
        ia.as_raw(),
        ib.as_raw(),
        depths.as_ref().map(|(x, y)| (x.as_slice(), y.as_slice())),
    )?;
    if json {
        println!("{}", serde_json::to_string(&c)?);
    } else {
        println!(
            "PSNR {:.2} dB over {:.1} % of the pixels",
            c.psnr,
            100.0 * c.valid_fraction
        );
        if let Some(r) = c.inverse_depth_rmse {
            println!("inverse-depth RMSE {r:.6}");
        }
    }
    Ok(())
}
