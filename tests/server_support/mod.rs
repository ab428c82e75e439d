//! The real server for the service tests: a temporary store, the server on
//! 127.0.0.1:0, an HTTP client, and the uploads and checks they share.
#![allow(dead_code)]

use std::sync::Arc;

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use dmesh::http::{serve_on, AppState, Pipeline, Settings};
use dmesh::store::FileStore;
use dmesh_proto::StripResponse;
use hyper_util::client::legacy::Client;
use hyper_util::rt::TokioExecutor;

use crate::common;

pub mod s3;

pub const W: u32 = 48;
pub const H: u32 = 32;

pub fn depth() -> Vec<f32> {
    (0..W * H)
        .map(|i| 2.0 + ((i % W) as f32 * 0.2).sin() * 0.1 + if i % W > 30 { 1.0 } else { 0.0 })
        .collect()
}

pub fn png_color(w: u32, h: u32) -> Vec<u8> {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 5) as u8, (y * 7) as u8, 90]));
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img)
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

pub fn png16_depth() -> Vec<u8> {
    let img = image::ImageBuffer::<image::Luma<u16>, _>::from_fn(W, H, |x, y| image::Luma([2000 + (x * 3 + y) as u16]));
    let mut out = Vec::new();
    image::DynamicImage::ImageLuma16(img)
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

pub fn camera_json(yaw: f64, x: f64) -> String {
    let (s, c) = ((yaw / 2.0).sin(), (yaw / 2.0).cos());
    format!(
        r#"{{"width": {W}, "height": {H}, "projection": {{"perspective": {{"fx": 40, "fy": 40, "cx": 23.5, "cy": 15.5}}}}, "pose": {{"rotation": [0, {s}, 0, {c}], "translation": [{x}, 0, 0]}}}}"#
    )
}

pub const BOUNDARY: &str = "dmeshboundary";

pub fn multipart(parts: &[(&str, &[u8])]) -> Vec<u8> {
    let mut out = Vec::new();
    for (name, data) in parts {
        out.extend_from_slice(
            format!("--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"{name}\"; filename=\"{name}\"\r\n\r\n")
                .as_bytes(),
        );
        out.extend_from_slice(data);
        out.extend_from_slice(b"\r\n");
    }
    out.extend_from_slice(format!("--{BOUNDARY}--\r\n").as_bytes());
    out
}

pub fn put(uri: &str, body: Vec<u8>) -> Request<Body> {
    Request::put(uri)
        .header(
            header::CONTENT_TYPE,
            format!("multipart/form-data; boundary={BOUNDARY}"),
        )
        .body(Body::from(body))
        .unwrap()
}

pub fn state(dir: &std::path::Path, settings: Settings) -> Arc<AppState> {
    Arc::new(AppState::new(Arc::new(FileStore::open(dir).unwrap()), settings))
}

/// Which store a test runs against.
#[derive(Clone, Copy, Debug)]
pub enum Store {
    /// The embedded file store in a temporary directory.
    File,
    /// An object store on a real S3 API server (`moto_server`).
    S3,
}

/// A store that outlives the servers a test starts over it (a restart is a
/// new server over the same store).
pub enum Backing {
    File(tempfile::TempDir),
    S3(s3::S3Server),
}

impl Backing {
    pub fn new(kind: Store) -> Self {
        match kind {
            Store::File => Self::File(tempfile::tempdir().unwrap()),
            Store::S3 => Self::S3(s3::S3Server::start(s3::Kind::Moto)),
        }
    }

    /// A fresh server state over this store.
    pub fn state(&self, settings: Settings) -> Arc<AppState> {
        match self {
            Self::File(dir) => state(dir.path(), settings),
            Self::S3(server) => Arc::new(AppState::new(Arc::new(server.store("views")), settings)),
        }
    }
}

/// Runs a store-independent test against both stores: `name_file` and
/// `name_s3` call `name(Store::File)` and `name(Store::S3)`.
#[macro_export]
macro_rules! on_both_stores {
    ($($name:ident),* $(,)?) => {
        $(
            mod $name {
                #[tokio::test]
                async fn file() {
                    super::$name($crate::server_support::Store::File).await
                }
                #[tokio::test]
                async fn s3() {
                    super::$name($crate::server_support::Store::S3).await
                }
            }
        )*
    };
}

/// A running server: its address and the task serving it.
pub struct Server {
    pub addr: std::net::SocketAddr,
    task: tokio::task::JoinHandle<std::io::Result<()>>,
}

impl Drop for Server {
    fn drop(&mut self) {
        self.task.abort();
    }
}

pub async fn start(state: Arc<AppState>, pipeline: Pipeline) -> Server {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    Server {
        addr,
        task: tokio::spawn(serve_on(listener, state, pipeline)),
    }
}

/// Sends `req` (its URI a path) to the server over HTTP/1.1.
pub async fn send(server: &Server, mut req: Request<Body>) -> (StatusCode, axum::http::HeaderMap, Vec<u8>) {
    let path = req.uri().path_and_query().map_or("/", |p| p.as_str()).to_string();
    *req.uri_mut() = format!("http://{}{path}", server.addr).parse().unwrap();
    let client = Client::builder(TokioExecutor::new()).build_http::<Body>();
    let resp = client.request(req).await.unwrap();
    let status = resp.status();
    let headers = resp.headers().clone();
    let body = axum::body::to_bytes(Body::new(resp.into_body()), usize::MAX)
        .await
        .unwrap()
        .to_vec();
    (status, headers, body)
}

pub fn upload_body(depth: &[u8], extra: &[(&str, &[u8])], cam: &str) -> Vec<u8> {
    let color = png_color(W, H);
    let mut parts: Vec<(&str, &[u8])> = vec![("camera", cam.as_bytes()), ("depth", depth), ("color", &color)];
    parts.extend_from_slice(extra);
    multipart(&parts)
}

pub fn canon(mut t: [u32; 3]) -> [u32; 3] {
    t.sort_unstable();
    t
}

pub fn check_strips(r: &StripResponse) {
    assert!(!r.vertices.is_empty());
    let vertices = dmesh_engine::wire::mesh_vertices(r).unwrap();
    for v in &vertices {
        assert!(u32::from(v.i) < W && u32::from(v.j) < H && v.depth.is_finite() && v.depth > 0.0);
    }
    let wide = r.indices.to_u32();
    let tris = dmesh_engine::mesh::decode_strips(&wide);
    assert_eq!(tris.len(), r.triangles as usize);
    let unique: std::collections::HashSet<_> = tris.iter().map(|t| canon(*t)).collect();
    assert_eq!(unique.len(), tris.len(), "a triangle is drawn twice");
    assert!(wide.iter().all(|&i| i == u32::MAX || (i as usize) < r.vertices.len()));
    // Conforming: rebuild the mesh (orienting each drawn triangle the
    // engine's way, since strip winding is not kept) and check it.
    let triangles = tris
        .iter()
        .map(|&[a, b, c]| {
            let p = |k: u32| (i64::from(vertices[k as usize].i), i64::from(vertices[k as usize].j));
            let (pa, pb, pc) = (p(a), p(b), p(c));
            let cross = (pb.0 - pa.0) * (pc.1 - pa.1) - (pb.1 - pa.1) * (pc.0 - pa.0);
            if cross > 0 {
                [b, a, c]
            } else {
                [a, b, c]
            }
        })
        .collect();
    common::assert_conforming(&dmesh_engine::mesh::Mesh {
        vertices,
        strips: wide,
        triangles,
        ..Default::default()
    });
}

pub fn urlencode(s: &str) -> String {
    s.bytes()
        .map(|b| {
            if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
                (b as char).to_string()
            } else {
                format!("%{b:02X}")
            }
        })
        .collect()
}
