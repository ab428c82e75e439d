//! The HTTP service, started for real on 127.0.0.1:0 with a temporary data
//! directory and driven by an HTTP client: upload of each depth format,
//! listing, strips static and view-dependent in JSON and bincode (decoded and
//! checked conforming), ETags, render weights, restart, deletion, shedding,
//! timeouts, compression, and a table of bad inputs with their statuses.

// The engine's mesh checks (conforming triangulations), shared with its tests.
#[path = "../engine/tests/common/mod.rs"]
mod common;
mod server_support;

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use dmesh::http::{Pipeline, Settings};
use dmesh_engine::image::{encode_exr, encode_pfm, Limits};
use dmesh_proto::{RenderResponse, StripResponse, ViewSummary};
use hyper_util::client::legacy::Client;
use hyper_util::rt::TokioExecutor;
use server_support::*;

on_both_stores!(
    upload_list_strips_render_restart_delete,
    bad_inputs_get_their_status_and_code_and_keep_the_stored_view,
    overload_is_shed_with_503_and_retry_after_and_uploads_never_take_read_slots,
    slow_requests_time_out_with_408,
    responses_are_compressed_when_asked,
);

async fn upload_list_strips_render_restart_delete(kind: Store) {
    let store = Backing::new(kind);
    let router = start(store.state(Settings::default()), Pipeline::default()).await;
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
            r#"{{"camera": {}, "lod": {{"tau": 1.0}}}}"#,
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
    let restarted = start(store.state(Settings::default()), Pipeline::default()).await;
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

async fn bad_inputs_get_their_status_and_code_and_keep_the_stored_view(kind: Store) {
    let store = Backing::new(kind);
    let settings = Settings {
        max_upload_bytes: 64 << 10,
        limits: Limits { max_pixels: 1 << 20 },
        cache_bytes: 1 << 20,
        ..Settings::default()
    };
    let router = start(store.state(settings), Pipeline::default()).await;
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
            "size mismatch in a live frame (checked from the colour's header)",
            put(
                "/v1/scenes/s/views/v?live=true",
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
            "a live frame's colour that is no image",
            put(
                "/v1/scenes/s/views/v?live=true",
                multipart(&[
                    ("camera", camera_json(0.0, 0.0).as_bytes()),
                    ("depth", &good),
                    ("color", b"GIF89a not an image we take"),
                ]),
            ),
            StatusCode::UNPROCESSABLE_ENTITY,
            "undecodable_image",
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

async fn overload_is_shed_with_503_and_retry_after_and_uploads_never_take_read_slots(kind: Store) {
    let store = Backing::new(kind);
    let pipeline = Pipeline {
        max_concurrency: 1,
        max_uploads: 1,
        queue_wait: std::time::Duration::from_millis(20),
        timeout: std::time::Duration::from_secs(30),
    };
    let router = start(store.state(Settings::default()), pipeline).await;
    let addr = router.addr;
    let busy = tokio::spawn(async move {
        let mut req = stalled_upload();
        *req.uri_mut() = format!("http://{addr}/v1/scenes/s/views/slow").parse().unwrap();
        Client::builder(TokioExecutor::new())
            .build_http::<Body>()
            .request(req)
            .await
    });
    // Once the stalled upload holds the only upload slot, another upload is
    // shed after its 20 ms queue wait (poll until the first has reached the
    // server, however slow the machine).
    let mut shed = None;
    for _ in 0..100 {
        let mut second = stalled_upload();
        *second.uri_mut() = "/v1/scenes/s/views/other".parse().unwrap();
        let reply = tokio::time::timeout(std::time::Duration::from_millis(500), send(&router, second)).await;
        if let Ok(reply) = reply {
            if reply.0 == StatusCode::SERVICE_UNAVAILABLE {
                shed = Some(reply);
                break;
            }
        }
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    }
    let (status, headers, body) = shed.expect("no upload was shed while the only upload slot was taken");
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(headers[header::RETRY_AFTER], "1");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["error"]["code"], "overloaded");
    // Reads have slots of their own: the stalled upload takes none of them.
    for uri in ["/v1/scenes", "/v1/scenes/s/views", "/healthz"] {
        let (status, _, _) = send(&router, Request::get(uri).body(Body::empty()).unwrap()).await;
        assert!(
            !status.is_server_error(),
            "{uri} answered {status} while an upload held the only upload slot"
        );
    }
    busy.abort();
}

async fn slow_requests_time_out_with_408(kind: Store) {
    let store = Backing::new(kind);
    let pipeline = Pipeline {
        max_concurrency: 4,
        timeout: std::time::Duration::from_millis(200),
        ..Pipeline::default()
    };
    let router = start(store.state(Settings::default()), pipeline).await;
    let (status, _, body) = send(&router, stalled_upload()).await;
    assert_eq!(status, StatusCode::REQUEST_TIMEOUT);
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["error"]["code"], "timeout");
}

async fn responses_are_compressed_when_asked(kind: Store) {
    let store = Backing::new(kind);
    let router = start(store.state(Settings::default()), Pipeline::default()).await;
    let (status, _, _) = send(
        &router,
        put(
            "/v1/scenes/s/views/v",
            upload_body(&encode_pfm(W, H, &depth()), &[], &camera_json(0.0, 0.0)),
        ),
    )
    .await;
    assert_eq!(status, StatusCode::CREATED);
    let strips = |encoding: Option<&str>| {
        let mut req = Request::get("/v1/scenes/s/views/v/strips?epsilon=0");
        if let Some(e) = encoding {
            req = req.header(header::ACCEPT_ENCODING, e);
        }
        req.body(Body::empty()).unwrap()
    };
    let (status, headers, plain) = send(&router, strips(None)).await;
    assert_eq!(status, StatusCode::OK);
    assert!(headers.get(header::CONTENT_ENCODING).is_none());
    for encoding in ["gzip", "zstd"] {
        let (status, headers, body) = send(&router, strips(Some(encoding))).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(headers[header::CONTENT_ENCODING], encoding);
        // The body decodes to the uncompressed answer, and is smaller.
        let decoded = match encoding {
            "gzip" => {
                let mut out = Vec::new();
                std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(&body[..]), &mut out).unwrap();
                out
            }
            _ => zstd::stream::decode_all(&body[..]).unwrap(),
        };
        // The same answer but its timing.
        let answer = |bytes: &[u8]| {
            let mut v: serde_json::Value = serde_json::from_slice(bytes).expect("a JSON strip answer");
            v["extract_ms"] = serde_json::Value::Null;
            v
        };
        assert!(
            answer(&decoded) == answer(&plain),
            "{encoding}: the body decodes to another answer"
        );
        assert!(
            body.len() < plain.len(),
            "{encoding}: {} of {} bytes",
            body.len(),
            plain.len()
        );
    }
}

