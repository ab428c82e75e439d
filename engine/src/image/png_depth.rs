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

    /// A PNG whose header declares `w x h` and which holds no pixel data.
    fn header_only(w: u32, h: u32) -> Vec<u8> {
        fn crc32(bytes: &[u8]) -> u32 {
            let mut crc = !0u32;
            for &b in bytes {
                crc ^= u32::from(b);
                for _ in 0..8 {
                    crc = if crc & 1 != 0 {
                        (crc >> 1) ^ 0xedb8_8320
                    } else {
                        crc >> 1
                    };
                }
            }
            !crc
        }
        let mut ihdr = b"IHDR".to_vec();
        ihdr.extend_from_slice(&w.to_be_bytes());
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[16, 0, 0, 0, 0]);
        let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
        out.extend_from_slice(&13u32.to_be_bytes());
        out.extend_from_slice(&ihdr);
        out.extend_from_slice(&crc32(&ihdr).to_be_bytes());
        // An empty IDAT: the header is complete, the pixels are missing.
        out.extend_from_slice(&0u32.to_be_bytes());
        out.extend_from_slice(b"IDAT");
        out.extend_from_slice(&crc32(b"IDAT").to_be_bytes());
        out
    }

    #[test]
    fn a_100000_square_header_is_refused_before_reading_pixels() {
        let e = decode(&header_only(100_000, 100_000), &Limits::default()).unwrap_err();
        assert!(matches!(e, Error::TooLarge(_)), "{e}");
        assert!(e.to_string().contains("100000x100000"), "{e}");
    }

    #[test]
    fn over_the_pixel_limit_is_refused_before_decoding() {
        let e = decode(&png16(64, 64), &Limits { max_pixels: 100 }).unwrap_err();
        assert!(matches!(e, Error::TooLarge(_)), "{e}");
    }
}
