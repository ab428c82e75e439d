//! The server calls, over HTTP/1.1 with hyper.

use std::path::PathBuf;

use anyhow::Context as _;
use bytes::Bytes;
use http_body_util::{BodyExt, Full};
use hyper::{header, Method, Request, StatusCode};
use hyper_util::client::legacy::{connect::HttpConnector, Client};
use hyper_util::rt::TokioExecutor;

/// A client of one dmesh server.
#[derive(Clone)]
pub struct Server {
    base: String,
    client: Client<HttpConnector, Full<Bytes>>,
    cache: Option<PathBuf>,
    wire: Wire,
}

/// How meshes travel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Wire {
    /// Protocol 7, the compact stream, zstd-coded (the default).
    #[default]
    Compact,
    /// Protocol 5, bincode vertex records and strips, uncompressed.
    Bincode,
}

/// A compact mesh a client holds, which a later request of the same view
/// names to receive only the change from it (protocol 7).
#[derive(Clone, Debug)]
pub struct HeldMesh {
    /// The ETag of the answer that made it.
    pub etag: String,
    /// The requesting camera it was made for.
    pub camera: Option<dmesh_proto::Camera>,
    /// The mesh as decoded.
    pub decoded: dmesh_proto::compact::DecodedMesh,
}

/// A failed call, with the server's error body when it sent one.
#[derive(Debug, thiserror::Error)]
#[error("{method} {path}: {status}: {message}")]
pub struct CallError {
    method: Method,
    path: String,
    status: StatusCode,
    message: String,
}

impl CallError {
    /// The status the server answered.
    pub fn status(&self) -> StatusCode {
        self.status
    }
}

impl Server {
    /// A client of `base` (`http://host:port`); colour images are cached in `cache` by ETag.
    pub fn new(base: &str, cache: Option<PathBuf>) -> Self {
        Self {
            base: base.trim_end_matches('/').to_string(),
            client: Client::builder(TokioExecutor::new()).build_http(),
            cache,
            wire: Wire::Compact,
        }
    }

    /// The same client asking for meshes in `wire`.
    pub fn with_wire(mut self, wire: Wire) -> Self {
        self.wire = wire;
        self
    }

    async fn call(
        &self,
        method: Method,
        path: &str,
        headers: &[(header::HeaderName, String)],
        body: Vec<u8>,
    ) -> anyhow::Result<(StatusCode, hyper::HeaderMap, Bytes)> {
        let (status, headers, body, _) = self.call_sized(method, path, headers, body).await?;
        Ok((status, headers, body))
    }

    /// [`Self::call`], with the body's size as it travelled (before content decoding).
    async fn call_sized(
        &self,
        method: Method,
        path: &str,
        headers: &[(header::HeaderName, String)],
        body: Vec<u8>,
    ) -> anyhow::Result<(StatusCode, hyper::HeaderMap, Bytes, usize)> {
        let mut req = Request::builder()
            .method(method.clone())
            .uri(format!("{}{path}", self.base));
        for (k, v) in headers {
            req = req.header(k, v);
        }
        let resp = self.client.request(req.body(Full::new(Bytes::from(body)))?).await?;
        let status = resp.status();
        let headers = resp.headers().clone();
        let body = resp.into_body().collect().await?.to_bytes();
        let zstd = headers
            .get(header::CONTENT_ENCODING)
            .is_some_and(|v| v.as_bytes().eq_ignore_ascii_case(b"zstd"));
        let travelled = body.len();
        let body = if zstd {
            Bytes::from(zstd::stream::decode_all(&body[..])?)
        } else {
            body
        };
        if !(status.is_success() || status == StatusCode::NOT_MODIFIED) {
            let message = serde_json::from_slice::<dmesh_proto::ErrorBody>(&body).map_or_else(
                |_| String::from_utf8_lossy(&body).into_owned(),
                |e| format!("{} ({})", e.error.message, e.error.code),
            );
            return Err(CallError {
                method,
                path: path.to_string(),
                status,
                message,
            }
            .into());
        }
        Ok((status, headers, body, travelled))
    }

