//! Decoding depth and colour images, and turning depth samples into `z`.
//!
//! Formats are recognised by their magic bytes, never by a file name. Every
//! decoder reads the header first and refuses an image whose declared size is
//! over [`Limits::max_pixels`] before it allocates for the pixels; truncated or
//! malformed input is an [`Error::Decode`], never a panic.
//!
//! Depth samples that are zero, negative, NaN or infinite (after conversion)
//! are *invalid*: they are kept as `0.0` in [`DepthImage::z`] and the mesher
//! segments every triangle that touches them.

mod color;
mod exr_depth;
mod pfm;
pub mod pgm;
mod png_depth;
mod view;

pub use color::{color_dimensions, decode_color, ColorImage};
pub use exr_depth::encode_exr;
pub use pfm::{decode_pfm, encode_pfm};
pub use view::{check_color_header, decode_view, DecodedView, ViewFiles};

use crate::camera::Camera;
use crate::error::{Error, Result};

/// Upper bounds checked before any pixel buffer is allocated.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Largest accepted `width * height`.
    pub max_pixels: u64,
}

impl Default for Limits {
    /// 64 Mpx, the server's default.
    fn default() -> Self {
        Self { max_pixels: 64 << 20 }
    }
}

impl Limits {
    /// Refuses `width x height` when it is empty or over the limit.
    pub fn check(&self, what: &str, width: u64, height: u64) -> Result<()> {
        if width == 0 || height == 0 {
            return Err(Error::decode(format!(
                "{what} is {width}x{height}; width and height must be at least 1"
            )));
        }
        let pixels = width.saturating_mul(height);
        if pixels > self.max_pixels {
            return Err(Error::TooLarge(format!(
                "{what} declares {width}x{height} = {pixels} pixels; the limit is {} pixels",
                self.max_pixels
            )));
        }
        Ok(())
    }
}

/// What the samples of a depth image measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DepthKind {
    /// Metres along the optical axis.
    #[default]
    Z,
    /// Distance from the camera centre along the pixel's ray.
    Range,
    /// Disparity in pixels; `z = focal * baseline / disparity`.
    Disparity,
    /// `1 / z`.
    InverseDepth,
}

impl DepthKind {
    /// Its names, as the upload form and `dmesh mesh --depth-kind` take
    /// them (`inverse` is short for `inverse_depth`).
    pub const NAMES: [(&'static str, Self); 5] = [
        ("z", Self::Z),
        ("range", Self::Range),
        ("disparity", Self::Disparity),
        ("inverse_depth", Self::InverseDepth),
        ("inverse", Self::InverseDepth),
    ];
}

impl std::str::FromStr for DepthKind {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        crate::by_name(&Self::NAMES, s).ok_or_else(|| {
            Error::invalid(format!(
                "depth kind {s:?} is unknown; use z, range, disparity or inverse_depth"
            ))
        })
    }
}

/// How raw samples become depth: `value = raw * scale + offset`, then `kind`.
#[derive(Clone, Debug)]
pub struct DepthOptions {
    /// What the samples measure.
    pub kind: DepthKind,
    /// Multiplies every raw sample (PNG samples are raw integers).
    pub scale: f64,
    /// Added after scaling (Middlebury 2005/2006 disparities need `dmin`).
    pub offset: f64,
    /// `focal * baseline` for disparity, in pixels times metres.
    pub focal_baseline: Option<f64>,
    /// Name of the EXR channel to read; the first float channel when `None`.
    pub channel: Option<String>,
}

impl Default for DepthOptions {
    fn default() -> Self {
        Self {
            kind: DepthKind::Z,
            scale: 1.0,
            offset: 0.0,
            focal_baseline: None,
            channel: None,
        }
    }
}

/// A depth map converted to `z`, invalid samples as `0.0`.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    /// Width in samples.
    pub width: u32,
    /// Height in samples.
    pub height: u32,
    /// Row-major `z` in metres; `0.0` marks an invalid sample.
    pub z: Vec<f32>,
}

