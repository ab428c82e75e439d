//! `dmesh serve`: the HTTP service over the embedded store or an object store.

use std::path::PathBuf;

use anyhow::{Context, Result};
use dmesh_engine::image::Limits;

#[derive(clap::Args)]
pub struct ServeArgs {
    /// Address to listen on.
    #[arg(long, default_value_t = std::net::SocketAddr::from(([127, 0, 0, 1], dmesh::http::DEFAULT_PORT)))]
    listen: std::net::SocketAddr,
    /// Data directory of the embedded store.
    #[arg(long, default_value = dmesh::http::DEFAULT_DATA_DIR, conflicts_with = "store")]
    data: PathBuf,
    /// Keep views in an S3-compatible object store instead, `s3://BUCKET/PREFIX`,
    /// so that replicas can share them. Endpoint, region and credentials come
    /// from AWS_ENDPOINT_URL, AWS_REGION, AWS_ACCESS_KEY_ID and
    /// AWS_SECRET_ACCESS_KEY; AWS_ALLOW_HTTP=true for a plain-HTTP endpoint.
    #[arg(long, value_name = "URL")]
    store: Option<String>,
    /// With --store: the longest a cached view or scene listing is served
    /// without checking its scene's version in the store, which happens in
    /// the background for scenes in use: how long another replica's replace
    /// may go unseen. 0 checks on every request.
    #[arg(long, default_value_t = dmesh::http::DEFAULT_REVALIDATE.as_millis() as u64)]
    revalidate_ms: u64,
    /// With --store: this replica's id, under which it notes the views it
    /// holds; restarted with the same id, it builds them before /healthz
    /// answers 200 [default: HOSTNAME-PORT]. `none`: no note.
    #[arg(long, value_name = "ID")]
    replica_id: Option<String>,
    /// The longest a live view's latest frame (`PUT ...?live=true`) waits
    /// before it is made durable; a live frame is visible at once, and a
    /// crash of the machine (not of the process) may lose this much.
    #[arg(long, default_value_t = 2.0)]
    live_persist_secs: f64,
    /// Bytes of built hierarchies kept in memory.
    #[arg(long, default_value_t = 1 << 30)]
    cache_bytes: usize,
    /// Largest request body, bytes.
    #[arg(long, default_value_t = 256 << 20)]
    max_upload_bytes: usize,
    /// Largest decoded image, pixels.
    #[arg(long, default_value_t = 64 << 20)]
    max_pixels: u64,
    /// Reads (renders, strips, summaries) served at once; more wait up to
    /// --queue-wait-ms for a slot, then are answered 503 with Retry-After
    /// [default: the number of cores].
    #[arg(long)]
    max_concurrency: Option<usize>,
    /// Uploads served at once, apart from reads [default: half the cores, at least 1].
    #[arg(long)]
    max_uploads: Option<usize>,
    /// Milliseconds a request may wait for a free slot before it is shed.
    #[arg(long, default_value_t = 5)]
    queue_wait_ms: u64,
    /// Request timeout, seconds.
    #[arg(long, default_value_t = 30)]
    timeout_secs: u64,
    /// Ingest the simulated demo scene (scene id `demo`) when it is not
    /// stored yet, and feed the moving scene `demo-live` (one live view).
    #[arg(long)]
    demo: bool,
    /// With --demo: frames per second of `demo-live` (0: no live scene).
    #[arg(long, default_value_t = 10.0, requires = "demo")]
    demo_live_fps: f64,
}