    /// Uploads one view (multipart): camera JSON, depth bytes, colour bytes.
    pub async fn put_view(
        &self,
        scene: &str,
        view: &str,
        camera_json: &str,
        depth: &[u8],
        color: &[u8],
    ) -> anyhow::Result<dmesh_proto::ViewSummary> {
        self.put_view_with(scene, view, camera_json, depth, color, &[]).await
    }

    /// Uploads one view with extra form fields (`depth_kind`, `scale`, `focal_baseline`, ...).
    pub async fn put_view_with(
        &self,
        scene: &str,
        view: &str,
        camera_json: &str,
        depth: &[u8],
        color: &[u8],
        fields: &[(&str, String)],
    ) -> anyhow::Result<dmesh_proto::ViewSummary> {
        self.put_frame(scene, view, camera_json, depth, color, fields, false)
            .await
    }

    /// [`Self::put_view_with`], as a frame of a live view when `live`
    /// (`?live=true`: visible at once, made durable within the server's
    /// `--live-persist-secs`).
    #[allow(clippy::too_many_arguments)]
    pub async fn put_frame(
        &self,
        scene: &str,
        view: &str,
        camera_json: &str,
        depth: &[u8],
        color: &[u8],
        fields: &[(&str, String)],
        live: bool,
    ) -> anyhow::Result<dmesh_proto::ViewSummary> {
        let boundary = "dmesh-client-boundary";
        let extra = fields.iter().map(|(k, v)| (*k, v.as_bytes()));
        // Sized once: a 1920 x 1080 frame's body is megabytes, which
        // growing by doubling copied (and faulted in) again and again.
        let parts: usize = [camera_json.len(), depth.len(), color.len()]
            .into_iter()
            .chain(fields.iter().map(|(k, v)| k.len() + v.len()))
            .map(|n| n + 128)
            .sum();
        let mut body = Vec::with_capacity(parts + 64);
        for (name, data) in [("camera", camera_json.as_bytes()), ("depth", depth), ("color", color)]
            .into_iter()
            .chain(extra)
        {
            body.extend_from_slice(
                format!("--{boundary}\r\nContent-Disposition: form-data; name=\"{name}\"\r\n\r\n").as_bytes(),
            );
            body.extend_from_slice(data);
            body.extend_from_slice(b"\r\n");
        }
        body.extend_from_slice(format!("--{boundary}--\r\n").as_bytes());
        let ct = format!("multipart/form-data; boundary={boundary}");
        let (_, _, bytes) = self
            .call(
                Method::PUT,
                &format!(
                    "/v1/scenes/{scene}/views/{view}{}",
                    if live { "?live=true" } else { "" }
                ),
                &[(header::CONTENT_TYPE, ct)],
                body,
            )
            .await?;
        Ok(serde_json::from_slice(&bytes)?)
    }

    /// Asks for a novel view's views, weights and strips.
    pub async fn render(
        &self,
        scene: &str,
        request: &dmesh_proto::RenderRequest,
    ) -> anyhow::Result<dmesh_proto::RenderResponse> {
        let (_, _, bytes, _) = self
            .post_json(&format!("/v1/scenes/{scene}/render"), serde_json::to_vec(request)?)
            .await?;
        match self.wire {
            Wire::Bincode => Ok(dmesh_proto::from_bincode(&bytes)?),
            Wire::Compact => {
                let stream: dmesh_proto::RenderStream = dmesh_proto::from_bincode(&bytes)?;
                let novel = dmesh_engine::camera::Camera::try_from(&request.camera)?;
                Ok(dmesh_engine::wire_compact::render_response(&stream, &novel)?)
            }
        }
    }