/// A 16-bit PGM depth (a depth camera's raw frame) is read as the same
/// samples in a 16-bit PNG are: the same mesh, the same depths, and the
/// integer lattice kept (all planes of the compact stream lossless).
#[tokio::test]
async fn a_pgm_depth_is_the_png_depth_it_holds() {
    let store = Backing::new(Store::File);
    let router = start(store.state(Settings::default()), Pipeline::default()).await;
    let samples: Vec<u16> = (0..W * H).map(|k| 2000 + ((k % W) * 3 + k / W) as u16).collect();
    let pgm = dmesh_engine::image::pgm::encode16(W, H, &samples);
    for (view, bytes) in [("png", png16_depth()), ("pgm", pgm)] {
        let body = upload_body(&bytes, &[("scale", b"0.001")], &camera_json(0.0, 0.0));
        let (status, _, body) = send(&router, put(&format!("/v1/scenes/s/views/{view}"), body)).await;
        assert_eq!(status, StatusCode::CREATED, "{}", String::from_utf8_lossy(&body));
    }
    let strips = |view: &str| {
        Request::get(format!("/v1/scenes/s/views/{view}/strips?epsilon=0.0005"))
            .header(header::ACCEPT, "application/json")
            .body(Body::empty())
            .unwrap()
    };
    let (_, _, png) = send(&router, strips("png")).await;
    let (_, _, pgm) = send(&router, strips("pgm")).await;
    let (mut png, mut pgm): (StripResponse, StripResponse) = (
        serde_json::from_slice(&png).unwrap(),
        serde_json::from_slice(&pgm).unwrap(),
    );
    assert!(png.triangles > 100);
    (png.view, png.extract_ms, pgm.view, pgm.extract_ms) = (String::new(), 0.0, String::new(), 0.0);
    assert_eq!(png, pgm);
    // Lossless on its lattice: all compact planes decode the vertices to
    // the stored depths, on the 1 mm lattice; a cut's crossing sides,
    // extrapolated between samples, are rounded onto it (half a step).
    let (status, _, body) = send(
        &router,
        Request::get("/v1/scenes/s/views/pgm/strips?epsilon=0.0005")
            .header(header::ACCEPT, dmesh_proto::MESH_MEDIA_TYPE)
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::OK);
    let dmesh_proto::MeshBody::Mesh(mesh) = dmesh_proto::from_bincode(&body).unwrap() else {
        panic!("a whole mesh")
    };
    assert!(mesh.max_error <= 0.0005 * 1.0001, "{}", mesh.max_error);
    assert_eq!(mesh.lattice.map(|g| g.scale), Some(0.001));
    let decoded = mesh.decode().unwrap();
    let off_lattice = |z: f32| (f64::from(z) * 1000.0 - (f64::from(z) * 1000.0).round()).abs() > 1e-3;
    assert!(!decoded.depths.iter().any(|&z| off_lattice(z)));
    if decoded.cuts.is_empty() {
        assert_eq!(mesh.max_error, 0.0);
    }
}

