//! Every wire type in bincode, as a client or the server decodes it: an
//! error or a value; a strip response's depths decode to finite positive
//! values or an error.
#![no_main]

use dmesh_proto::{from_bincode, RenderRequest, RenderResponse, StripRequest, StripResponse};
use libfuzzer_sys::fuzz_target;

fn depths_are_sound(s: &StripResponse) {
    if let Ok(z) = s.decode_depths() {
        assert_eq!(z.len(), s.vertices.len());
        assert!(z.iter().all(|&v| v.is_finite() && v > 0.0));
    }
}

fuzz_target!(|data: &[u8]| {
    let _ = from_bincode::<RenderRequest>(data);
    let _ = from_bincode::<StripRequest>(data);
    if let Ok(s) = from_bincode::<StripResponse>(data) {
        depths_are_sound(&s);
    }
    if let Ok(r) = from_bincode::<RenderResponse>(data) {
        r.views.iter().for_each(|v| depths_are_sound(&v.strips));
    }
});
