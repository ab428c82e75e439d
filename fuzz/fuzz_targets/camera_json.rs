//! Camera JSON of any text: an error or a camera of finite numbers and a unit rotation.
#![no_main]

use dmesh_engine::camera::{camera_from_json, Projection};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(c) = camera_from_json(text) {
        assert!(c.width >= 1 && c.height >= 1);
        let (a, b, cx, cy) = match c.projection {
            Projection::Perspective { fx, fy, cx, cy } => (fx, fy, cx, cy),
            Projection::Orthographic { sx, sy, cx, cy } => (sx, sy, cx, cy),
        };
        assert!(a > 0.0 && b > 0.0 && [a, b, cx, cy].iter().all(|v| v.is_finite()));
        assert!((c.rotation.length() - 1.0).abs() < 1e-9);
        assert!(c.translation.is_finite());
    }
});
