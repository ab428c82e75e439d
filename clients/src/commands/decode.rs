//! `dmesh-client decode`: a compact body (protocol 7) as the protocol 5
//! JSON a tool reads: vertices with their derived normals and rho, exact
//! depths as decoded, the triangles as strips of one triangle each, and
//! beside them `cuts`, the cut triangles with their decoded depths.
//! A change is decoded against the whole mesh it was asked against
//! (`--held`). What the browser's decoder is checked against, and a way to
//! look inside a body.

use std::path::PathBuf;

use anyhow::{Context, Result};
use dmesh_engine::camera::{camera_from_json, Camera};
use dmesh_engine::wire_compact::{decoded_response, render_response, strip_response};
use dmesh_proto::{MeshBody, RenderStream, StripResponse};
use serde_json::Value;

/// Options of `decode`.
#[derive(clap::Args, Debug)]
pub struct DecodeArgs {
    /// The body: a strip route's (a mesh) or the render route's answer.
    #[arg(long)]
    pub body: PathBuf,
    /// The camera of the request (JSON): the novel camera of a render, or
    /// the requesting camera of a view-dependent strip request.
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// The body is a render answer.
    #[arg(long)]
    pub render: bool,
    /// For a change: the whole-mesh body of the mesh it was asked against.
    #[arg(long)]
    pub held: Option<PathBuf>,
}

/// Prints the decoded body as JSON.
pub fn run(args: DecodeArgs) -> Result<()> {
    let bytes = std::fs::read(&args.body).with_context(|| format!("reading {}", args.body.display()))?;
    let camera: Option<Camera> = args
        .camera
        .as_ref()
        .map(|p| -> Result<Camera> {
            let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            Ok(camera_from_json(&text)?)
        })
        .transpose()?;
    let json = if args.render {
        let stream: RenderStream = dmesh_proto::from_bincode(&bytes).context("a compact render body")?;
        let novel = camera.context("a render body needs --camera, the novel camera")?;
        let response = render_response(&stream, &novel)?;
        let mut value = serde_json::to_value(&response)?;
        if let Some(views) = value.get_mut("views").and_then(Value::as_array_mut) {
            for (v, r) in views.iter_mut().zip(&response.views) {
                v["strips"] = with_cuts(&r.strips)?;
            }
        }
        value.to_string()
    } else {
        let body: MeshBody = dmesh_proto::from_bincode(&bytes).context("a compact strip body")?;
        match body {
            MeshBody::Mesh(stream) => with_cuts(&strip_response(&stream, camera.as_ref())?)?.to_string(),
            MeshBody::Change(change) => {
                let path = args
                    .held
                    .context("a change needs --held, the body of the mesh it changes")?;
                let held = std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
                let MeshBody::Mesh(held) = dmesh_proto::from_bincode(&held).context("a compact strip body")? else {
                    anyhow::bail!("--held must be a whole mesh");
                };
                let decoded = change.apply(&held.decode()?)?;
                with_cuts(&decoded_response(&change.mesh, decoded, camera.as_ref())?)?.to_string()
            }
            MeshBody::Planes(_) => anyhow::bail!("the body holds planes for a held mesh, not a mesh"),
        }
    };
    // A closed pipe (`| head`) ends the output, not the program with a panic.
    use std::io::Write;
    let _ = writeln!(std::io::stdout().lock(), "{json}");
    Ok(())
}

/// A decoded mesh as JSON, its cut triangles (not part of protocol 5)
/// under `cuts`.
fn with_cuts(r: &StripResponse) -> Result<Value> {
    let mut value = serde_json::to_value(r)?;
    value["cuts"] = serde_json::to_value(&r.cuts)?;
    Ok(value)
}
