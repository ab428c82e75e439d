//! Residual depth decoding (PROTOCOL.md) of any header, anchors, bits and
//! vertex list: an error or finite positive depths, one per vertex.
#![no_main]

use dmesh_proto::residual::ResidualDepths;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The first byte says how many vertices follow as (i, j) u16 pairs; the
    // rest is the residual block in bincode.
    let Some((&n, rest)) = data.split_first() else { return };
    let n = usize::from(n);
    if rest.len() < 4 * n {
        return;
    }
    let ij: Vec<(u16, u16)> = rest[..4 * n]
        .chunks_exact(4)
        .map(|c| (u16::from_le_bytes([c[0], c[1]]), u16::from_le_bytes([c[2], c[3]])))
        .collect();
    if let Ok(r) = dmesh_proto::from_bincode::<ResidualDepths>(&rest[4 * n..]) {
        if let Ok(z) = r.decode(&ij) {
            assert_eq!(z.len(), ij.len());
            assert!(z.iter().all(|&v| v.is_finite() && v > 0.0));
        }
    }
});
