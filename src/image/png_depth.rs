//! 8- and 16-bit greyscale PNG depth maps (Middlebury disparities are 8-bit PNG).

use std::io::Cursor;

use image::{DynamicImage, ImageFormat, ImageReader};

use super::{Limits, RawSamples};
use crate::error::{Error, Result};

/// Opens `bytes` as `format` with both our pixel limit and the decoder's
/// allocation limit in force, after checking the declared size.
pub(crate) fn decode_with_limits(
    bytes: &[u8],
    format: ImageFormat,
    what: &str,
    limits: &Limits,
) -> Result<DynamicImage> {
    let reader = ImageReader::with_format(Cursor::new(bytes), format);
    let (w, h) = reader
        .into_dimensions()
        .map_err(|e| Error::decode(format!("{what}: {e}")))?;
    limits.check(what, u64::from(w), u64::from(h))?;
    let mut reader = ImageReader::with_format(Cursor::new(bytes), format);
    let mut image_limits = image::Limits::default();
    // Four bytes per channel of RGBA 16-bit is the most any decoder here needs.
    image_limits.max_alloc = Some(limits.max_pixels.saturating_mul(8).max(1 << 20));
    reader.limits(image_limits);
    reader.decode().map_err(|e| Error::decode(format!("{what}: {e}")))
}

pub(crate) fn decode(bytes: &[u8], limits: &Limits) -> Result<RawSamples> {
    let image = decode_with_limits(bytes, ImageFormat::Png, "depth PNG", limits)?;
    let (width, height) = (image.width(), image.height());
    let values: Vec<f32> = match image {
        DynamicImage::ImageLuma8(img) => img.into_raw().into_iter().map(f32::from).collect(),
        DynamicImage::ImageLuma16(img) => img.into_raw().into_iter().map(f32::from).collect(),
        DynamicImage::ImageLumaA8(img) => img.into_raw().chunks_exact(2).map(|p| f32::from(p[0])).collect(),
        DynamicImage::ImageLumaA16(img) => img.into_raw().chunks_exact(2).map(|p| f32::from(p[0])).collect(),
        other => {
            return Err(Error::decode(format!(
                "depth PNG has colour type {:?}; it must be 8- or 16-bit greyscale",
                other.color()
            )))
        }
    };
    Ok(RawSamples { width, height, values })
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{ImageBuffer, Luma};

    fn png16(w: u32, h: u32) -> Vec<u8> {
        let img: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_fn(w, h, |x, y| Luma([(x * 1000 + y) as u16]));
        let mut out = Vec::new();
        DynamicImage::ImageLuma16(img)
            .write_to(&mut Cursor::new(&mut out), ImageFormat::Png)
            .unwrap();
        out
    }

    #[test]
    fn sixteen_bit_values_survive() {
        let raw = decode(&png16(3, 2), &Limits::default()).unwrap();
        assert_eq!(raw.values, vec![0.0, 1000.0, 2000.0, 1.0, 1001.0, 2001.0]);
    }

    #[test]
    fn truncated_png_is_an_error() {
        let bytes = png16(16, 16);
        // Cuts inside the header and the pixel data (a missing IEND alone is harmless).
        for cut in [8, 20, 33, bytes.len() / 2, bytes.len() - 20] {
            assert!(decode(&bytes[..cut], &Limits::default()).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn over_the_pixel_limit_is_refused_before_decoding() {
        let e = decode(&png16(64, 64), &Limits { max_pixels: 100 }).unwrap_err();
        assert!(matches!(e, Error::TooLarge(_)), "{e}");
    }
}
