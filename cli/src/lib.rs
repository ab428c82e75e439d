//! Glue shared by the `dmesh` and `dmesh-client` binaries (a crate of its own
//! so that neither compiles the other's file): every failure,
//! from bad arguments to a failed run, ends in one line on stderr and a
//! non-zero exit code.

use std::process::ExitCode;

/// Parses the command line. `--help` and `--version` print and exit 0; a bad
/// argument prints clap's explanation on one line and exits 2.
pub fn parse<T: clap::Parser>() -> Result<T, ExitCode> {
    match T::try_parse() {
        Ok(cli) => Ok(cli),
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            Err(ExitCode::SUCCESS)
        }
        Err(e) => {
            // Clap explains over several lines; keep everything before the
            // usage block, on one line.
            let text = e.render().to_string();
            let head: Vec<&str> = text
                .lines()
                .take_while(|l| !l.starts_with("Usage:"))
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("{}", head.join(" "));
            Err(ExitCode::from(2))
        }
    }
}

/// A parser of the values `names` names (an engine enum's table of names,
/// as `DepthKind::NAMES`): the engine knows nothing of clap, and the
/// binaries write no second enum of the same values. `--help` lists the
/// names.
pub fn one_of<T: Copy + Send + Sync + 'static>(
    names: &'static [(&'static str, T)],
) -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(names.iter().map(|(name, _)| *name)).try_map(move |given: String| {
        names
            .iter()
            .find(|(name, _)| *name == given)
            .map(|&(_, value)| value)
            .ok_or_else(|| format!("{given:?} is not one of the names"))
    })
}

/// The exit code of a run; on failure, the error's context chain on one line.
pub fn finish(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", format!("{e:#}").replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}

/// Logs to stderr at the level `DMESH_LOG` names (`error`, `warn`, `info`,
/// the default, `debug` or `trace`): `debug` adds a line per request
/// (route, status, ms) and per build and extraction.
pub fn init_logging() {
    let level = std::env::var("DMESH_LOG")
        .ok()
        .and_then(|l| l.trim().parse::<tracing_subscriber::filter::LevelFilter>().ok())
        .unwrap_or(tracing_subscriber::filter::LevelFilter::INFO);
    let _ = tracing_subscriber::fmt()
        .with_max_level(level)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}