/// `PUT ...?live=true` stores a frame that readers see at once; the server
/// makes the latest frame of each live view durable once it is due, and a
/// frame that is not live, or a delete, ends the view's live frames.
#[tokio::test]
async fn live_frames_are_visible_at_once_and_made_durable_when_due() {
    let store = Backing::new(Store::File);
    let state = store.state(Settings::default());
    let router = start(state.clone(), Pipeline::default()).await;
    let frame = |live: bool| {
        let uri = if live {
            "/v1/scenes/s/views/cam?live=true"
        } else {
            "/v1/scenes/s/views/cam"
        };
        put(
            uri,
            upload_body(&png16_depth(), &[("scale", b"0.001")], &camera_json(0.0, 0.0)),
        )
    };
    let hour = std::time::Duration::from_secs(3600);
    let now = std::time::Duration::ZERO;
    for _ in 0..3 {
        let (status, _, body) = send(&router, frame(true)).await;
        assert_eq!(status, StatusCode::CREATED, "{}", String::from_utf8_lossy(&body));
        let (status, _, _) = send(
            &router,
            Request::get("/v1/scenes/s/views/cam").body(Body::empty()).unwrap(),
        )
        .await;
        assert_eq!(status, StatusCode::OK, "a live frame is visible at once");
    }
    // Answers drawn from a live frame say how old it is; others do not.
    let frame_age = || async {
        let (status, headers, _) = send(
            &router,
            Request::get("/v1/scenes/s/views/cam/strips?epsilon=0.001")
                .header(header::ACCEPT, "application/json")
                .body(Body::empty())
                .unwrap(),
        )
        .await;
        assert_eq!(status, StatusCode::OK);
        headers
            .get(dmesh::http::strips::FRAME_AGE)
            .map(|v| v.to_str().unwrap().parse::<f64>().unwrap())
    };
    let age = frame_age().await.expect("a live frame's age");
    assert!((0.0..60_000.0).contains(&age), "age {age} ms");
    assert_eq!(state.persist_live(hour).unwrap(), 0, "not due yet");
    assert_eq!(state.persist_live(now).unwrap(), 1, "one live view, its latest frame");
    assert_eq!(state.persist_live(now).unwrap(), 0, "nothing left");
    send(&router, frame(true)).await;
    send(&router, frame(false)).await;
    assert_eq!(frame_age().await, None, "a frame that is not live has no age");
    assert_eq!(
        state.persist_live(now).unwrap(),
        0,
        "a durable frame ends the live ones"
    );
    send(&router, frame(true)).await;
    let (status, _, _) = send(
        &router,
        Request::delete("/v1/scenes/s/views/cam").body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::NO_CONTENT);
    assert_eq!(
        state.persist_live(now).unwrap(),
        0,
        "a deleted view has nothing to keep"
    );
}

