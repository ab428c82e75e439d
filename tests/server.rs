//! The HTTP service, started for real on 127.0.0.1:0 with a temporary data
//! directory and driven by an HTTP client: upload of each depth format,
//! listing, strips static and view-dependent in JSON and bincode (decoded and
//! checked conforming), ETags, render weights, restart, deletion, shedding,
//! timeouts, compression, and a table of bad inputs with their statuses.

mod common;

use std::sync::Arc;

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use dmesh::http::{serve_on, AppState, Pipeline, Settings};
use dmesh::image::{encode_exr, encode_pfm, Limits};
use dmesh::store::FileStore;
use dmesh_proto::{RenderResponse, StripResponse, ViewSummary};
use hyper_util::client::legacy::Client;
use hyper_util::rt::TokioExecutor;

const W: u32 = 48;
const H: u32 = 32;

fn depth() -> Vec<f32> {
    (0..W * H)
        .map(|i| 2.0 + ((i % W) as f32 * 0.2).sin() * 0.1 + if i % W > 30 { 1.0 } else { 0.0 })
        .collect()
}

fn png_color(w: u32, h: u32) -> Vec<u8> {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 5) as u8, (y * 7) as u8, 90]));
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img)
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

fn png16_depth() -> Vec<u8> {
    let img = image::ImageBuffer::<image::Luma<u16>, _>::from_fn(W, H, |x, y| image::Luma([2000 + (x * 3 + y) as u16]));
    let mut out = Vec::new();
    image::DynamicImage::ImageLuma16(img)
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

fn camera_json(yaw: f64, x: f64) -> String {
    let (s, c) = ((yaw / 2.0).sin(), (yaw / 2.0).cos());
    format!(
        r#"{{"width": {W}, "height": {H}, "projection": {{"perspective": {{"fx": 40, "fy": 40, "cx": 23.5, "cy": 15.5}}}}, "pose": {{"rotation": [0, {s}, 0, {c}], "translation": [{x}, 0, 0]}}}}"#
    )
}

const BOUNDARY: &str = "dmeshboundary";

fn multipart(parts: &[(&str, &[u8])]) -> Vec<u8> {
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

fn put(uri: &str, body: Vec<u8>) -> Request<Body> {
    Request::put(uri)
        .header(
            header::CONTENT_TYPE,
            format!("multipart/form-data; boundary={BOUNDARY}"),
        )
        .body(Body::from(body))
        .unwrap()
}

fn state(dir: &std::path::Path, settings: Settings) -> Arc<AppState> {
    Arc::new(AppState::new(Arc::new(FileStore::open(dir).unwrap()), settings))
}

/// A running server: its address and the task serving it.
struct Server {
    addr: std::net::SocketAddr,
    task: tokio::task::JoinHandle<std::io::Result<()>>,
}

impl Drop for Server {
    fn drop(&mut self) {
        self.task.abort();
    }
}

async fn start(state: Arc<AppState>, pipeline: Pipeline) -> Server {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    Server {
        addr,
        task: tokio::spawn(serve_on(listener, state, pipeline)),
    }
}

/// Sends `req` (its URI a path) to the server over HTTP/1.1.
async fn send(server: &Server, mut req: Request<Body>) -> (StatusCode, axum::http::HeaderMap, Vec<u8>) {
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

fn upload_body(depth: &[u8], extra: &[(&str, &[u8])], cam: &str) -> Vec<u8> {
    let color = png_color(W, H);
    let mut parts: Vec<(&str, &[u8])> = vec![("camera", cam.as_bytes()), ("depth", depth), ("color", &color)];
    parts.extend_from_slice(extra);
    multipart(&parts)
}

fn canon(mut t: [u32; 3]) -> [u32; 3] {
    t.sort_unstable();
    t
}

fn check_strips(r: &StripResponse) {
    assert!(!r.vertices.is_empty());
    let vertices = dmesh::wire::mesh_vertices(r).unwrap();
    for v in &vertices {
        assert!(u32::from(v.i) < W && u32::from(v.j) < H && v.depth.is_finite() && v.depth > 0.0);
    }
    let wide = r.indices.to_u32();
    let tris = dmesh::mesh::decode_strips(&wide);
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
    common::assert_conforming(&dmesh::mesh::Mesh {
        vertices,
        strips: wide,
        triangles,
        ..Default::default()
    });
}

#[tokio::test]
async fn upload_list_strips_render_restart_delete() {
    let dir = tempfile::tempdir().unwrap();
    let router = start(state(dir.path(), Settings::default()), Pipeline::default()).await;
    let z = depth();
    type Upload<'a> = (&'a str, Vec<u8>, Vec<(&'a str, Vec<u8>)>);
    let uploads: [Upload; 3] = [
        ("pfm", encode_pfm(W, H, &z), vec![]),
        ("exr", encode_exr(W, H, &z).unwrap(), vec![]),
        ("png", png16_depth(), vec![("scale", b"0.001".to_vec())]),
    ];
    for (i, (view, bytes, extra)) in uploads.iter().enumerate() {
        let extra: Vec<(&str, &[u8])> = extra.iter().map(|(k, v)| (*k, v.as_slice())).collect();
        let body = upload_body(bytes, &extra, &camera_json(0.3 * i as f64, 0.1 * i as f64));
        let (status, _, body) = send(&router, put(&format!("/v1/scenes/demo/views/{view}"), body)).await;
        assert_eq!(status, StatusCode::CREATED, "{}", String::from_utf8_lossy(&body));
        let summary: ViewSummary = serde_json::from_slice(&body).unwrap();
        assert_eq!((summary.camera.width, summary.view.as_str()), (W, *view));
    }
    let (status, _, body) = send(
        &router,
        Request::get("/v1/scenes/demo/views").body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::OK);
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["views"], serde_json::json!(["exr", "pfm", "png"]));

    // Static strips, JSON, with a strong ETag honoured by If-None-Match.
    let (status, headers, body) = send(
        &router,
        Request::get("/v1/scenes/demo/views/pfm/strips?epsilon=0.001")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    check_strips(&serde_json::from_slice(&body).unwrap());
    let etag = headers[header::ETAG].to_str().unwrap().to_string();
    let req = Request::get("/v1/scenes/demo/views/pfm/strips?epsilon=0.001")
        .header(header::IF_NONE_MATCH, &etag)
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(&router, req).await.0, StatusCode::NOT_MODIFIED);

    // View-dependent strips in bincode, camera in the query.
    let cam = camera_json(0.1, 0.05);
    let uri = format!("/v1/scenes/demo/views/exr/strips?tau=1&camera={}", urlencode(&cam));
    let req = Request::get(uri)
        .header(header::ACCEPT, "application/x-bincode")
        .body(Body::empty())
        .unwrap();
    let (status, headers, body) = send(&router, req).await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    assert_eq!(headers[header::CONTENT_TYPE], "application/x-bincode");
    check_strips(&dmesh_proto::from_bincode::<StripResponse>(&body).unwrap());

    // Render: weights sum to 1.
    let req = Request::post("/v1/scenes/demo/render")
        .header(header::CONTENT_TYPE, "application/json")
        .body(Body::from(format!(
            r#"{{"camera": {}, "tau": 1.0}}"#,
            camera_json(0.15, 0.05)
        )))
        .unwrap();
    let (status, _, body) = send(&router, req).await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    let r: RenderResponse = serde_json::from_slice(&body).unwrap();
    assert!(!r.views.is_empty());
    assert!((r.views.iter().map(|v| v.weight).sum::<f64>() - 1.0).abs() < 1e-9);
    r.views.iter().for_each(|v| check_strips(&v.strips));

    // Colour with ETag.
    let (status, headers, body) = send(
        &router,
        Request::get("/v1/scenes/demo/views/pfm/color")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(body, png_color(W, H));
    let etag = headers[header::ETAG].to_str().unwrap().to_string();
    let req = Request::get("/v1/scenes/demo/views/pfm/color")
        .header(header::IF_NONE_MATCH, etag)
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(&router, req).await.0, StatusCode::NOT_MODIFIED);

    // A new server over the same data directory has every view.
    drop(router);
    let restarted = start(state(dir.path(), Settings::default()), Pipeline::default()).await;
    for view in ["pfm", "exr", "png"] {
        let (status, _, _) = send(
            &restarted,
            Request::get(format!("/v1/scenes/demo/views/{view}"))
                .body(Body::empty())
                .unwrap(),
        )
        .await;
        assert_eq!(status, StatusCode::OK, "{view} lost on restart");
    }
    let (status, _, _) = send(
        &restarted,
        Request::delete("/v1/scenes/demo/views/png")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::NO_CONTENT);
    let (status, _, _) = send(
        &restarted,
        Request::get("/v1/scenes/demo/views/png").body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let (status, _, body) = send(&restarted, Request::get("/metrics").body(Body::empty()).unwrap()).await;
    assert_eq!(status, StatusCode::OK);
    let text = String::from_utf8(body).unwrap();
    assert!(
        text.contains("dmesh_request_duration_ms_bucket") && text.contains("dmesh_bytes_stored"),
        "{text}"
    );
}

fn urlencode(s: &str) -> String {
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

#[tokio::test]
async fn bad_inputs_get_their_status_and_code_and_keep_the_stored_view() {
    let dir = tempfile::tempdir().unwrap();
    let settings = Settings {
        max_upload_bytes: 64 << 10,
        limits: Limits { max_pixels: 1 << 20 },
        cache_bytes: 1 << 20,
    };
    let router = start(state(dir.path(), settings), Pipeline::default()).await;
    let z = depth();
    let good = encode_pfm(W, H, &z);
    let (status, _, _) = send(
        &router,
        put("/v1/scenes/s/views/v", upload_body(&good, &[], &camera_json(0.0, 0.0))),
    )
    .await;
    assert_eq!(status, StatusCode::CREATED);

    let png = png16_depth();
    let truncated_png = &png[..png.len() / 2];
    let small_color = png_color(8, 8);
    let huge_pfm = b"Pf\n50000 50000\n-1.0\n".to_vec();
    let int_exr = {
        use exr::prelude::*;
        let channel = AnyChannel::new("Z", FlatSamples::U32(vec![1; (W * H) as usize]));
        let layer = Layer::new(
            (W as usize, H as usize),
            LayerAttributes::default(),
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(vec![channel])),
        );
        let mut out = std::io::Cursor::new(Vec::new());
        Image::from_layer(layer).write().to_buffered(&mut out).unwrap();
        out.into_inner()
    };
    let cases: Vec<(&str, Request<Body>, StatusCode, &str)> = vec![
        (
            "wrong method",
            Request::post("/v1/scenes").body(Body::empty()).unwrap(),
            StatusCode::METHOD_NOT_ALLOWED,
            "method_not_allowed",
        ),
        (
            "no such endpoint",
            Request::get("/v2/nothing").body(Body::empty()).unwrap(),
            StatusCode::NOT_FOUND,
            "not_found",
        ),
        (
            "truncated png",
            put(
                "/v1/scenes/s/views/v",
                upload_body(truncated_png, &[], &camera_json(0.0, 0.0)),
            ),
            StatusCode::UNPROCESSABLE_ENTITY,
            "undecodable_image",
        ),
        (
            "EXR without a float channel",
            put(
                "/v1/scenes/s/views/v",
                upload_body(&int_exr, &[], &camera_json(0.0, 0.0)),
            ),
            StatusCode::UNPROCESSABLE_ENTITY,
            "undecodable_image",
        ),
        (
            "size mismatch",
            put(
                "/v1/scenes/s/views/v",
                multipart(&[
                    ("camera", camera_json(0.0, 0.0).as_bytes()),
                    ("depth", &good),
                    ("color", &small_color),
                ]),
            ),
            StatusCode::BAD_REQUEST,
            "bad_request",
        ),
        (
            "NaN in camera",
            put(
                "/v1/scenes/s/views/v",
                upload_body(&good, &[], &camera_json(0.0, 0.0).replace("\"fx\": 40", "\"fx\": NaN")),
            ),
            StatusCode::BAD_REQUEST,
            "bad_request",
        ),
        (
            "zero focal length",
            put(
                "/v1/scenes/s/views/v",
                upload_body(&good, &[], &camera_json(0.0, 0.0).replace("\"fx\": 40", "\"fx\": 0")),
            ),
            StatusCode::BAD_REQUEST,
            "bad_request",
        ),
        (
            "unknown scene",
            Request::get("/v1/scenes/nope/views").body(Body::empty()).unwrap(),
            StatusCode::NOT_FOUND,
            "not_found",
        ),
        (
            "unknown view",
            Request::get("/v1/scenes/s/views/nope/strips?epsilon=1")
                .body(Body::empty())
                .unwrap(),
            StatusCode::NOT_FOUND,
            "not_found",
        ),
        (
            "huge declared size",
            put(
                "/v1/scenes/s/views/v",
                upload_body(&huge_pfm, &[], &camera_json(0.0, 0.0)),
            ),
            StatusCode::PAYLOAD_TOO_LARGE,
            "too_large",
        ),
        (
            "oversized body",
            put(
                "/v1/scenes/s/views/v",
                upload_body(&vec![0u8; 100 << 10], &[], &camera_json(0.0, 0.0)),
            ),
            StatusCode::PAYLOAD_TOO_LARGE,
            "too_large",
        ),
        (
            "wrong media type",
            Request::put("/v1/scenes/s/views/v")
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from("{}"))
                .unwrap(),
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "unsupported_media_type",
        ),
        (
            "malformed JSON",
            Request::post("/v1/scenes/s/render")
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from("{\"camera\": "))
                .unwrap(),
            StatusCode::BAD_REQUEST,
            "bad_request",
        ),
        (
            "bad id",
            Request::get("/v1/scenes/a..b%2F/views").body(Body::empty()).unwrap(),
            StatusCode::BAD_REQUEST,
            "bad_request",
        ),
        (
            "epsilon and tau",
            Request::get("/v1/scenes/s/views/v/strips?epsilon=1&tau=1")
                .body(Body::empty())
                .unwrap(),
            StatusCode::BAD_REQUEST,
            "bad_request",
        ),
        (
            "negative epsilon",
            Request::get("/v1/scenes/s/views/v/strips?epsilon=-1")
                .body(Body::empty())
                .unwrap(),
            StatusCode::BAD_REQUEST,
            "bad_request",
        ),
    ];
    for (name, req, want, code) in cases {
        let (status, _, body) = send(&router, req).await;
        assert_eq!(status, want, "{name}: {}", String::from_utf8_lossy(&body));
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap_or_else(|_| panic!("{name}: body is not JSON"));
        assert_eq!(v["error"]["code"], code, "{name}");
        assert!(!v["error"]["message"].as_str().unwrap().is_empty(), "{name}");
    }
    // The failed uploads left the first version intact.
    let (status, _, body) = send(
        &router,
        Request::get("/v1/scenes/s/views/v/strips?epsilon=0.001")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
}

fn stalled_upload() -> Request<Body> {
    // A body that never arrives: the request holds its slot until it is cut off.
    let body = Body::from_stream(futures_util::stream::pending::<Result<axum::body::Bytes, std::io::Error>>());
    Request::put("/v1/scenes/s/views/slow")
        .header(
            header::CONTENT_TYPE,
            format!("multipart/form-data; boundary={BOUNDARY}"),
        )
        .body(body)
        .unwrap()
}

#[tokio::test]
async fn overload_is_shed_with_503_and_retry_after() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = Pipeline {
        max_concurrency: 1,
        queue_wait: std::time::Duration::from_millis(20),
        timeout: std::time::Duration::from_secs(30),
    };
    let router = start(state(dir.path(), Settings::default()), pipeline).await;
    let addr = router.addr;
    let busy = tokio::spawn(async move {
        let mut req = stalled_upload();
        *req.uri_mut() = format!("http://{addr}/v1/scenes/s/views/slow").parse().unwrap();
        Client::builder(TokioExecutor::new())
            .build_http::<Body>()
            .request(req)
            .await
    });
    // Once the stalled upload holds the only slot, every other request is
    // shed after its 20 ms queue wait (poll until it has reached the server, however slow the machine).
    let mut shed = None;
    for _ in 0..100 {
        let reply = send(&router, Request::get("/healthz").body(Body::empty()).unwrap()).await;
        if reply.0 == StatusCode::SERVICE_UNAVAILABLE {
            shed = Some(reply);
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    }
    let (status, headers, body) = shed.expect("no request was shed while the only slot was taken");
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(headers[header::RETRY_AFTER], "1");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["error"]["code"], "overloaded");
    busy.abort();
}

#[tokio::test]
async fn slow_requests_time_out_with_408() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = Pipeline {
        max_concurrency: 4,
        timeout: std::time::Duration::from_millis(200),
        ..Pipeline::default()
    };
    let router = start(state(dir.path(), Settings::default()), pipeline).await;
    let (status, _, body) = send(&router, stalled_upload()).await;
    assert_eq!(status, StatusCode::REQUEST_TIMEOUT);
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["error"]["code"], "timeout");
}