impl DepthImage {
    /// Wraps row-major depths, mapping every non-finite or non-positive value to
    /// invalid (`0.0`). Width and height must be at least 2.
    pub fn from_z(width: u32, height: u32, mut z: Vec<f32>) -> Result<Self> {
        for v in &mut z {
            if !(v.is_finite() && *v > 0.0) {
                *v = 0.0;
            }
        }
        Self::from_valid_z(width, height, z)
    }

    /// [`Self::from_z`] of depths already finite and positive or `0.0`
    /// (as [`to_z_with`] leaves them): the sizes checked, the samples not
    /// read again (a tenth of a 1920 x 1080 frame's decode).
    fn from_valid_z(width: u32, height: u32, z: Vec<f32>) -> Result<Self> {
        debug_assert!(z.iter().all(|v| v.is_finite() && *v >= 0.0));
        if width < 2 || height < 2 {
            return Err(Error::invalid(format!(
                "depth image is {width}x{height}; width and height must be at least 2"
            )));
        }
        if z.len() as u64 != u64::from(width) * u64::from(height) {
            return Err(Error::invalid(format!(
                "depth image is {width}x{height} but has {} samples",
                z.len()
            )));
        }
        if width > u32::from(u16::MAX) || height > u32::from(u16::MAX) {
            return Err(Error::TooLarge(format!(
                "depth image is {width}x{height}; each side must be at most 65535"
            )));
        }
        Ok(Self { width, height, z })
    }

    /// Marks samples invalid where `mask` is false. The mask must have the same size.
    pub fn apply_mask(&mut self, mask: &[bool]) -> Result<()> {
        if mask.len() != self.z.len() {
            return Err(Error::invalid(format!(
                "mask has {} samples but the depth image has {}",
                mask.len(),
                self.z.len()
            )));
        }
        for (z, &keep) in self.z.iter_mut().zip(mask) {
            if !keep {
                *z = 0.0;
            }
        }
        Ok(())
    }

    /// Number of valid samples.
    pub fn valid_count(&self) -> usize {
        self.z.iter().filter(|&&z| z > 0.0).count()
    }
}

/// Decodes a validity mask: a PNG (8- or 16-bit greyscale) of the depth
/// image's size whose non-zero samples mark valid depth.
pub fn decode_mask(bytes: &[u8], width: u32, height: u32, limits: &Limits) -> Result<Vec<bool>> {
    if sniff(bytes) != Some(Format::Png) {
        return Err(Error::decode("mask is not a PNG (unrecognised magic bytes)"));
    }
    let raw =
        png_depth::decode(bytes, limits).map_err(|e| Error::decode(e.to_string().replace("depth PNG", "mask PNG")))?;
    if (raw.width, raw.height) != (width, height) {
        return Err(Error::invalid(format!(
            "mask is {}x{} but the depth image is {width}x{height}; they must match",
            raw.width, raw.height
        )));
    }
    Ok(raw.values.iter().map(|&v| v != 0.0).collect())
}

/// Raw samples as decoded, before conversion to `z`.
#[derive(Debug)]
pub(crate) struct RawSamples {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
}

/// Image containers recognised by their first bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// `\x89PNG`.
    Png,
    /// OpenEXR, `76 2f 31 01`.
    Exr,
    /// Portable float map, `Pf` (grey) or `PF` (colour).
    Pfm,
    /// Binary greyscale portable graymap, `P5`.
    Pgm,
    /// JPEG, `ff d8 ff`.
    Jpeg,
}

impl Format {
    /// Its media type, for a `Content-Type` header.
    pub fn media_type(self) -> &'static str {
        match self {
            Self::Png => "image/png",
            Self::Exr => "image/x-exr",
            Self::Pfm => "image/x-portable-floatmap",
            Self::Pgm => "image/x-portable-graymap",
            Self::Jpeg => "image/jpeg",
        }
    }
}

