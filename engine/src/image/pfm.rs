//! Portable float maps (PFM), as Middlebury ships disparities.
//!
//! Header: `Pf` (one channel) or `PF` (three; the first is used), then width and
//! height, then a scale whose sign gives the byte order (negative: little
//! endian). Rows are stored bottom to top.

use super::{Limits, RawSamples};
use crate::error::{Error, Result};

/// Reads one whitespace-delimited header token starting at `*pos`.
fn token<'a>(bytes: &'a [u8], pos: &mut usize) -> Result<&'a str> {
    while *pos < bytes.len() && bytes[*pos].is_ascii_whitespace() {
        *pos += 1;
    }
    let start = *pos;
    while *pos < bytes.len() && !bytes[*pos].is_ascii_whitespace() {
        *pos += 1;
        if *pos - start > 32 {
            return Err(Error::decode("PFM header token is longer than 32 bytes"));
        }
    }
    if start == *pos {
        return Err(Error::decode("PFM header is truncated"));
    }
    std::str::from_utf8(&bytes[start..*pos]).map_err(|_| Error::decode("PFM header is not ASCII"))
}

pub(crate) fn decode(bytes: &[u8], limits: &Limits) -> Result<RawSamples> {
    let mut pos = 0;
    let channels = match token(bytes, &mut pos)? {
        "Pf" => 1usize,
        "PF" => 3,
        other => return Err(Error::decode(format!("PFM magic is {other:?}; expected Pf or PF"))),
    };
    let w: u64 = token(bytes, &mut pos)?
        .parse()
        .map_err(|_| Error::decode("PFM width is not an integer"))?;
    let h: u64 = token(bytes, &mut pos)?
        .parse()
        .map_err(|_| Error::decode("PFM height is not an integer"))?;
    let scale: f64 = token(bytes, &mut pos)?
        .parse()
        .map_err(|_| Error::decode("PFM scale is not a number"))?;
    if !scale.is_finite() || scale == 0.0 {
        return Err(Error::decode(format!(
            "PFM scale is {}; it must be finite and non-zero",
            crate::error::Shown(scale)
        )));
    }
    limits.check("PFM image", w, h)?;
    // Exactly one whitespace byte separates the header from the data.
    pos += 1;
    let (w, h) = (w as usize, h as usize);
    let need = w * h * channels * 4;
    let data = bytes.get(pos..).unwrap_or_default();
    if data.len() < need {
        return Err(Error::decode(format!(
            "PFM data is truncated: {w}x{h} needs {need} bytes, found {}",
            data.len()
        )));
    }
    let little = scale < 0.0;
    let mut values = vec![0f32; w * h];
    for row in 0..h {
        // Bottom-to-top storage: file row 0 is the image's last row.
        let dst = (h - 1 - row) * w;
        for col in 0..w {
            let at = (row * w + col) * channels * 4;
            let b = [data[at], data[at + 1], data[at + 2], data[at + 3]];
            values[dst + col] = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
        }
    }
    Ok(RawSamples {
        width: w as u32,
        height: h as u32,
        values,
    })
}

/// Decodes a PFM file to `(width, height, row-major values)` (the first
/// channel of a colour `PF`), top row first.
pub fn decode_pfm(bytes: &[u8], limits: &Limits) -> Result<(u32, u32, Vec<f32>)> {
    let raw = decode(bytes, limits)?;
    Ok((raw.width, raw.height, raw.values))
}

/// Encodes row-major single-channel floats as a little-endian `Pf` file.
pub fn encode_pfm(width: u32, height: u32, values: &[f32]) -> Vec<u8> {
    let mut out = format!("Pf\n{width} {height}\n-1.0\n").into_bytes();
    for row in (0..height as usize).rev() {
        for v in &values[row * width as usize..(row + 1) * width as usize] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_row_order() {
        let values = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let raw = decode(&encode_pfm(3, 2, &values), &Limits::default()).unwrap();
        assert_eq!((raw.width, raw.height), (3, 2));
        assert_eq!(raw.values, values);
    }

    #[test]
    fn truncated_and_huge_are_errors_not_panics() {
        let bytes = encode_pfm(3, 2, &[1.0; 6]);
        for cut in 0..bytes.len() {
            assert!(decode(&bytes[..cut], &Limits::default()).is_err(), "cut at {cut}");
        }
        let huge = b"Pf\n100000 100000\n-1.0\n";
        let e = decode(huge, &Limits::default()).unwrap_err();
        assert!(matches!(e, Error::TooLarge(_)), "{e}");
    }
}
