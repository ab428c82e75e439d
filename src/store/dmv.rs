//! The `.dmv` encoding of one stored view, shared by every store.
//!
//! The magic `DMV1`; a little-endian `u64` length and the JSON metadata
//! (`camera`, `segmentation`, `raw_grid`); a `u64` sample count and the
//! depths as little-endian `f32`; a `u64` length and the colour image bytes.
//! Decoding checks every length against the bytes present, so damaged or
//! truncated bytes are an error, never a panic.

use serde::{Deserialize, Serialize};

use super::{StoreError, StoredView, ViewParts};
use dmesh_engine::mesh::SegmentationSpec;

/// The first four bytes of every `.dmv`.
pub const MAGIC: &[u8; 4] = b"DMV1";
/// Metadata (camera, segmentation) is a few hundred bytes of JSON.
pub const MAX_META_BYTES: u64 = 1 << 20;
/// Bytes before the metadata: the magic and the metadata length.
pub const HEAD_BYTES: usize = 12;

/// A view's metadata: everything but the samples and the colour.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Meta {
    /// The reference camera, wire form.
    pub camera: dmesh_proto::Camera,
    /// Segmentation settings.
    pub segmentation: SegmentationSpec,
    /// Absent in files written before residual coding.
    #[serde(default)]
    pub raw_grid: Option<dmesh_proto::RawGrid>,
}

impl Meta {
    /// The metadata of `v`.
    pub fn of(v: ViewParts<'_>) -> Self {
        Self {
            camera: v.camera.clone(),
            segmentation: v.segmentation,
            raw_grid: v.raw_grid,
        }
    }
}

/// A bounds-checked cursor.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len())?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Some(s)
    }

    fn len(&mut self) -> Option<usize> {
        let b: [u8; 8] = self.take(8)?.try_into().ok()?;
        usize::try_from(u64::from_le_bytes(b)).ok()
    }
}

fn damaged(name: &str, why: &str) -> StoreError {
    StoreError::Damaged(name.to_string(), why.to_string())
}

/// Encodes a view.
pub fn encode(v: ViewParts<'_>) -> Result<Vec<u8>, StoreError> {
    let meta = meta_bytes(v)?;
    let mut out = Vec::with_capacity(HEAD_BYTES + 16 + meta.len() + v.z.len() * 4 + v.color.len());
    write_parts(v, &meta, &mut out)?;
    Ok(out)
}

/// Writes the encoding of a view to `out` as [`encode`] gives it, without
/// holding it whole: the depths go through a small buffer, so a file store
/// writes a 1920 x 1080 frame without first filling (and faulting in) 8 MB.
pub fn write(v: ViewParts<'_>, out: &mut impl std::io::Write) -> Result<(), StoreError> {
    write_parts(v, &meta_bytes(v)?, out)
}

fn meta_bytes(v: ViewParts<'_>) -> Result<Vec<u8>, StoreError> {
    serde_json::to_vec(&Meta::of(v)).map_err(|e| StoreError::Io(std::io::Error::other(e)))
}

fn write_parts(v: ViewParts<'_>, meta: &[u8], out: &mut impl std::io::Write) -> Result<(), StoreError> {
    out.write_all(MAGIC)?;
    out.write_all(&(meta.len() as u64).to_le_bytes())?;
    out.write_all(meta)?;
    out.write_all(&(v.z.len() as u64).to_le_bytes())?;
    depth_bytes(v.z, |block| out.write_all(block))?;
    out.write_all(&(v.color.len() as u64).to_le_bytes())?;
    out.write_all(v.color)?;
    Ok(())
}

/// `f` of the depths' bytes as the encoding lays them out (little-endian
/// `f32`), a block of a few thousand at a time: a straight copy per
/// block, and one call rather than one per sample.
pub fn depth_bytes<E>(z: &[f32], mut f: impl FnMut(&[u8]) -> Result<(), E>) -> Result<(), E> {
    let mut block = [0u8; 4 * 8192];
    for z in z.chunks(block.len() / 4) {
        for (bytes, z) in block.chunks_exact_mut(4).zip(z) {
            bytes.copy_from_slice(&z.to_le_bytes());
        }
        f(&block[..4 * z.len()])?;
    }
    Ok(())
}

/// The metadata length from the first [`HEAD_BYTES`] bytes, checked
/// against [`MAX_META_BYTES`]; `name` names the view in errors.
pub fn meta_len(name: &str, head: &[u8]) -> Result<usize, StoreError> {
    if head.len() < HEAD_BYTES {
        return Err(damaged(name, "truncated"));
    }
    if &head[..4] != MAGIC {
        return Err(damaged(name, "bad magic"));
    }
    let n = u64::from_le_bytes(head[4..HEAD_BYTES].try_into().map_err(|_| damaged(name, "truncated"))?);
    if n > MAX_META_BYTES {
        return Err(damaged(name, "metadata too long"));
    }
    Ok(n as usize)
}

/// Parses metadata bytes.
pub fn decode_meta(name: &str, bytes: &[u8]) -> Result<Meta, StoreError> {
    serde_json::from_slice(bytes).map_err(|e| damaged(name, &e.to_string()))
}

/// Decodes a whole view.
pub fn decode(name: &str, bytes: &[u8]) -> Result<StoredView, StoreError> {
    let truncated = || damaged(name, "truncated");
    let n = meta_len(name, bytes)?;
    let mut r = Reader { bytes, at: HEAD_BYTES };
    let meta = decode_meta(name, r.take(n).ok_or_else(truncated)?)?;
    let count = r.len().ok_or_else(truncated)?;
    let raw = count.checked_mul(4).and_then(|n| r.take(n)).ok_or_else(truncated)?;
    let z = raw
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let n = r.len().ok_or_else(truncated)?;
    let color = bytes::Bytes::copy_from_slice(r.take(n).ok_or_else(truncated)?);
    if r.at != bytes.len() {
        return Err(damaged(name, "trailing bytes"));
    }
    Ok(StoredView {
        camera: meta.camera,
        segmentation: meta.segmentation,
        raw_grid: meta.raw_grid,
        z,
        color,
    })
}
