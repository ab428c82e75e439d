//! Binary greyscale PGM (`P5`), 8 or 16 bits per sample: the cheapest
//! container for a depth camera's raw frames (a few header bytes, then the
//! samples as they come off the sensor; 16-bit samples are big-endian, as
//! the Netpbm format defines). Read as a 16-bit PNG is, so an integer
//! depth keeps its lattice (`depth_kind=z` with `depth_scale`).
//!
//! Header: `P5`, width, height, maxval (1 to 65535), each separated by
//! whitespace, `#` comments allowed between them, then exactly one
//! whitespace byte before the samples.

use super::{Limits, RawSamples};
use crate::error::{Error, Result};

/// One header number starting at `*pos` (after whitespace and comments).
fn number(bytes: &[u8], pos: &mut usize, what: &str) -> Result<u64> {
    loop {
        while *pos < bytes.len() && bytes[*pos].is_ascii_whitespace() {
            *pos += 1;
        }
        if bytes.get(*pos) != Some(&b'#') {
            break;
        }
        while *pos < bytes.len() && bytes[*pos] != b'\n' {
            *pos += 1;
        }
    }
    let start = *pos;
    while *pos < bytes.len() && bytes[*pos].is_ascii_digit() {
        *pos += 1;
        if *pos - start > 10 {
            return Err(Error::decode(format!("PGM {what} has more than 10 digits")));
        }
    }
    if start == *pos {
        return Err(Error::decode(format!(
            "PGM header is truncated or malformed at its {what}"
        )));
    }
    std::str::from_utf8(&bytes[start..*pos])
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| Error::decode(format!("PGM {what} is not a number")))
}

crate::simd::dispatch! {
    /// Big-endian 16-bit samples `data` as f32 into `out` (as long as
    /// `data` has pairs), with AVX2 or AVX-512 where the CPU has them.
    fn be16_to_f32(data: &[u8], out: &mut [f32]) -> () = be16_to_f32_body;
}

#[inline(always)]
fn be16_to_f32_body(data: &[u8], out: &mut [f32]) {
    for (o, b) in out.iter_mut().zip(data.chunks_exact(2)) {
        *o = f32::from(u16::from_be_bytes([b[0], b[1]]));
    }
}

pub(crate) fn decode(bytes: &[u8], limits: &Limits) -> Result<RawSamples> {
    if !bytes.starts_with(b"P5") {
        return Err(Error::decode("PGM magic is not P5 (binary greyscale)"));
    }
    let mut pos = 2;
    let w = number(bytes, &mut pos, "width")?;
    let h = number(bytes, &mut pos, "height")?;
    let maxval = number(bytes, &mut pos, "maxval")?;
    if !(1..=65535).contains(&maxval) {
        return Err(Error::decode(format!("PGM maxval is {maxval}; it must be 1 to 65535")));
    }
    limits.check("PGM image", w, h)?;
    if !bytes.get(pos).is_some_and(u8::is_ascii_whitespace) {
        return Err(Error::decode("PGM header must end with one whitespace byte"));
    }
    pos += 1;
    let n = (w * h) as usize;
    let size = if maxval < 256 { 1 } else { 2 };
    let data = bytes.get(pos..).unwrap_or_default();
    if data.len() < n * size {
        return Err(Error::decode(format!(
            "PGM data is truncated: {w}x{h} at {size} bytes a sample needs {} bytes, found {}",
            n * size,
            data.len()
        )));
    }
    let values = if size == 1 {
        data[..n].iter().map(|&v| f32::from(v)).collect()
    } else {
        let mut values = vec![0f32; n];
        super::in_halves(&mut values, |first, part| {
            be16_to_f32(&data[2 * first..2 * (first + part.len())], part)
        });
        values
    };
    Ok(RawSamples {
        width: w as u32,
        height: h as u32,
        values,
    })
}

/// `samples` (row-major, `width` wide) as a 16-bit binary PGM.
pub fn encode16(width: u32, height: u32, samples: &[u16]) -> Vec<u8> {
    let mut out = format!("P5\n{width} {height}\n65535\n").into_bytes();
    out.reserve(2 * samples.len());
    for v in samples {
        out.extend_from_slice(&v.to_be_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_and_eight_bit_samples_read_as_written() {
        let samples: Vec<u16> = (0..12).map(|k| k * 5000).collect();
        let raw = decode(&encode16(4, 3, &samples), &Limits::default()).unwrap();
        assert_eq!((raw.width, raw.height), (4, 3));
        assert_eq!(raw.values, samples.iter().map(|&v| f32::from(v)).collect::<Vec<_>>());
        let mut eight = b"P5 # a comment\n2 2\n# another\n255\n".to_vec();
        eight.extend_from_slice(&[0, 7, 200, 255]);
        assert_eq!(
            decode(&eight, &Limits::default()).unwrap().values,
            [0.0, 7.0, 200.0, 255.0]
        );
    }

    #[test]
    fn bad_headers_and_short_data_are_errors() {
        let limits = Limits::default();
        let good = encode16(4, 3, &[1; 12]);
        for bad in [
            &b"P6\n4 3\n65535\n"[..],
            b"P5\n4 3\n0\n",
            b"P5\n4 3\n70000\n",
            b"P5\n4\n",
            b"P5\n4 x 255\n",
            b"P5\n4 3\n65535",
            &good[..good.len() - 1],
        ] {
            assert!(decode(bad, &limits).is_err(), "{:?}", String::from_utf8_lossy(bad));
        }
        let huge = b"P5\n100000 100000\n65535\n";
        assert!(matches!(decode(huge, &limits), Err(Error::TooLarge(_))));
    }
}