/// Stores the simulated demo scene's reference views as scene `demo`, unless present.
fn ingest_demo(store: &dyn dmesh::store::ViewStore) -> Result<()> {
    use dmesh::store::StoredView;
    use dmesh_engine::mesh::SegmentationSpec;
    let scene = dmesh_engine::sim::SceneSpec::demo();
    let existing = store.views("demo")?.unwrap_or_default();
    let views = scene.reference_views()?;
    for (k, v) in views.iter().enumerate() {
        let name = format!("v{k:02}");
        if existing.contains(&name) {
            continue;
        }
        let img =
            image::RgbImage::from_raw(v.color.width, v.color.height, v.color.rgb.clone()).context("demo colour")?;
        let mut color = Vec::new();
        image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut color), image::ImageFormat::Png)?;
        let stored = StoredView {
            camera: (&v.camera).into(),
            segmentation: SegmentationSpec::default(),
            z: v.depth.z.clone(),
            raw_grid: None,
            color: color.into(),
        };
        store.put("demo", &name, &stored)?;
    }
    tracing::info!("demo scene: {} simulated views in scene \"demo\"", views.len());
    tracing::info!(
        "render a novel view: cargo run --release -p dmesh-client -- render --scene demo \
         --camera examples/cameras/demo-novel.json --out novel.png --coverage-out coverage.png"
    );
    Ok(())
}

/// The replica id: `--replica-id`, or this host's name and the port.
fn replica_id(a: &ServeArgs) -> Option<Result<String>> {
    let id = match a.replica_id.as_deref() {
        Some("none") => return None,
        Some(id) => id.to_string(),
        None => {
            let host = std::env::var("HOSTNAME")
                .ok()
                .or_else(|| std::fs::read_to_string("/etc/hostname").ok())
                .map(|h| h.trim().to_string())
                .filter(|h| !h.is_empty())
                .unwrap_or_else(|| "replica".into());
            let host: String = host
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '.' || c == '-' {
                        c
                    } else {
                        '_'
                    }
                })
                .take(56)
                .collect();
            format!("{host}-{}", a.listen.port())
        }
    };
    Some(
        dmesh::store::validate_id("replica", &id)
            .map(|()| id)
            .context("--replica-id"),
    )
}

pub fn run(a: &ServeArgs) -> Result<()> {
    use dmesh::http::{serve, AppState, Pipeline, Settings};
    use dmesh::store::{FileStore, ObjectViewStore, ViewStore};
    // The port is bound before the store is opened: a server started on a
    // port in use (a second one over the same data directory, say) stops
    // here, before its demo scene or live feed writes anything.
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    let listener = runtime
        .block_on(tokio::net::TcpListener::bind(a.listen))
        .with_context(|| format!("listening on {}", a.listen))?;
    let store: std::sync::Arc<dyn ViewStore> = match &a.store {
        Some(url) => {
            std::sync::Arc::new(ObjectViewStore::from_url(url).with_context(|| format!("object store {url}"))?)
        }
        None => std::sync::Arc::new(
            FileStore::open(&a.data).with_context(|| format!("data directory {}", a.data.display()))?,
        ),
    };
    let settings = Settings {
        max_upload_bytes: a.max_upload_bytes,
        limits: Limits {
            max_pixels: a.max_pixels,
        },
        cache_bytes: a.cache_bytes,
        revalidate: std::time::Duration::from_millis(a.revalidate_ms),
        live_persist: std::time::Duration::try_from_secs_f64(a.live_persist_secs)
            .ok()
            .filter(|d| d.as_secs() <= 3600)
            .context("--live-persist-secs must be 0 to 3600 seconds")?,
        replica: a.store.as_ref().and_then(|_| replica_id(a)).transpose()?,
    };
    if a.demo {
        ingest_demo(store.as_ref())?;
    }
    let state = std::sync::Arc::new(AppState::new(store, settings));
    if a.demo && a.demo_live_fps != 0.0 {
        if !(a.demo_live_fps.is_finite() && (0.1..=60.0).contains(&a.demo_live_fps)) {
            anyhow::bail!("--demo-live-fps must be 0 (off) or 0.1 to 60");
        }
        super::demo_live::start(state.clone(), a.demo_live_fps).context("the demo-live scene")?;
    }
    let defaults = Pipeline::default();
    let pipeline = Pipeline {
        max_concurrency: a.max_concurrency.unwrap_or(defaults.max_concurrency),
        max_uploads: a.max_uploads.unwrap_or(defaults.max_uploads),
        queue_wait: std::time::Duration::from_millis(a.queue_wait_ms),
        timeout: std::time::Duration::from_secs(a.timeout_secs),
    };
    runtime
        .block_on(serve(listener, state, pipeline))
        .with_context(|| format!("serving on {}", a.listen))
}
