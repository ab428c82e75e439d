//! The report on the exact simulated scene: rows that make sense, files that open.

use dmesh_client::report::{cases, markdown, sweep, write, Options, Sweep};

/// Differences of PSNR below this are noise of the blend, not of the depth.
const PSNR_RESOLUTION_DB: f64 = 0.05;

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
        // Each row's floor, about 3 dB under what it measures (common mask):
        // 0 bits is the coarsest levels' prediction alone (20.2 dB), a budget
        // of 10,000 triangles 30.4, tau 8 px 34.9, the fine rows 37.9-38.7.
        let floor = match (r.sweep, r.setting) {
            (Sweep::Bits, 0.0) => 17.0,
            (Sweep::Budget, _) => 27.0,
            (Sweep::Tau, s) if s >= 8.0 => 31.0,
            _ => 35.0,
        };
        assert!(r.psnr_common >= floor, "below its floor of {floor} dB: {r:?}");
        assert!(r.psnr.is_finite() && r.psnr > 15.0, "{r:?}");
        assert!(r.triangles > 0.0 && r.bytes > 0.0 && r.extract_ms >= 0.0, "{r:?}");
        // The common mask is inside every row's own, and the same for all.
        assert!(r.psnr_common.is_finite() && r.psnr_common > 15.0, "{r:?}");
        assert!(r.common_mask > 0.2 && r.common_mask <= r.coverage + 1e-12, "{r:?}");
        assert_eq!(r.common_mask, rows[0].common_mask, "{r:?}");
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
    // One more bit never lowers the view's quality, to within the
    // measurement's resolution: depth moves of a hundredth of a pixel flip
    // silhouette pixels, so exact f32 depth itself lands 0.05 dB either side
    // of 16 bits (docs/report).
    let bits: Vec<_> = of(Sweep::Bits).collect();
    assert!(
        bits.windows(2).all(|w| w[1].psnr >= w[0].psnr - PSNR_RESOLUTION_DB),
        "{:?}",
        bits.iter().map(|r| (r.setting, r.psnr)).collect::<Vec<_>>()
    );
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

/// Issue 12's residual defect: 2 bits gave a worse view than none. On every
/// scene of the full report (Middlebury from the shared data included), each
/// added bit at least halves the decoding error of the meshes the report
/// sends, and no bit-depth is worse than `bits = 0`'s interpolation.
#[test]
fn each_residual_bit_at_least_halves_the_error_on_every_report_scene() {
    use dmesh_engine::mesh::{Hierarchy, Lod, Segmentation};
    use dmesh_proto::ResidualDepths;
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    assert!(data.is_dir(), "the report's data must be at {}", data.display());
    let options = Options {
        quick: false,
        data: Some(data),
        repeats: 1,
    };
    let cases = cases(&options).unwrap();
    assert_eq!(cases.len(), 4, "demo, demo-noisy, cones, teddy");
    for case in &cases {
        let novel = &case.novels[0].camera;
        for (k, r) in case.references.iter().enumerate() {
            let h = Hierarchy::build(&r.depth, &r.camera, &Segmentation::default()).unwrap();
            let mesh = h.extract(Lod::Tau { tau: 1.0, view: novel }).unwrap();
            let ij: Vec<(u16, u16)> = mesh.vertices.iter().map(|v| (v.i, v.j)).collect();
            let z: Vec<f32> = mesh.vertices.iter().map(|v| v.depth).collect();
            let errors: Vec<f32> = (0..=16)
                .map(|bits| {
                    let coded = ResidualDepths::encode(&ij, &z, bits, h.grid().side(), r.raw_grid).unwrap();
                    let back = coded.decode(&ij).unwrap();
                    let worst = back.iter().zip(&z).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
                    assert_eq!(worst, coded.max_error, "{} view {k} bits {bits}", case.name);
                    worst
                })
                .collect();
            for (b, w) in errors.windows(2).enumerate() {
                assert!(
                    w[1] <= w[0] / 2.0,
                    "{} view {k}: bits {b} -> {}: {errors:?}",
                    case.name,
                    b + 1
                );
            }
            assert!(errors[0] > 0.0, "{} view {k}: interpolation is not exact", case.name);
        }
    }
}

/// The committed report (`docs/report/report.json`, regenerated with the
/// README's command) keeps its bits rows monotone in PSNR on every scene,
/// to within the blend's resolution.
#[test]
fn the_committed_reports_bits_rows_are_monotone_in_psnr() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/report/report.json");
    let rows: Vec<serde_json::Value> = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let mut scenes = std::collections::BTreeMap::<String, Vec<(f64, f64)>>::new();
    for r in rows.iter().filter(|r| r["sweep"] == "bits") {
        let (setting, psnr) = (r["setting"].as_f64().unwrap(), r["psnr"].as_f64().unwrap());
        scenes
            .entry(r["scene"].as_str().unwrap().to_string())
            .or_default()
            .push((setting, psnr));
    }
    assert_eq!(scenes.len(), 4, "{:?}", scenes.keys());
    for (scene, mut bits) in scenes {
        bits.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert!(bits.len() >= 8, "{scene}: {bits:?}");
        for w in bits.windows(2) {
            assert!(w[1].1 >= w[0].1 - PSNR_RESOLUTION_DB, "{scene}: {bits:?}");
        }
        assert!(bits[1].1 > bits[0].1, "{scene}: 2 bits beat interpolation: {bits:?}");
    }
}

/// The README's headline row on the demo's novel views quotes the committed
/// report: PSNR on the common mask and extraction time at tau 16 and 1 px.
#[test]
fn the_readme_quotes_the_committed_report() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let rows: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(root.join("docs/report/report.json")).unwrap()).unwrap();
    let at = |tau: f64| {
        rows.iter()
            .find(|r| r["scene"] == "demo" && r["sweep"] == "tau" && r["setting"].as_f64() == Some(tau))
            .unwrap_or_else(|| panic!("no demo row at tau {tau}"))
    };
    let f = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap();
    let (coarse, fine) = (at(16.0), at(1.0));
    let row = format!(
        "| Demo novel views, tau 16 -> 1 px | {:.1} -> {:.1} dB, {:.1} -> {:.1} ms of extraction |",
        f(coarse, "psnr_common"),
        f(fine, "psnr_common"),
        f(coarse, "extract_ms"),
        f(fine, "extract_ms")
    );
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    assert!(readme.contains(&row), "the README's row should begin\n{row}");
}
