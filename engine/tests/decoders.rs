//! Untrusted image bytes never panic a decoder: mutated and truncated files
//! of every format give an error or an image, nothing else.

use dmesh_engine::camera::Camera;
use dmesh_engine::image::{decode_color, decode_depth, decode_mask, encode_exr, encode_pfm, DepthOptions, Limits};
use proptest::prelude::*;

fn seeds() -> Vec<Vec<u8>> {
    let z: Vec<f32> = (0..48).map(|i| 1.0 + i as f32 * 0.1).collect();
    let mut png = Vec::new();
    image::DynamicImage::ImageLuma16(image::ImageBuffer::from_fn(8, 6, |x, y| {
        image::Luma([(x * 100 + y) as u16])
    }))
    .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
    .unwrap();
    let mut jpeg = Vec::new();
    image::DynamicImage::ImageRgb8(image::ImageBuffer::from_fn(8, 6, |x, y| {
        image::Rgb([x as u8 * 30, y as u8 * 40, 7])
    }))
    .write_to(&mut std::io::Cursor::new(&mut jpeg), image::ImageFormat::Jpeg)
    .unwrap();
    vec![encode_exr(8, 6, &z).unwrap(), encode_pfm(8, 6, &z), png, jpeg]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn mutated_files_never_panic(which in 0usize..4, edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8), cut in any::<usize>()) {
        let mut bytes = seeds().swap_remove(which);
        for (at, value) in edits {
            let n = bytes.len();
            bytes[at % n] = value;
        }
        let keep = 1 + cut % bytes.len();
        bytes.truncate(keep);
        let cam = Camera::perspective(8, 6, 8.0, 8.0, 3.5, 2.5).unwrap();
        let limits = Limits { max_pixels: 1 << 20 };
        let _ = decode_depth(&bytes, &DepthOptions::default(), &cam, &limits);
        let _ = decode_color(&bytes, &limits);
        let _ = decode_mask(&bytes, 8, 6, &limits);
    }
}