/// Live replaces under concurrent readers are never torn: while two
/// distinct frames are put live in turn, every strip answer read meanwhile
/// is exactly one frame's answer (its depths all from one frame), never a
/// mix, and a summary names one of the frames' sample counts.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn live_replaces_under_concurrent_readers_are_never_torn() {
    let store = Backing::new(Store::File);
    let router = std::sync::Arc::new(start(store.state(Settings::default()), Pipeline::default()).await);
    // Frame A: the usual depths; frame B: the same, 30 % further, with a
    // hole of invalid samples (another valid count).
    let a = depth();
    let b: Vec<f32> = a
        .iter()
        .enumerate()
        .map(|(k, &z)| if k % (W as usize) < 6 { 0.0 } else { z * 1.3 })
        .collect();
    let frames = [encode_pfm(W, H, &a), encode_pfm(W, H, &b)];
    let put_frame = |k: usize| {
        put(
            "/v1/scenes/s/views/cam?live=true",
            upload_body(&frames[k], &[], &camera_json(0.0, 0.0)),
        )
    };
    let strips = || {
        Request::get("/v1/scenes/s/views/cam/strips?epsilon=0")
            .header(header::ACCEPT, "application/json")
            .body(Body::empty())
            .unwrap()
    };
    // Each frame's own answer, with nothing else going on.
    let mut want = Vec::new();
    for k in 0..2 {
        let (status, _, _) = send(&router, put_frame(k)).await;
        assert_eq!(status, StatusCode::CREATED);
        let (_, _, body) = send(&router, strips()).await;
        let mut r: StripResponse = serde_json::from_slice(&body).unwrap();
        r.extract_ms = 0.0;
        want.push(r);
    }
    assert_ne!(want[0].depths, want[1].depths);
    let writer = {
        let router = router.clone();
        let frames = frames.clone();
        tokio::spawn(async move {
            for k in 0..40 {
                let req = put(
                    "/v1/scenes/s/views/cam?live=true",
                    upload_body(&frames[k % 2], &[], &camera_json(0.0, 0.0)),
                );
                let (status, _, _) = send(&router, req).await;
                assert_eq!(status, StatusCode::CREATED);
            }
        })
    };
    let mut seen = [0usize; 2];
    while !writer.is_finished() {
        let (status, _, body) = send(&router, strips()).await;
        if status == StatusCode::SERVICE_UNAVAILABLE {
            continue;
        }
        assert_eq!(status, StatusCode::OK);
        let mut r: StripResponse = serde_json::from_slice(&body).unwrap();
        r.extract_ms = 0.0;
        let which = want
            .iter()
            .position(|w| *w == r)
            .expect("an answer that is neither frame's: torn");
        seen[which] += 1;
    }
    writer.await.unwrap();
    assert!(seen[0] + seen[1] >= 5, "readers ran meanwhile: {seen:?}");
}
