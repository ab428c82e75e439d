//! One uploaded view decoded as the engine needs it: its depth converted to
//! `z` and masked, its colour checked to be PNG or JPEG of the depth's size.
//! The server's upload and `dmesh mesh` both decode through it, so the same
//! file gets the same answer from either.

use super::{color_dimensions, decode_color, decode_depth, decode_mask, ColorImage, DepthImage, DepthOptions, Limits};
use crate::camera::Camera;
use crate::error::{Error, Result};

/// The encoded parts of a view.
#[derive(Clone, Copy, Debug)]
pub struct ViewFiles<'a> {
    /// The depth image (EXR, PNG, PFM or PGM).
    pub depth: &'a [u8],
    /// A mask of valid samples (PNG, nonzero keeps a sample), if any.
    pub mask: Option<&'a [u8]>,
    /// The colour image (PNG or JPEG), if any.
    pub color: Option<&'a [u8]>,
}

/// A decoded view.
#[derive(Clone, Debug)]
pub struct DecodedView {
    /// Depth as `z`, masked.
    pub depth: DepthImage,
    /// Colour, the depth's size.
    pub color: Option<ColorImage>,
}

/// Decodes `files` for `camera`: depth by `options`, then the mask, then the
/// colour, each within `limits`. Errors name the part that failed.
pub fn decode_view(
    files: ViewFiles<'_>,
    options: &DepthOptions,
    camera: &Camera,
    limits: &Limits,
) -> Result<DecodedView> {
    let mut depth = decode_depth(files.depth, options, camera, limits)?;
    if let Some(m) = files.mask {
        depth.apply_mask(&decode_mask(m, depth.width, depth.height, limits)?)?;
    }
    let color = match files.color {
        None => None,
        Some(bytes) => {
            let c = decode_color(bytes, limits)?;
            same_size(c.width, c.height, &depth)?;
            Some(c)
        }
    };
    Ok(DecodedView { depth, color })
}

/// Checks a colour image against `depth` from its header alone: PNG or
/// JPEG, within `limits`, the depth's size. Its pixel data is not decoded,
/// so damage past the header is not seen: for a live frame, whose budget a
/// whole decode would take a tenth of (`decode_view` decodes it whole).
pub fn check_color_header(bytes: &[u8], depth: &DepthImage, limits: &Limits) -> Result<()> {
    let (width, height) = color_dimensions(bytes, limits)?;
    same_size(width, height, depth)
}

/// Refuses a colour image of another size than `depth`.
fn same_size(width: u32, height: u32, depth: &DepthImage) -> Result<()> {
    if (width, height) == (depth.width, depth.height) {
        return Ok(());
    }
    Err(Error::invalid(format!(
        "colour image is {width}x{height} but the depth image is {}x{}; they must match",
        depth.width, depth.height
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::DepthImage;

    fn png(w: u32, h: u32) -> Vec<u8> {
        let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([x as u8, y as u8, 7]));
        let mut out = Vec::new();
        image::DynamicImage::ImageRgb8(img)
            .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
            .unwrap();
        out
    }

    /// The header check refuses what the whole decode refuses for its
    /// type and size, and takes damage past the header, as documented.
    #[test]
    fn the_header_check_sees_type_and_size_but_not_the_pixels() {
        let depth = DepthImage::from_z(12, 9, vec![1.0; 12 * 9]).unwrap();
        let limits = Limits::default();
        let good = png(12, 9);
        check_color_header(&good, &depth, &limits).unwrap();
        let err = check_color_header(&png(9, 12), &depth, &limits)
            .unwrap_err()
            .to_string();
        assert!(err.contains("9x12") && err.contains("must match"), "{err}");
        assert!(check_color_header(b"GIF89a", &depth, &limits).is_err());
        assert!(
            check_color_header(&good[..20], &depth, &limits).is_err(),
            "no whole header"
        );
        let tiny = Limits { max_pixels: 50 };
        assert!(
            check_color_header(&good, &depth, &tiny).is_err(),
            "over the pixel limit"
        );
        // Pixel data cut short: the header check passes, a whole decode does not.
        let cut = &good[..good.len() - 30];
        check_color_header(cut, &depth, &limits).unwrap();
        let files = ViewFiles {
            depth: &crate::image::encode_pfm(12, 9, &depth.z),
            mask: None,
            color: Some(cut),
        };
        let camera = Camera::perspective(12, 9, 10.0, 10.0, 6.0, 4.5).unwrap();
        let options = DepthOptions::default();
        assert!(decode_view(files, &options, &camera, &limits).is_err());
    }
}
