//! Colour images (PNG, JPEG) of any bytes: an error or an image of the size it says.
#![no_main]

use dmesh_engine::image::{decode_color, Limits};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(img) = decode_color(data, &Limits { max_pixels: 1 << 20 }) {
        assert_eq!(img.rgb.len() as u64, 3 * u64::from(img.width) * u64::from(img.height));
    }
});
