//! Colour images (PNG or JPEG) decoded to 8-bit RGB.

use image::ImageFormat;

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
    let format = match sniff(bytes) {
        Some(Format::Png) => ImageFormat::Png,
        Some(Format::Jpeg) => ImageFormat::Jpeg,
        _ => {
            return Err(Error::decode(
                "colour image is not PNG or JPEG (unrecognised magic bytes)",
            ))
        }
    };
    let image = decode_with_limits(bytes, format, "colour image", limits)?;
    let rgb = image.to_rgb8();
    Ok(ColorImage {
        width: rgb.width(),
        height: rgb.height(),
        rgb: rgb.into_raw(),
    })
}
