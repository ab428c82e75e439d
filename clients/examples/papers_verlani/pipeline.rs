//! The pipeline every table of `papers_verlani` shares: the scene and its
//! selections, extraction at a detail, the compact stream zipped and
//! decoded, the blend, and PSNR over a common mask (Verlani et al.,
//! Sec. 5).

use std::io::Write;

use anyhow::Result;
use dmesh_client::blend::{blend, BlendOptions, Blended, Texture, ViewInput};
use dmesh_client::report::cases::Case;
use dmesh_engine::camera::Camera;
use dmesh_engine::mesh::{Hierarchy, Lod, Mesh, Outlines, StripOrder};
use dmesh_engine::scene::Weighted;
use dmesh_engine::wire_compact::{mesh_stream, strip_response};
use dmesh_proto::StripResponse;

/// `--quick`: a few settings of everything.
pub(crate) static QUICK: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

pub(crate) fn quick() -> bool {
    QUICK.load(std::sync::atomic::Ordering::Relaxed)
}

/// `full` normally, `short` when quick.
pub(crate) fn pick<T: Clone>(full: &[T], short: &[T]) -> Vec<T> {
    if quick() { short } else { full }.to_vec()
}

/// Deflated size (zlib, level 6), as a zip file holds it.
pub(crate) fn zipped(bytes: &[u8]) -> usize {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    let _ = e.write_all(bytes);
    e.finish().map_or(usize::MAX, |v| v.len())
}

/// A depth map as `bits`-bit samples over its range (0: invalid), and the
/// range.
pub(crate) fn quantise(z: &[f32], bits: u32) -> (Vec<u16>, f32, f32) {
    let valid = z.iter().copied().filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = valid.fold((f32::INFINITY, 0f32), |(a, b), v| (a.min(v), b.max(v)));
    let top = f64::from((1u32 << bits) - 2);
    let span = f64::from((hi - lo).max(f32::MIN_POSITIVE));
    let q = z
        .iter()
        .map(|&v| {
            if v.is_finite() && v > 0.0 {
                1 + (f64::from(v - lo) / span * top).round() as u16
            } else {
                0
            }
        })
        .collect();
    (q, lo, hi)
}

/// Zipped bytes of a depth map quantised to `bits` (8 or 16) bits.
pub(crate) fn zipped_depth(z: &[f32], bits: u32) -> usize {
    let (q, _, _) = quantise(z, bits);
    let bytes: Vec<u8> = if bits <= 8 {
        q.iter().map(|&v| v as u8).collect()
    } else {
        q.iter().flat_map(|v| v.to_le_bytes()).collect()
    };
    zipped(&bytes)
}

/// The scene, its hierarchies and each novel view's selection.
pub(crate) struct Scene {
    pub(crate) case: Case,
    pub(crate) hierarchies: Vec<Hierarchy>,
    pub(crate) selections: Vec<Vec<Weighted>>,
}

impl Scene {
    pub(crate) fn new(case: Case, max_views: Option<u32>) -> Result<Self> {
        let hierarchies = case
            .references
            .iter()
            .map(|r| Hierarchy::build(&r.depth, &r.camera, &Default::default()))
            .collect::<Result<Vec<_>, _>>()?;
        let selections = case.selections(max_views)?;
        Ok(Self {
            case,
            hierarchies,
            selections,
        })
    }
}

/// How a reference's mesh is extracted for a novel view.
#[derive(Clone, Copy)]
pub(crate) enum Detail {
    /// Lossless: epsilon 0.
    Exact,
    /// View-dependent at tau pixels.
    Tau(f64),
}

pub(crate) fn extract(h: &Hierarchy, detail: Detail, novel: &Camera, outlines: Outlines) -> Result<Mesh> {
    let lod = match detail {
        Detail::Exact => Lod::Epsilon(0.0),
        Detail::Tau(tau) => Lod::Tau { tau, view: novel },
    };
    Ok(h.extract_as(lod, StripOrder::Traversal, outlines)?)
}

