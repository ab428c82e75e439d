//! The seeds' experiments (`scripts/papers.sh`, minutes in release) stay out
//! of the test command, but a quick form of each runs here so that none of
//! them rots: every table printed, every number finite, the plot written.

use std::path::PathBuf;
use std::process::Command;

use dmesh_client::report::verdict::Verdict;

/// An example binary `cargo test` built beside this test.
fn example(name: &str) -> PathBuf {
    // target/debug/deps/papers-HASH -> target/debug/examples/NAME
    let path = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .parent()
        .unwrap()
        .join("examples")
        .join(name);
    assert!(
        path.exists(),
        "{} is missing: build it with `cargo build -p dmesh-client --examples` (cargo test --workspace does)",
        path.display()
    );
    path
}

/// Runs an example with `args` and returns what it printed.
fn run(name: &str, args: &[&str]) -> String {
    let out = Command::new(example(name)).args(args).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{name} failed: {}\n{text}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        !text.contains("NaN") && !text.contains("inf"),
        "{name} printed a non-finite number:\n{text}"
    );
    text
}

/// The verdict lines of `text`: exactly `count` of them, each reading back
/// and judged (a claim whose criterion was not evaluated fails), and one on
/// each of `claims` at least.
fn assert_judged(text: &str, count: usize, claims: &[&str]) {
    let mut verdicts = Vec::new();
    for line in text
        .lines()
        .filter(|l| l.starts_with("- **") && l.contains("Criterion: "))
    {
        let (claim, word) = Verdict::parse(line).unwrap_or_else(|| panic!("a verdict that does not read back: {line}"));
        assert!(
            word == "held" || word == "did not hold",
            "not judged in the quick form: {line}"
        );
        verdicts.push(claim);
    }
    assert_eq!(verdicts.len(), count, "{verdicts:?}");
    for claim in claims {
        assert!(
            verdicts.iter().any(|v| v.contains(claim)),
            "no verdict on {claim}: {verdicts:?}"
        );
    }
}

fn data() -> String {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    assert!(data.is_dir(), "the Middlebury data must be at {}", data.display());
    data.display().to_string()
}

#[test]
fn dmesh_experiments_run_in_their_quick_form() {
    let dir = tempfile::tempdir().unwrap();
    let text = run("papers_dmesh", &["--quick", &data(), dir.path().to_str().unwrap()]);
    // Fig. 18: three panels of the demo reference (256 x 192) with 4 px between.
    let fig = image::open(dir.path().join("fig18-demo.png")).unwrap().to_rgb8();
    assert_eq!((fig.width(), fig.height()), (3 * 256 + 2 * 4, 192));
    assert!(fig.pixels().any(|p| p.0 == [220, 30, 30]), "no segmented cell drawn");
    for section in [
        "### Table 4",
        "### Table 1's stages",
        "Shares of the whole build",
        "### Strip lengths by tolerance",
        "### Sec. 7.1 and Fig. 18",
    ] {
        assert!(text.contains(section), "{section} is missing:\n{text}");
    }
    for method in ["orthogonality", "disparity", "connectedness", "none"] {
        assert!(text.contains(&format!("| demo | {method} |")), "{method}:\n{text}");
    }
    // Table 4 at two sizes (2 each), Table 1 (2), strips (3), Sec. 7.1 (3).
    assert_judged(
        &text,
        12,
        &["Table 4", "Table 1", "Sec. 7.2", "Sec. 7.3", "Sec. 7.1, Fig. 18"],
    );
}

#[test]
fn verlani_experiments_run_in_their_quick_form() {
    let dir = tempfile::tempdir().unwrap();
    let plot = dir.path().join("fig5");
    let text = run("papers_verlani", &["--quick", plot.to_str().unwrap()]);
    for section in [
        "### Table 2",
        "### Table 1",
        "### Fig. 5",
        "### Table 3",
        "### The angular weights",
    ] {
        assert!(text.contains(section), "{section} is missing:\n{text}");
    }
    // Table 2 (3), Table 1 (2), Fig. 5 (2), Table 3 (2), the weights (1).
    assert_judged(&text, 10, &["Table 2", "Table 1", "Fig. 5", "Table 3", "Sec. 2"]);
    let png = image::open(plot.with_extension("png")).unwrap();
    assert_eq!((png.width(), png.height()), (800, 520));
    assert!(std::fs::read_to_string(plot.with_extension("svg"))
        .unwrap()
        .contains("<svg"));
}

/// The rate-distortion run (`--rd`) prints every curve, a verdict judged
/// by its criterion, and writes its figure.
#[test]
fn the_rate_distortion_run_judges_and_plots_in_its_quick_form() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("rd");
    let text = run("papers_verlani", &["--quick", "--rd", base.to_str().unwrap()]);
    for curve in [
        "| protocol 7 (outlines cut) |",
        "| protocol 6 (outlines refined) |",
        "| JPEG depth maps, meshed losslessly |",
        "| zipped 16-bit depth maps, per pixel |",
    ] {
        assert!(text.contains(curve), "{curve} is missing:\n{text}");
    }
    let verdict = text
        .lines()
        .find(|l| l.starts_with("- **Protocol 7 on or above every other curve**"))
        .unwrap_or_else(|| panic!("no verdict:\n{text}"));
    assert!(
        [": met.", ": not met.", "not judged"]
            .iter()
            .any(|v| verdict.contains(v)),
        "{verdict}"
    );
    let png = image::open(base.with_extension("png")).unwrap();
    assert_eq!((png.width(), png.height()), (800, 520));
    assert!(std::fs::read_to_string(base.with_extension("svg"))
        .unwrap()
        .contains("<svg"));
}