/// Recognises the container from its magic bytes.
pub fn sniff(bytes: &[u8]) -> Option<Format> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some(Format::Png)
    } else if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        Some(Format::Exr)
    } else if bytes.starts_with(b"Pf") || bytes.starts_with(b"PF") {
        Some(Format::Pfm)
    } else if bytes.starts_with(b"P5") {
        Some(Format::Pgm)
    } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
        Some(Format::Jpeg)
    } else {
        None
    }
}

/// Decodes a depth image (EXR, PNG 8/16-bit grey, PFM, PGM 8/16-bit) and converts it to `z`
/// for `camera`, whose size must match the image.
pub fn decode_depth(bytes: &[u8], options: &DepthOptions, camera: &Camera, limits: &Limits) -> Result<DepthImage> {
    let raw = match sniff(bytes) {
        Some(Format::Png) => png_depth::decode(bytes, limits)?,
        Some(Format::Exr) => exr_depth::decode(bytes, options.channel.as_deref(), limits)?,
        Some(Format::Pfm) => pfm::decode(bytes, limits)?,
        Some(Format::Pgm) => pgm::decode(bytes, limits)?,
        Some(Format::Jpeg) => {
            return Err(Error::decode(
                "depth image is a JPEG; use EXR, 8/16-bit greyscale PNG or PGM, or PFM",
            ))
        }
        None => {
            return Err(Error::decode(
                "depth image is not EXR, PNG, PFM or PGM (unrecognised magic bytes)",
            ))
        }
    };
    if raw.width != camera.width || raw.height != camera.height {
        return Err(Error::invalid(format!(
            "depth image is {}x{} but the camera is {}x{}; they must match",
            raw.width, raw.height, camera.width, camera.height
        )));
    }
    to_z(raw, options, camera)
}

fn to_z(raw: RawSamples, options: &DepthOptions, camera: &Camera) -> Result<DepthImage> {
    if !options.scale.is_finite() || options.scale == 0.0 {
        return Err(Error::invalid(format!(
            "depth scale is {}; it must be finite and non-zero",
            crate::error::Shown(options.scale)
        )));
    }
    if !options.offset.is_finite() {
        return Err(Error::invalid(format!(
            "depth offset is {}; it must be finite",
            crate::error::Shown(options.offset)
        )));
    }
    let fb = match (options.kind, options.focal_baseline) {
        (DepthKind::Disparity, Some(fb)) if fb.is_finite() && fb > 0.0 => fb,
        (DepthKind::Disparity, Some(fb)) => {
            return Err(Error::invalid(format!(
                "focal_baseline is {}; it must be a finite number greater than 0",
                crate::error::Shown(fb)
            )))
        }
        (DepthKind::Disparity, None) => {
            return Err(Error::invalid(
                "depth kind disparity needs focal_baseline (focal length in pixels times baseline)",
            ))
        }
        _ => 0.0,
    };
    let RawSamples {
        width,
        height,
        mut values,
    } = raw;
    let w = width as usize;
    let (scale, offset) = (options.scale, options.offset);
    // One straight loop per kind (the compiler widens them).
    match options.kind {
        DepthKind::Z => in_halves(&mut values, |_, half| z_affine(half, scale, offset)),
        DepthKind::Range => to_z_with(&mut values, |idx, raw| {
            let (u, vv) = ((idx % w) as f64, (idx / w) as f64);
            (raw * scale + offset) / camera.ray_length(u, vv)
        }),
        DepthKind::Disparity => to_z_with(&mut values, |_, raw| {
            let x = raw * scale + offset;
            if x > 0.0 {
                fb / x
            } else {
                0.0
            }
        }),
        DepthKind::InverseDepth => to_z_with(&mut values, |_, raw| {
            let x = raw * scale + offset;
            if x > 0.0 {
                1.0 / x
            } else {
                0.0
            }
        }),
    }
    DepthImage::from_valid_z(width, height, values)
}