    /// POSTs a JSON body asking for a mesh in this client's wire; the
    /// answer's body as it travelled (zstd-coded for the compact stream) is
    /// decoded by [`Self::call`].
    async fn post_json(
        &self,
        path: &str,
        body: Vec<u8>,
    ) -> anyhow::Result<(StatusCode, hyper::HeaderMap, Bytes, usize)> {
        let mut headers = vec![(header::CONTENT_TYPE, "application/json".to_string())];
        match self.wire {
            Wire::Bincode => headers.push((header::ACCEPT, dmesh_proto::BINCODE_MEDIA_TYPE.to_string())),
            Wire::Compact => {
                headers.push((header::ACCEPT, dmesh_proto::MESH_MEDIA_TYPE.to_string()));
                headers.push((header::ACCEPT_ENCODING, "zstd".to_string()));
            }
        }
        self.call_sized(Method::POST, path, &headers, body).await
    }

    /// The reference cameras of a scene's views.
    pub async fn cameras(&self, scene: &str) -> anyhow::Result<Vec<dmesh_engine::camera::Camera>> {
        self.views(scene)
            .await?
            .iter()
            .map(|v| Ok(dmesh_engine::camera::Camera::try_from(&v.camera)?))
            .collect()
    }

    /// The summaries of a scene's views, in the server's (sorted) order.
    pub async fn views(&self, scene: &str) -> anyhow::Result<Vec<dmesh_proto::ViewSummary>> {
        let (_, _, bytes) = self
            .call(Method::GET, &format!("/v1/scenes/{scene}/views"), &[], Vec::new())
            .await?;
        let list: dmesh_proto::ViewList = serde_json::from_slice(&bytes)?;
        let mut out = Vec::new();
        for view in list.views {
            let (_, _, bytes) = self
                .call(
                    Method::GET,
                    &format!("/v1/scenes/{scene}/views/{view}"),
                    &[],
                    Vec::new(),
                )
                .await?;
            out.push(serde_json::from_slice(&bytes)?);
        }
        Ok(out)
    }

    /// One view's mesh, with the response's size in bytes as it travelled.
    pub async fn strips(
        &self,
        scene: &str,
        view: &str,
        request: &dmesh_proto::StripRequest,
    ) -> anyhow::Result<(dmesh_proto::StripResponse, usize)> {
        let (mesh, _, size) = self.strips_from(scene, view, request, None).await?;
        Ok((mesh, size))
    }

    /// One view's mesh as [`Self::strips`] gives it, naming `held` (another
    /// mesh of the view this client decoded) so that the compact stream
    /// sends only the change from it; with what to hold for the next
    /// request (`None` on the bincode wire).
    pub async fn strips_from(
        &self,
        scene: &str,
        view: &str,
        request: &dmesh_proto::StripRequest,
        held: Option<&HeldMesh>,
    ) -> anyhow::Result<(dmesh_proto::StripResponse, Option<HeldMesh>, usize)> {
        if self.wire == Wire::Bincode {
            let (_, _, bytes, size) = self
                .post_json(
                    &format!("/v1/scenes/{scene}/views/{view}/strips"),
                    serde_json::to_vec(request)?,
                )
                .await?;
            return Ok((dmesh_proto::from_bincode(&bytes)?, None, size));
        }
        let mut request = request.clone();
        request.held = held.map(|h| h.etag.clone());
        request.held_camera = held.and_then(|h| h.camera.clone());
        let (body, etag, size) = self.mesh_body(scene, view, &request).await?;
        let camera = request
            .camera
            .as_ref()
            .map(dmesh_engine::camera::Camera::try_from)
            .transpose()?;
        let (stream, decoded) = match body {
            dmesh_proto::MeshBody::Mesh(stream) => {
                let decoded = stream.decode()?;
                (*stream, decoded)
            }
            dmesh_proto::MeshBody::Change(change) => {
                let held = held.context("the server sent a change for a request that held no mesh")?;
                let decoded = change.apply(&held.decoded)?;
                (change.mesh, decoded)
            }
            dmesh_proto::MeshBody::Planes(_) => {
                anyhow::bail!("the server sent planes for a request that held the mesh at every plane asked")
            }
        };
        let next = HeldMesh {
            etag,
            camera: request.camera.clone(),
            decoded: decoded.clone(),
        };
        let mesh = dmesh_engine::wire_compact::decoded_response(&stream, decoded, camera.as_ref())?;
        Ok((mesh, Some(next), size))
    }