#[tokio::test]
async fn responses_are_compressed_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let router = start(state(dir.path(), Settings::default()), Pipeline::default()).await;
    let (status, _, _) = send(
        &router,
        put(
            "/v1/scenes/s/views/v",
            upload_body(&encode_pfm(W, H, &depth()), &[], &camera_json(0.0, 0.0)),
        ),
    )
    .await;
    assert_eq!(status, StatusCode::CREATED);
    for encoding in ["gzip", "zstd"] {
        let req = Request::get("/v1/scenes/s/views/v/strips?epsilon=0")
            .header(header::ACCEPT_ENCODING, encoding)
            .body(Body::empty())
            .unwrap();
        let (status, headers, _) = send(&router, req).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(headers[header::CONTENT_ENCODING], encoding);
    }
}

fn get_strips(uri: &str) -> Request<Body> {
    Request::get(uri)
        .header(header::ACCEPT, dmesh_proto::BINCODE_MEDIA_TYPE)
        .body(Body::empty())
        .unwrap()
}

#[tokio::test]
async fn residual_bits_and_triangle_budgets() {
    let dir = tempfile::tempdir().unwrap();
    let router = start(state(dir.path(), Settings::default()), Pipeline::default()).await;
    // 16-bit depth over most of the range, smooth with one step.
    let img = image::ImageBuffer::<image::Luma<u16>, _>::from_fn(W, H, |x, y| {
        let smooth = 9000.0 + 4000.0 * (x as f64 * 0.3).sin() + 57.0 * f64::from(y);
        image::Luma([smooth as u16 + if x > 30 { 40_000 } else { 0 }])
    });
    let mut png = Vec::new();
    image::DynamicImage::ImageLuma16(img)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let body = upload_body(&png, &[("scale", b"0.0001")], &camera_json(0.0, 0.0));
    let (status, _, body) = send(&router, put("/v1/scenes/r/views/v", body)).await;
    assert_eq!(status, StatusCode::CREATED, "{}", String::from_utf8_lossy(&body));

    let fetch = |uri: String| {
        let router = &router;
        async move {
            let (status, headers, body) = send(router, get_strips(&uri)).await;
            assert_eq!(status, StatusCode::OK, "{uri}: {}", String::from_utf8_lossy(&body));
            (
                headers,
                dmesh_proto::from_bincode::<StripResponse>(&body).unwrap(),
                body.len(),
            )
        }
    };
    let (_, exact, exact_bytes) = fetch("/v1/scenes/r/views/v/strips?epsilon=0".into()).await;
    check_strips(&exact);
    let truth = exact.decode_depths().unwrap();
    let (_, lossless, _) = fetch("/v1/scenes/r/views/v/strips?epsilon=0&bits=16".into()).await;
    assert_eq!(
        lossless.decode_depths().unwrap(),
        truth,
        "bits = 16 must be lossless for 16-bit input"
    );
    let mut last_bytes = usize::MAX;
    for bits in (0..=16).rev() {
        let (headers, r, bytes) = fetch(format!("/v1/scenes/r/views/v/strips?epsilon=0&bits={bits}")).await;
        let dmesh_proto::Depths::Residual(res) = &r.depths else {
            panic!("bits {bits}: exact depths")
        };
        assert!(headers[header::ETAG].to_str().unwrap().contains(&format!("-b{bits}")));
        let back = r.decode_depths().unwrap();
        for (a, b) in back.iter().zip(&truth) {
            assert!((a - b).abs() <= res.max_error, "bits {bits}: {a} vs {b}");
        }
        if bits > 0 {
            assert!(f64::from(res.max_error) <= res.step() / 2.0 + 1e-6, "bits {bits}");
        }
        assert!(bytes <= last_bytes && bytes < exact_bytes, "bits {bits}: {bytes} bytes");
        last_bytes = bytes;
    }

    // Budgets: never above max_triangles; the response says the tolerance used.
    for max in [50u32, 300, 1000, 100_000] {
        let (_, r, _) = fetch(format!("/v1/scenes/r/views/v/strips?max_triangles={max}")).await;
        check_strips(&r);
        assert!(r.triangles <= max, "{} > {max}", r.triangles);
        assert!(matches!(r.lod, dmesh_proto::Lod::Epsilon(e) if e >= 0.0));
        let cam = camera_json(0.2, 0.3);
        let uri = format!(
            "/v1/scenes/r/views/v/strips?max_triangles={max}&camera={}",
            urlencode(&cam)
        );
        let (_, r, _) = fetch(uri).await;
        assert!(r.triangles <= max, "{} > {max}", r.triangles);
    }
    let (_, r, _) = fetch("/v1/scenes/r/views/v/strips?budget_ms=0.5&bits=8".into()).await;
    assert!(r.triangles > 0);
    for (uri, why) in [
        ("/v1/scenes/r/views/v/strips?epsilon=0&bits=17", "bits is 17"),
        ("/v1/scenes/r/views/v/strips?epsilon=0&max_triangles=9", "exactly one"),
        ("/v1/scenes/r/views/v/strips?max_triangles=1", "coarsest"),
        ("/v1/scenes/r/views/v/strips?budget_ms=-1", "budget_ms"),
    ] {
        let (status, _, body) = send(&router, get_strips(uri)).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{uri}");
        assert!(
            String::from_utf8_lossy(&body).contains(why),
            "{uri}: {}",
            String::from_utf8_lossy(&body)
        );
    }
}