/// Samples from which a conversion runs on two threads: a 1920 x 1080
/// live frame's decode took 4 ms on one.
const HALVES_FROM: usize = 1 << 20;

/// `f(offset, part)` over `values` cut in two parts, on two threads when
/// there are [`HALVES_FROM`] values or more and the machine has two cores
/// (every value the same as on one).
fn in_halves<T: Send>(values: &mut [T], f: impl Fn(usize, &mut [T]) + Sync) {
    let two = values.len() >= HALVES_FROM && std::thread::available_parallelism().is_ok_and(|n| n.get() >= 2);
    if !two {
        return f(0, values);
    }
    let mid = values.len() / 2;
    let (first, second) = values.split_at_mut(mid);
    std::thread::scope(|s| {
        let f = &f;
        s.spawn(move || f(mid, second));
        f(0, first);
    });
}

crate::simd::dispatch! {
    /// [`to_z_with`] of depths given as z (`raw * scale + offset`), the
    /// kind a depth camera sends, with AVX2 or AVX-512 where the CPU has
    /// them (the same bits: the f64 arithmetic is only widened).
    fn z_affine(values: &mut [f32], scale: f64, offset: f64) -> () = z_affine_body;
}

#[inline(always)]
fn z_affine_body(values: &mut [f32], scale: f64, offset: f64) {
    to_z_with(values, |_, raw| raw * scale + offset);
}

/// Each raw sample in place as `z(index, raw)`, as f32; a raw 0 or
/// non-finite value (Middlebury's "unknown"), and any `z` not finite and
/// positive, is 0 (invalid).
#[inline(always)]
fn to_z_with(values: &mut [f32], z: impl Fn(usize, f64) -> f64) {
    for (idx, v) in values.iter_mut().enumerate() {
        let raw = f64::from(*v);
        let z = if raw == 0.0 || !raw.is_finite() {
            0.0
        } else {
            z(idx, raw) as f32
        };
        *v = if z.is_finite() && z > 0.0 { z } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(values: Vec<f32>) -> RawSamples {
        RawSamples {
            width: 2,
            height: 2,
            values,
        }
    }

    #[test]
    fn disparity_converts_with_scale_and_offset_and_zero_stays_invalid() {
        let cam = Camera::perspective(2, 2, 100.0, 100.0, 0.5, 0.5).unwrap();
        let opts = DepthOptions {
            kind: DepthKind::Disparity,
            scale: 0.5,
            offset: 1.0,
            focal_baseline: Some(10.0),
            channel: None,
        };
        let d = to_z(raw(vec![0.0, 2.0, 8.0, f32::NAN]), &opts, &cam).unwrap();
        assert_eq!(d.z, vec![0.0, 5.0, 2.0, 0.0]);
    }

    #[test]
    fn range_is_shortened_off_axis() {
        let cam = Camera::perspective(2, 2, 1.0, 1.0, 0.0, 0.0).unwrap();
        let d = to_z(
            raw(vec![1.0; 4]),
            &DepthOptions {
                kind: DepthKind::Range,
                ..Default::default()
            },
            &cam,
        )
        .unwrap();
        assert_eq!(d.z[0], 1.0);
        assert!((f64::from(d.z[3]) - 1.0 / 3f64.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn disparity_without_focal_baseline_is_refused() {
        let cam = Camera::perspective(2, 2, 1.0, 1.0, 0.0, 0.0).unwrap();
        let e = to_z(
            raw(vec![1.0; 4]),
            &DepthOptions {
                kind: DepthKind::Disparity,
                ..Default::default()
            },
            &cam,
        )
        .unwrap_err();
        assert!(e.to_string().contains("focal_baseline"));
    }

    #[test]
    fn tiny_images_are_refused() {
        assert!(DepthImage::from_z(1, 5, vec![1.0; 5])
            .unwrap_err()
            .to_string()
            .contains("at least 2"));
    }
}
