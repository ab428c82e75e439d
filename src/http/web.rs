//! The browser viewer (`clients/web/src`), embedded in the binary and served
//! at `/`: one command is all a user runs, and the page always matches the
//! server it came from.
//!
//! Each file has a strong ETag (a hash of its bytes) and `Cache-Control:
//! no-cache`, so a browser keeps its copy but revalidates it on every load
//! (a 304 without a body), and an upgraded server never meets a stale page.

use std::sync::LazyLock;

use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;

use super::conditional::none_match;

/// Path under `/`, media type, bytes.
const FILES: &[(&str, &str, &[u8])] = &[
    (
        "index.html",
        "text/html; charset=utf-8",
        include_bytes!("../../clients/web/src/index.html"),
    ),
    (
        "favicon.svg",
        "image/svg+xml",
        include_bytes!("../../clients/web/src/favicon.svg"),
    ),
    (
        "style.css",
        "text/css; charset=utf-8",
        include_bytes!("../../clients/web/src/style.css"),
    ),
    (
        "main.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/main.js"),
    ),
    (
        "camera.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/camera.js"),
    ),
    (
        "compact.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/compact.js"),
    ),
    (
        "controls.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/controls.js"),
    ),
    (
        "protocol.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/protocol.js"),
    ),
    (
        "renderer.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/renderer.js"),
    ),
    (
        "net.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/net.js"),
    ),
    (
        "panel.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/panel.js"),
    ),
    (
        "rounds.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/rounds.js"),
    ),
    (
        "url.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/url.js"),
    ),
    (
        "walkthrough.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/walkthrough.js"),
    ),
    (
        "worker.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../clients/web/src/worker.js"),
    ),
];

/// Only this origin's scripts, workers and images; no inline script.
const CSP: &str =
    "default-src 'self'; img-src 'self' blob:; worker-src 'self'; style-src 'self'; object-src 'none'; base-uri 'none'";

/// The embedded files' names, for tests that check every source file is served.
pub fn file_names() -> impl Iterator<Item = &'static str> {
    FILES.iter().map(|(name, _, _)| *name)
}

/// FNV-1a, 64 bits: stable across builds and platforms, enough to tell
/// versions of a file apart.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

static ETAGS: LazyLock<Vec<String>> =
    LazyLock::new(|| FILES.iter().map(|(_, _, b)| format!("\"{:016x}\"", fnv1a(b))).collect());

fn serve(index: usize, headers: &HeaderMap) -> Response {
    let (_, media, bytes) = FILES[index];
    let etag = &ETAGS[index];
    let common = [
        (
            header::ETAG,
            HeaderValue::from_str(etag).unwrap_or(HeaderValue::from_static("\"0\"")),
        ),
        (header::CACHE_CONTROL, HeaderValue::from_static("no-cache")),
        (header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff")),
    ];
    if none_match(headers, etag) || none_match(headers, "*") {
        return (StatusCode::NOT_MODIFIED, common).into_response();
    }
    (
        common,
        [
            (header::CONTENT_TYPE, HeaderValue::from_static(media)),
            (header::CONTENT_SECURITY_POLICY, HeaderValue::from_static(CSP)),
        ],
        bytes,
    )
        .into_response()
}

/// Routes `/` (the page) and `/{file}` for each embedded file.
pub fn routes<S: Clone + Send + Sync + 'static>() -> Router<S> {
    let mut router = Router::new().route("/", get(|h: HeaderMap| async move { serve(0, &h) }));
    for (index, (name, _, _)) in FILES.iter().enumerate() {
        router = router.route(
            &format!("/{name}"),
            get(move |h: HeaderMap| async move { serve(index, &h) }),
        );
    }
    router
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_source_file_is_embedded() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("clients/web/src");
        let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        on_disk.sort();
        let mut embedded: Vec<String> = file_names().map(String::from).collect();
        embedded.sort();
        assert_eq!(on_disk, embedded, "clients/web/src and web::FILES differ");
    }

    #[test]
    fn etags_differ_per_file_and_are_strong() {
        let mut tags = ETAGS.clone();
        assert!(tags.iter().all(|t| t.starts_with('"') && t.len() == 18));
        tags.sort();
        tags.dedup();
        assert_eq!(tags.len(), FILES.len());
    }
}
