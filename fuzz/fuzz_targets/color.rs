//! Colour images (PNG, JPEG) of any bytes: an error or an image of the size
//! it says; and the header check a live frame gets (`color_dimensions`)
//! never panics and, where the whole decode succeeds, gives its size.
#![no_main]

use dmesh_engine::image::{color_dimensions, decode_color, Limits};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let limits = Limits { max_pixels: 1 << 20 };
    let header = color_dimensions(data, &limits);
    if let Ok(img) = decode_color(data, &limits) {
        assert_eq!(img.rgb.len() as u64, 3 * u64::from(img.width) * u64::from(img.height));
        assert_eq!(header.ok(), Some((img.width, img.height)));
    }
});
