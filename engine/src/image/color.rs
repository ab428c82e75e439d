//! Colour images (PNG or JPEG) decoded to 8-bit RGB.

use std::io::Cursor;

use image::{ImageFormat, ImageReader};

use super::{png_depth::decode_with_limits, sniff, Format, Limits};
use crate::error::{Error, Result};

/// Row-major 8-bit RGB pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct ColorImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `3 * width * height` bytes, R, G, B per pixel.
    pub rgb: Vec<u8>,
}

/// Decodes a PNG or JPEG colour image, recognised by its magic bytes.
pub fn decode_color(bytes: &[u8], limits: &Limits) -> Result<ColorImage> {
    let image = decode_with_limits(bytes, color_format(bytes)?, "colour image", limits)?;
    let rgb = image.to_rgb8();
    Ok(ColorImage {
        width: rgb.width(),
        height: rgb.height(),
        rgb: rgb.into_raw(),
    })
}

/// A colour image's size from its header, within `limits`, without
/// decoding its pixels.
pub fn color_dimensions(bytes: &[u8], limits: &Limits) -> Result<(u32, u32)> {
    let reader = ImageReader::with_format(Cursor::new(bytes), color_format(bytes)?);
    let (w, h) = reader
        .into_dimensions()
        .map_err(|e| Error::decode(format!("colour image: {e}")))?;
    limits.check("colour image", u64::from(w), u64::from(h))?;
    Ok((w, h))
}

/// PNG or JPEG, by the magic bytes.
fn color_format(bytes: &[u8]) -> Result<ImageFormat> {
    match sniff(bytes) {
        Some(Format::Png) => Ok(ImageFormat::Png),
        Some(Format::Jpeg) => Ok(ImageFormat::Jpeg),
        _ => Err(Error::decode(
            "colour image is not PNG or JPEG (unrecognised magic bytes)",
        )),
    }
}
