//! One uploaded view decoded as the engine needs it: its depth converted to
//! `z` and masked, its colour checked to be PNG or JPEG of the depth's size.
//! The server's upload and `dmesh mesh` both decode through it, so the same
//! file gets the same answer from either.

use super::{decode_color, decode_depth, decode_mask, sniff, ColorImage, DepthImage, DepthOptions, Format, Limits};
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
            if !matches!(sniff(bytes), Some(Format::Png | Format::Jpeg)) {
                return Err(Error::Decode(
                    "colour is not PNG or JPEG (unrecognised magic bytes)".into(),
                ));
            }
            let c = decode_color(bytes, limits)?;
            if (c.width, c.height) != (depth.width, depth.height) {
                return Err(Error::invalid(format!(
                    "colour image is {}x{} but the depth image is {}x{}; they must match",
                    c.width, c.height, depth.width, depth.height
                )));
            }
            Some(c)
        }
    };
    Ok(DecodedView { depth, color })
}
