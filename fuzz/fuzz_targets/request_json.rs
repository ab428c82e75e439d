//! Strip and render request bodies in JSON: an error or a value whose camera
//! either validates or is refused, never a panic.
#![no_main]

use dmesh_engine::camera::Camera;
use dmesh_proto::{RenderRequest, StripRequest};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = serde_json::from_slice::<RenderRequest>(data) {
        let _ = Camera::try_from(&r.camera);
    }
    if let Ok(r) = serde_json::from_slice::<StripRequest>(data) {
        if let Some(c) = &r.camera {
            let _ = Camera::try_from(c);
        }
    }
});
