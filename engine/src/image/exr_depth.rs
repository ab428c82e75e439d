//! OpenEXR depth maps: the first float channel, or the one named by the caller.

use std::io::Cursor;

use exr::prelude::*;

use super::{Limits, RawSamples};
use crate::error::{Error as EngineError, Result as EngineResult};

pub(crate) fn decode(bytes: &[u8], channel: Option<&str>, limits: &Limits) -> EngineResult<RawSamples> {
    let bad = |e: exr::error::Error| EngineError::decode(format!("depth EXR: {e}"));
    // Header first: refuse oversized layers before any pixel is allocated.
    let meta = MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(bad)?;
    for header in meta.headers.iter() {
        limits.check(
            "depth EXR layer",
            header.layer_size.0 as u64,
            header.layer_size.1 as u64,
        )?;
    }
    // The decoder is third-party code fed untrusted bytes: a panic in it must
    // become an error, never take the caller down.
    let read = std::panic::catch_unwind(|| {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_buffered(Cursor::new(bytes))
    })
    .map_err(|_| EngineError::decode("depth EXR is malformed (the decoder gave up)"))?;
    let image = read.map_err(bad)?;
    let layer = &image.layer_data;
    let list = &layer.channel_data.list;
    let is_float = |c: &&AnyChannel<FlatSamples>| !matches!(c.sample_data, FlatSamples::U32(_));
    let chosen = match channel {
        Some(name) => list.iter().find(|c| c.name.to_string() == name).ok_or_else(|| {
            let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
            EngineError::decode(format!("depth EXR has no channel {name:?}; it has {names:?}"))
        })?,
        None => list
            .iter()
            .find(is_float)
            .ok_or_else(|| EngineError::decode("depth EXR has no float (half or float) channel"))?,
    };
    let (w, h) = (layer.size.0, layer.size.1);
    let values: Vec<f32> = chosen.sample_data.values_as_f32().collect();
    if values.len() != w * h {
        return Err(EngineError::decode(format!(
            "depth EXR channel has {} samples for a {w}x{h} layer (subsampled channels are not supported)",
            values.len()
        )));
    }
    Ok(RawSamples {
        width: w as u32,
        height: h as u32,
        values,
    })
}

/// Encodes row-major floats as a single-channel (`Z`) 32-bit float EXR.
pub fn encode_exr(width: u32, height: u32, values: &[f32]) -> EngineResult<Vec<u8>> {
    let channel = AnyChannel::new("Z", FlatSamples::F32(values.to_vec()));
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vec![channel])),
    );
    let mut out = Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut out)
        .map_err(|e| EngineError::Internal(format!("writing EXR: {e}")))?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_channel_round_trips() {
        let v: Vec<f32> = (0..12).map(|i| i as f32 * 0.5).collect();
        let raw = decode(&encode_exr(4, 3, &v).unwrap(), None, &Limits::default()).unwrap();
        assert_eq!((raw.width, raw.height), (4, 3));
        assert_eq!(raw.values, v);
    }

    #[test]
    fn missing_named_channel_is_named() {
        let bytes = encode_exr(2, 2, &[1.0; 4]).unwrap();
        let e = decode(&bytes, Some("depth"), &Limits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"depth\"") && e.contains("Z"), "{e}");
    }

    #[test]
    fn a_100000_square_data_window_is_refused_before_reading_pixels() {
        let mut bytes = encode_exr(2, 2, &[1.0; 4]).unwrap();
        // dataWindow is a box2i: name, type name, size 16, then xmin ymin xmax ymax.
        let at = bytes.windows(10).position(|w| w == b"dataWindow").unwrap();
        let values = at + b"dataWindow\0box2i\0".len() + 4;
        bytes[values + 8..values + 12].copy_from_slice(&99_999i32.to_le_bytes());
        bytes[values + 12..values + 16].copy_from_slice(&99_999i32.to_le_bytes());
        let e = decode(&bytes, None, &Limits::default()).unwrap_err();
        assert!(matches!(e, EngineError::TooLarge(_)), "{e}");
    }

    #[test]
    fn truncated_exr_is_an_error() {
        let bytes = encode_exr(8, 8, &[1.0; 64]).unwrap();
        for cut in [4, 10, 50, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..cut], None, &Limits::default()).is_err(), "cut at {cut}");
        }
    }
}
