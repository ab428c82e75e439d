//! Redraws the plots of saved walkthroughs from their CSV and JSON, without
//! walking again (after a change to the plots' drawing).
//!
//! Usage: `cargo run --release -p dmesh-client --example replot_walkthrough -- DIR NAME...`
//! (`DIR` as written by `dmesh-client walkthrough --out DIR`, a `NAME` per
//! path, e.g. `docs/walkthrough demo-orbit terrain-flyover`).
fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let dir = std::path::PathBuf::from(
        args.next()
            .ok_or_else(|| anyhow::anyhow!("usage: replot_walkthrough DIR NAME..."))?,
    );
    for name in args {
        dmesh_client::walkthrough::summary::replot(&dir, &name)?;
        println!("redrew {}/{name}-*.png", dir.display());
    }
    Ok(())
}