#[tokio::test]
async fn render_loads_only_the_selected_views_and_sees_store_changes() {
    let dir = tempfile::tempdir().unwrap();
    {
        let router = start(state(dir.path(), Settings::default()), Pipeline::default()).await;
        let pfm = encode_pfm(W, H, &depth());
        for (k, yaw) in [0.0, 1.2, 2.4].iter().enumerate() {
            let body = upload_body(&pfm, &[], &camera_json(*yaw, 0.0));
            let (status, _, _) = send(&router, put(&format!("/v1/scenes/s/views/v{k}"), body)).await;
            assert_eq!(status, StatusCode::CREATED);
        }
    }
    // A fresh server over the same store: nothing is loaded yet.
    let router = start(state(dir.path(), Settings::default()), Pipeline::default()).await;
    let render = |max_views: u32| {
        let body = format!(
            r#"{{"camera": {}, "tau": 1, "max_views": {max_views}}}"#,
            camera_json(0.1, 0.0)
        );
        Request::post("/v1/scenes/s/render")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body))
            .unwrap()
    };
    let loaded = |metrics: &[u8]| {
        String::from_utf8_lossy(metrics)
            .lines()
            .find_map(|l| {
                l.strip_prefix("dmesh_views_loaded ")
                    .map(|n| n.trim().parse::<u32>().unwrap())
            })
            .unwrap()
    };
    let (status, _, body) = send(&router, render(1)).await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    let r: dmesh_proto::RenderResponse = serde_json::from_slice(&body).unwrap();
    assert_eq!(r.views.len(), 1);
    assert!(r.views[0].color_url.contains("/v0/"), "{}", r.views[0].color_url);
    let metrics = send(&router, Request::get("/metrics").body(Body::empty()).unwrap())
        .await
        .2;
    assert_eq!(loaded(&metrics), 1, "only the selected view is built");
    // Deleting the selected view changes the next selection at once.
    let (status, _, _) = send(
        &router,
        Request::delete("/v1/scenes/s/views/v0").body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::NO_CONTENT);
    let (status, _, body) = send(&router, render(1)).await;
    assert_eq!(status, StatusCode::OK);
    let r: dmesh_proto::RenderResponse = serde_json::from_slice(&body).unwrap();
    assert!(!r.views[0].color_url.contains("/v0/"), "{}", r.views[0].color_url);
}
