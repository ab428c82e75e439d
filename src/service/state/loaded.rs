//! A view ready to serve: its hierarchy, the colour image, and the strong
//! ETag that names its content and store version.

use std::hash::{Hash, Hasher};

use crate::store::{dmv, StoredView, Version, ViewParts};
use dmesh_engine::camera::Camera;
use dmesh_engine::image::{sniff, DepthImage, Format};
use dmesh_engine::mesh::Hierarchy;

use super::super::error::AppError;

/// A view ready to serve: its hierarchy and what responses need.
#[derive(Debug)]
pub struct Loaded {
    /// The hierarchy.
    pub hierarchy: Hierarchy,
    /// The reference camera.
    pub camera: Camera,
    /// The colour image as uploaded, shared with the stored view.
    pub color: bytes::Bytes,
    /// The colour's media type, from its magic bytes (`image/png` or
    /// `image/jpeg` for anything uploaded).
    pub color_type: &'static str,
    /// The store's version of the view this was built from.
    pub version: Version,
    /// Strong validator of the stored view (depth, camera, segmentation,
    /// colour) and its version.
    pub etag: String,
    /// Hash of the stored content.
    pub(super) content: u64,
    /// Valid depth samples.
    pub valid_samples: u64,
    /// The integer grid of the uploaded depth, for lossless residual coding.
    pub raw_grid: Option<dmesh_proto::RawGrid>,
    /// When this frame became visible, for a live frame (`PUT ...?live=true`)
    /// this process received; `None` otherwise.
    pub live_since: Option<std::time::SystemTime>,
}

impl Loaded {
    /// Milliseconds since this live frame became visible (`None`: not a
    /// live frame of this process).
    pub fn live_age_ms(&self) -> Option<f64> {
        let since = self.live_since?;
        Some(since.elapsed().map_or(0.0, |d| d.as_secs_f64() * 1e3))
    }
}

impl Loaded {
    /// Bytes this entry keeps in memory, at most: its size must not change
    /// while it is cached (the hierarchy computes its outlines on first
    /// use), so the hierarchy's bound is charged.
    pub fn bytes(&self) -> usize {
        self.hierarchy.heap_bytes_bound() + self.color.len()
    }

    /// Builds from a stored view at `version` (a store read, or a frame
    /// kept for replay).
    pub fn from_stored(v: &StoredView, version: Version) -> Result<Self, AppError> {
        let camera = Camera::try_from(&v.camera)?;
        let depth = DepthImage::from_z(camera.width, camera.height, v.z.clone())?;
        let hierarchy = Hierarchy::build(&depth, &camera, &v.segmentation.to_engine())?;
        Ok(Self::from_built(hierarchy, camera, v, content_of(v.parts()), version))
    }

    /// The view `v` (what the store keeps of it: hashed for the ETag, its
    /// colour shared, not copied) with its `hierarchy`, built for `camera`,
    /// at `version`; `content` is [`content_of`] `v`.
    pub fn from_built(hierarchy: Hierarchy, camera: Camera, v: &StoredView, content: u64, version: Version) -> Self {
        // Uploads are checked to be PNG or JPEG by their magic bytes; what a
        // store holds is named by its own, never assumed.
        let color_type = sniff(&v.color).map_or("application/octet-stream", Format::media_type);
        Self {
            version: Version::new(),
            content,
            valid_samples: hierarchy.stats().valid_samples as u64,
            raw_grid: v.raw_grid,
            live_since: None,
            hierarchy,
            camera,
            color: v.color.clone(),
            color_type,
            etag: String::new(),
        }
        .at_version(version)
    }

    /// The same view as stored at `version`: its ETag names both the
    /// content and the version.
    pub fn at_version(mut self, version: Version) -> Self {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        version.hash(&mut h);
        self.etag = format!("\"{:016x}.{:08x}\"", self.content, h.finish() as u32);
        self.version = version;
        self
    }
}

/// The hash of a view's content, its ETag's first part: the same for the
/// same camera, segmentation, depths and colour, in every process.
pub fn content_of(v: ViewParts<'_>) -> u64 {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    // The depths as the store lays them out (one update per block: with
    // SipHash, per sample, hashing took 4.6 ms of a 1920 x 1080 frame).
    let Ok(()) = dmv::depth_bytes(v.z, |block| {
        h.update(block);
        Ok::<(), std::convert::Infallible>(())
    });
    v.color.hash(&mut h);
    serde_json::to_string(v.camera).unwrap_or_default().hash(&mut h);
    serde_json::to_string(&v.segmentation).unwrap_or_default().hash(&mut h);
    serde_json::to_string(&v.raw_grid).unwrap_or_default().hash(&mut h);
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use dmesh_engine::mesh::SegmentationSpec;

    fn stored(color: &[u8]) -> StoredView {
        StoredView {
            camera: dmesh_proto::Camera {
                width: 2,
                height: 2,
                projection: dmesh_proto::Projection::Perspective {
                    fx: 2.0,
                    fy: 2.0,
                    cx: 0.5,
                    cy: 0.5,
                },
                pose: dmesh_proto::Pose::default(),
            },
            segmentation: SegmentationSpec::default(),
            z: vec![1.0, 1.0, 1.0, 1.0],
            raw_grid: None,
            color: color.to_vec().into(),
        }
    }

    #[test]
    fn the_colour_is_named_by_its_own_bytes_never_assumed() {
        let cases: [(&[u8], &str); 4] = [
            (b"\x89PNG\r\n\x1a\nrest", "image/png"),
            (&[0xff, 0xd8, 0xff, 0xe0], "image/jpeg"),
            (b"GIF89a", "application/octet-stream"),
            (b"", "application/octet-stream"),
        ];
        for (bytes, want) in cases {
            let loaded = Loaded::from_stored(&stored(bytes), "1".into()).unwrap();
            assert_eq!(loaded.color_type, want, "{bytes:?}");
        }
    }
}
