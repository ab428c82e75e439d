//! Strip decoding as the clients do it: any indices give triangles of
//! distinct indices taken from the input, none across a restart.
#![no_main]

use dmesh_engine::mesh::{decode_strips, RESTART};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let indices: Vec<u32> = data
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let tris = decode_strips(&indices);
    let runs: usize = indices.split(|&i| i == RESTART).map(|r| r.len().saturating_sub(2)).sum();
    assert!(tris.len() <= runs);
    for t in tris {
        assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
        assert!(t.iter().all(|&v| v != RESTART && indices.contains(&v)));
    }
});
