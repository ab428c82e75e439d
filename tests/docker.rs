//! No Docker engine runs here, so the image is checked against the server's
//! defaults instead: the exposed port, the volume and the entrypoint's data
//! directory are those `dmesh serve` uses, and compose mounts that volume.

fn read(path: &str) -> String {
    std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap()
}

fn directive<'a>(dockerfile: &'a str, name: &str) -> Vec<&'a str> {
    dockerfile
        .lines()
        .filter_map(|l| l.strip_prefix(name))
        .map(str::trim)
        .collect()
}

#[test]
fn dockerfile_matches_the_server_defaults() {
    let d = read("docker/Dockerfile");
    let (port, data) = (dmesh::http::DEFAULT_PORT, dmesh::http::DEFAULT_DATA_DIR);
    assert_eq!(directive(&d, "EXPOSE "), vec![port.to_string()]);
    let workdir = *directive(&d, "WORKDIR ").last().unwrap();
    let volume = directive(&d, "VOLUME ")[0];
    assert_eq!(volume, format!("{workdir}/{}", data.trim_start_matches("./")));
    let entry = directive(&d, "ENTRYPOINT ")[0];
    let args: Vec<String> = serde_json::from_str(entry).unwrap();
    assert_eq!(&args[..2], ["dmesh", "serve"]);
    let listen = &args[args.iter().position(|a| a == "--listen").unwrap() + 1];
    assert_eq!(listen, &format!("0.0.0.0:{port}"));
    let data_arg = &args[args.iter().position(|a| a == "--data").unwrap() + 1];
    assert_eq!(data_arg, data);
    assert!(
        d.contains(&format!("http://127.0.0.1:{port}/healthz")),
        "HEALTHCHECK must probe /healthz"
    );
    assert!(d.contains("USER dmesh"), "the runtime must not run as root");
    // Compose: replicas on the default port over the object store, each
    // with its own host name (its replica id), HAProxy publishing that port
    // and balancing over every replica with health checks.
    let compose = read("docker/compose.yaml");
    assert!(
        compose.contains(&format!("\"0.0.0.0:{port}\", \"--store\"")) && compose.contains(&format!(":{port}:{port}\"")),
        "{compose}"
    );
    let haproxy = read("docker/haproxy.cfg");
    assert!(
        haproxy.contains(&format!("bind :{port}\n"))
            && haproxy.contains("hash-type consistent")
            && haproxy.contains("option httpchk GET /healthz"),
        "{haproxy}"
    );
    assert!(compose.contains("./haproxy.cfg:/usr/local/etc/haproxy/haproxy.cfg"));
    for r in ["dmesh-1", "dmesh-2", "dmesh-3"] {
        assert!(compose.contains(&format!("{r}:")), "compose lacks {r}");
        assert!(
            compose.contains(&format!("hostname: {r}")),
            "compose gives {r} no host name"
        );
        assert!(
            haproxy.contains(&format!("server {r} {r}:{port} check")),
            "haproxy.cfg lacks {r}"
        );
    }
}

#[test]
fn openapi_documents_every_route() {
    let router = read("src/http/mod.rs");
    let spec = read("proto/openapi.yaml");
    let routes: Vec<&str> = router
        .split(".route(")
        .skip(1)
        .filter_map(|r| r.trim_start().strip_prefix('"')?.split('"').next())
        .collect();
    assert!(routes.len() >= 9, "{routes:?}");
    for r in routes {
        assert!(spec.contains(&format!("  {r}:")), "openapi.yaml lacks {r}");
    }
}

/// `dmesh` embeds the viewer's files at compile time, so the image's build
/// context must keep them: nothing in `.dockerignore` may hide them.
#[test]
fn the_image_build_keeps_the_embedded_viewer() {
    let ignore = read(".dockerignore");
    let viewer = "clients/web/src/index.html";
    for pattern in ignore
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
    {
        let p = pattern.trim_end_matches('/');
        assert!(
            !(viewer == p || viewer.starts_with(&format!("{p}/")) || p == "*"),
            ".dockerignore line {pattern:?} hides {viewer}"
        );
    }
    assert!(
        ignore.lines().any(|l| l.trim() == "target/"),
        "the build context should skip target/"
    );
}
