//! What depends on what: the client and the engine link no server. A
//! third-party client needs `dmesh-proto` (the wire) and, for meshing or
//! cameras, `dmesh-engine`; neither brings axum, the store or clap.

use std::process::Command;

/// `cargo tree` of `package`'s normal (non-dev) dependencies, one crate a line.
fn tree(package: &str) -> String {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["tree", "--offline", "-e", "normal", "--prefix", "none", "-p", package])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "cargo tree: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn crates(tree: &str) -> Vec<&str> {
    tree.lines().filter_map(|l| l.split_whitespace().next()).collect()
}

#[test]
fn the_client_links_no_server() {
    let t = tree("dmesh-client");
    let c = crates(&t);
    assert!(c.contains(&"dmesh-proto") && c.contains(&"dmesh-engine"), "{t}");
    for server in ["dmesh", "axum", "tower-http", "object_store"] {
        assert!(!c.contains(&server), "dmesh-client depends on {server}:\n{t}");
    }
}

#[test]
fn the_engine_links_no_service_and_no_command_line() {
    let t = tree("dmesh-engine");
    let c = crates(&t);
    for outside in ["dmesh", "axum", "tokio", "object_store", "clap", "anyhow"] {
        assert!(!c.contains(&outside), "dmesh-engine depends on {outside}:\n{t}");
    }
}

#[test]
fn the_wire_needs_only_serde() {
    let t = tree("dmesh-proto");
    for outside in ["dmesh-engine", "glam", "image", "axum", "tokio"] {
        assert!(!crates(&t).contains(&outside), "dmesh-proto depends on {outside}:\n{t}");
    }
}

/// Every Rust source under `dir`, recursively.
fn sources(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn the_server_names_the_engine_and_re_exports_nothing_of_it() {
    let t = tree("dmesh");
    assert!(crates(&t).contains(&"dmesh-engine"), "{t}");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../src");
    let mut files = Vec::new();
    sources(&root, &mut files);
    assert!(files.len() > 10, "found only {files:?}");
    let mut named = 0;
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        named += text.matches("dmesh_engine::").count();
        for line in text.lines().map(str::trim) {
            assert!(
                !(line.starts_with("pub use dmesh_engine") || line.starts_with("pub(crate) use dmesh_engine")),
                "{} re-exports the engine: {line}",
                file.display()
            );
        }
    }
    assert!(named > 0, "the server's sources never name dmesh_engine");
}