/// One novel view through the compact stream: the zipped bytes of its
/// selected views' streams and what the client decodes from them.
pub(crate) fn streamed(
    h: &Hierarchy,
    camera: &Camera,
    mesh: &Mesh,
    planes: Option<u8>,
    novel: &Camera,
) -> Result<(Vec<u8>, StripResponse)> {
    let s = mesh_stream(mesh, h.grid(), "demo", "v", camera, None, planes, String::new())?;
    let body = dmesh_proto::to_bincode(&s)?;
    Ok((body, strip_response(&s, Some(novel))?))
}

/// A blend without gap filling, optionally with an angular weight.
pub(crate) fn blended(
    novel: &Camera,
    views: &[(f64, StripResponse, &Texture)],
    options: BlendOptions,
) -> Result<Blended> {
    let inputs = ViewInput::of_responses(views);
    blend(
        novel,
        &inputs,
        &BlendOptions {
            fill_gaps: 0,
            ..options
        },
    )
}

/// Every novel view of `scene` through the stream at `detail` and
/// `planes`, outlines refined (Verlani's tables were measured so): the
/// blends and the zipped bytes per novel view.
pub(crate) fn through_stream(
    scene: &Scene,
    detail: Detail,
    planes: Option<u8>,
    options: BlendOptions,
) -> Result<(Vec<Blended>, f64)> {
    through_stream_as(scene, (detail, Outlines::Kept), planes, options)
}

/// [`through_stream`] with the outlines given.
pub(crate) fn through_stream_as(
    scene: &Scene,
    (detail, outlines): (Detail, Outlines),
    planes: Option<u8>,
    options: BlendOptions,
) -> Result<(Vec<Blended>, f64)> {
    let (mut out, mut bytes) = (Vec::new(), 0usize);
    for (novel, selected) in scene.case.novels.iter().zip(&scene.selections) {
        let (mut body, mut views) = (Vec::new(), Vec::new());
        for w in selected {
            let (h, r) = (&scene.hierarchies[w.index], &scene.case.references[w.index]);
            let mesh = extract(h, detail, &novel.camera, outlines)?;
            let (b, strips) = streamed(h, &r.camera, &mesh, planes, &novel.camera)?;
            body.extend_from_slice(&b);
            views.push((w.weight, strips, &r.texture));
        }
        bytes += zipped(&body);
        out.push(blended(&novel.camera, &views, options)?);
    }
    Ok((out, bytes as f64 / scene.case.novels.len() as f64))
}

/// PSNR (dB) of each row over the pixels every row covers and the truth
/// holds (the common mask), and each row's coverage of the image.
pub(crate) fn scores(case: &Case, rows: &[Vec<Blended>]) -> Vec<(f64, f64)> {
    let mut se = vec![(0f64, 0usize); rows.len()];
    let mut cover = vec![0f64; rows.len()];
    for (k, novel) in case.novels.iter().enumerate() {
        let n = novel.depth.len();
        for i in 0..n {
            let truth = novel.depth[i] > 0.0;
            let common = truth && rows.iter().all(|r| r[k].depth[i] > 0.0);
            for (j, r) in rows.iter().enumerate() {
                if r[k].depth[i] > 0.0 {
                    cover[j] += 1.0 / n as f64;
                }
                if common {
                    let e: f64 = (0..3)
                        .map(|c| (f64::from(r[k].rgb[3 * i + c]) - f64::from(novel.rgb[3 * i + c])).powi(2))
                        .sum::<f64>()
                        / 3.0;
                    se[j] = (se[j].0 + e, se[j].1 + 1);
                }
            }
        }
    }
    let novels = case.novels.len().max(1) as f64;
    se.iter()
        .zip(&cover)
        .map(|(&(e, count), c)| {
            let mse = e / count.max(1) as f64;
            (10.0 * (255.0f64 * 255.0 / mse.max(1e-12)).log10(), 100.0 * c / novels)
        })
        .collect()
}