    /// One view's mesh in the compact stream as it arrived: the whole mesh
    /// (its `etag` set from the answer's), or the planes a held one lacks
    /// (`request.held`), with the answer's ETag and its size as it travelled.
    pub async fn mesh_body(
        &self,
        scene: &str,
        view: &str,
        request: &dmesh_proto::StripRequest,
    ) -> anyhow::Result<(dmesh_proto::MeshBody, String, usize)> {
        let (_, headers, bytes, size) = self
            .clone()
            .with_wire(Wire::Compact)
            .post_json(
                &format!("/v1/scenes/{scene}/views/{view}/strips"),
                serde_json::to_vec(request)?,
            )
            .await?;
        let etag = headers
            .get(header::ETAG)
            .and_then(|v| v.to_str().ok())
            .unwrap_or_default()
            .to_string();
        let mut body: dmesh_proto::MeshBody = dmesh_proto::from_bincode(&bytes)?;
        if let dmesh_proto::MeshBody::Mesh(m) = &mut body {
            m.etag.clone_from(&etag);
        }
        Ok((body, etag, size))
    }

    /// Sends a render request without decoding the answer: its size and the
    /// server's extraction milliseconds from `Server-Timing` (what a load
    /// generator needs, without spending the machine's CPU on decoding), or
    /// the failing status (0 for a transport error).
    pub async fn render_timed(&self, scene: &str, request: &dmesh_proto::RenderRequest) -> Result<(u64, f64), u16> {
        let body = serde_json::to_vec(request).map_err(|_| 0u16)?;
        match self.post_json(&format!("/v1/scenes/{scene}/render"), body).await {
            Ok((_, resp_headers, _, size)) => {
                let extract_ms = resp_headers
                    .get("server-timing")
                    .and_then(|v| v.to_str().ok())
                    .and_then(|v| v.split(',').find_map(|m| m.trim().strip_prefix("extract;dur=")))
                    .and_then(|ms| ms.parse().ok())
                    .ok_or(0u16)?;
                Ok((size as u64, extract_ms))
            }
            Err(e) => Err(e.downcast_ref::<CallError>().map_or(0, |c| c.status.as_u16())),
        }
    }

    /// A colour image by URL path, from the ETag cache when the server says it is current.
    pub async fn color(&self, path: &str) -> anyhow::Result<Vec<u8>> {
        let key = path.replace('/', "_");
        let cached = self.cache.as_ref().and_then(|dir| {
            let etag = std::fs::read_to_string(dir.join(format!("{key}.etag"))).ok()?;
            let bytes = std::fs::read(dir.join(format!("{key}.img"))).ok()?;
            Some((etag, bytes))
        });
        let headers: Vec<_> = cached
            .iter()
            .map(|(etag, _)| (header::IF_NONE_MATCH, etag.clone()))
            .collect();
        let (status, resp_headers, bytes) = self.call(Method::GET, path, &headers, Vec::new()).await?;
        if status == StatusCode::NOT_MODIFIED {
            if let Some((_, bytes)) = cached {
                return Ok(bytes);
            }
        }
        if let (Some(dir), Some(etag)) = (
            &self.cache,
            resp_headers.get(header::ETAG).and_then(|v| v.to_str().ok()),
        ) {
            std::fs::create_dir_all(dir)?;
            std::fs::write(dir.join(format!("{key}.img")), &bytes)?;
            std::fs::write(dir.join(format!("{key}.etag")), etag)?;
        }
        Ok(bytes.to_vec())
    }
}
