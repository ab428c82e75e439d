//! Depth images (PNG 8/16-bit, OpenEXR, PFM) of any bytes: an error or a
//! depth map whose samples are finite and positive, or 0 (invalid).
#![no_main]

use dmesh_engine::camera::Camera;
use dmesh_engine::image::{decode_depth, DepthKind, DepthOptions, Limits};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&kind, bytes)) = data.split_first() else { return };
    let kind = [DepthKind::Z, DepthKind::Range, DepthKind::Disparity, DepthKind::InverseDepth][usize::from(kind % 4)];
    let options = DepthOptions {
        kind,
        focal_baseline: Some(100.0),
        ..DepthOptions::default()
    };
    let limits = Limits { max_pixels: 1 << 20 };
    // The decoders run whole before the size is compared with the camera's.
    let camera = Camera::perspective(8, 8, 10.0, 10.0, 3.5, 3.5).unwrap();
    if let Ok(depth) = decode_depth(bytes, &options, &camera, &limits) {
        assert!(depth.z.iter().all(|&z| z == 0.0 || (z.is_finite() && z > 0.0)));
    }
});
