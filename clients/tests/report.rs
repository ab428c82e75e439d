//! The report on the exact simulated scene: rows that make sense, files that open.

use dmesh_client::report::{cases, markdown, sweep, write, Options, Sweep};

#[test]
fn quick_report_sweeps_and_writes_tables_and_curves() {
    let options = Options {
        quick: true,
        data: None,
        repeats: 1,
    };
    let cases = cases(&options).unwrap();
    assert_eq!(cases.len(), 1);
    let rows = sweep(&cases[0], &options).unwrap();
    for r in &rows {
        assert!(r.psnr.is_finite() && r.psnr > 15.0, "{r:?}");
        assert!(r.triangles > 0.0 && r.bytes > 0.0 && r.extract_ms >= 0.0, "{r:?}");
    }
    let of = |sweep: Sweep| rows.iter().filter(move |r| r.sweep == sweep);
    let tau: Vec<_> = of(Sweep::Tau).collect();
    assert!(
        tau.windows(2).all(|w| w[1].triangles < w[0].triangles),
        "coarser tau, fewer triangles"
    );
    // Lossless 16 bits on the simulated (float) depth: within rounding of exact.
    let exact = tau.iter().find(|r| r.setting == 1.0).unwrap();
    let sixteen = of(Sweep::Bits).find(|r| r.setting == 16.0).unwrap();
    assert!(
        (sixteen.psnr - exact.psnr).abs() < 0.05,
        "{} vs {}",
        sixteen.psnr,
        exact.psnr
    );
    assert!(sixteen.bytes < exact.bytes);
    for r in of(Sweep::Budget) {
        assert!(r.triangles <= r.setting, "{r:?}");
    }
    let dir = tempfile::tempdir().unwrap();
    write(&rows, dir.path()).unwrap();
    for name in ["psnr-vs-extract-ms", "psnr-vs-bytes"] {
        let png = image::open(dir.path().join(format!("{name}.png"))).unwrap();
        assert_eq!((png.width(), png.height()), (800, 520));
        let svg = std::fs::read_to_string(dir.path().join(format!("{name}.svg"))).unwrap();
        assert!(svg.contains("<svg") && svg.contains("PSNR"), "{name}.svg");
    }
    let md = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert_eq!(md, markdown(&rows));
    assert!(md.contains("### demo") && md.contains("PSNR against residual bits"));
}
