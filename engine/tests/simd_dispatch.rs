//! The build's AVX2 and AVX-512 code (`dmesh_engine::simd`) and its
//! portable fallback give the same bytes: every vertex's error, radius and flags, and the
//! meshes extracted from them with their normals and rho, on scenes with
//! boxes, holes and noise, every segmentation method, perspective and
//! orthographic cameras, one thread and two. So do the depth decodes
//! that run at those tiers (16-bit PGM, and z from raw samples), on one
//! thread and on two.

use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Lod, Method, Segmentation, Threads};

/// Everything a build produces that users rely on, as bits.
fn fingerprint(depth: &DepthImage, camera: &Camera, seg: &Segmentation, threads: Threads) -> Vec<u64> {
    let m = Hierarchy::build_with(depth, camera, seg, threads).unwrap();
    let g = *m.grid();
    let mut out = Vec::new();
    for y in 0..g.gh() {
        for x in 0..g.gw() {
            out.push(u64::from(m.error((x, y)).to_bits()));
            out.push(u64::from(m.radius((x, y)).to_bits()));
            out.push(u64::from(m.cell_segmented((x, y), 0)) | u64::from(m.cell_segmented((x, y), 1)) << 1);
        }
    }
    for eps in [0.0, 0.002, 0.02] {
        let mesh = m.extract(Lod::Epsilon(eps)).unwrap();
        out.extend(mesh.triangles.iter().flatten().map(|&i| u64::from(i)));
        out.extend(mesh.strips.iter().map(|&i| u64::from(i)));
        for v in &mesh.vertices {
            out.push(u64::from(v.i) | u64::from(v.j) << 16 | u64::from(v.depth.to_bits()) << 32);
            out.push(u64::from(v.normal[0]) | u64::from(v.normal[1]) << 8 | u64::from(v.rho) << 16);
        }
    }
    out
}

/// The synthetic terrain with boxes, with holes and a little noise.
fn scenes() -> Vec<(String, DepthImage, Camera)> {
    let mut out = Vec::new();
    for (w, h) in [(129, 97), (64, 64), (33, 47)] {
        let (d, c) = dmesh_engine::synthetic::terrain_with_boxes(w, h);
        out.push((format!("{w}x{h}"), d.clone(), c));
        let mut z = d.z.clone();
        let mut state = 0x9e37_79b9_7f4a_7c15u64 ^ u64::from(w);
        for (k, s) in z.iter_mut().enumerate() {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let r = (state >> 40) as f32 / (1u64 << 24) as f32;
            if k % 97 == 5 || r < 0.01 {
                *s = 0.0;
            } else {
                *s *= 1.0 + 0.002 * (r - 0.5);
            }
        }
        let holes = DepthImage::from_z(w, h, z).unwrap();
        out.push((format!("{w}x{h} with holes and noise"), holes, c));
    }
    let (d, _) = dmesh_engine::synthetic::terrain_with_boxes(48, 40);
    let ortho = Camera::orthographic(48, 40, 0.01, 0.01, 23.5, 19.5).unwrap();
    out.push(("48x40 orthographic".into(), d, ortho));
    out
}

#[test]
fn every_tier_and_the_portable_code_give_the_same_bytes() {
    use dmesh_engine::simd::{limit, tier_in_use, Tier};
    check_limits();
    #[cfg(target_arch = "x86_64")]
    assert!(
        Tier::Avx2.available(),
        "this CPU has no AVX2: the comparison would be of the portable code with itself"
    );
    // Every tier this CPU has; AVX-512 where it has it (the CPUs CI runs
    // on do not all have it: the test names the tiers it compared).
    let tiers: Vec<Tier> = Tier::ALL[1..].iter().copied().filter(|t| t.available()).collect();
    eprintln!("tiers compared with the portable code: {tiers:?}");
    let methods = [
        Method::Orthogonality { omega_deg: 5.0 },
        Method::Disparity { sigma: 0.5 },
        Method::Connectedness { kappa: 0.5 },
        Method::None,
    ];
    let mut compared = 0;
    for (name, depth, camera) in scenes() {
        for method in methods {
            let seg = Segmentation {
                method,
                ..Default::default()
            };
            for threads in [Threads::Single, Threads::Parallel] {
                limit(Tier::Portable);
                assert_eq!(tier_in_use(), Tier::Portable);
                let portable = fingerprint(&depth, &camera, &seg, threads);
                for &tier in &tiers {
                    limit(tier);
                    assert_eq!(tier_in_use(), tier);
                    let fast = fingerprint(&depth, &camera, &seg, threads);
                    assert!(
                        portable == fast,
                        "{name}, {method:?}, {threads:?}: {tier:?} and portable differ"
                    );
                    compared += 1;
                }
            }
        }
    }
    for &tier in &tiers {
        limit(Tier::Portable);
        let portable = decoded();
        limit(tier);
        assert!(portable == decoded(), "decodes: {tier:?} and portable differ");
    }
    limit(Tier::Avx512);
    assert_eq!(compared, 7 * 4 * 2 * tiers.len());
}

/// The bits of depths decoded from 16-bit PGM and from PFM holding every
/// kind of raw value (zero, negative, NaN, infinite, huge, tiny), with
/// scales and offsets that send some out of range, at sizes decoded on
/// one thread and on two.
fn decoded() -> Vec<u32> {
    use dmesh_engine::image::{decode_depth, encode_pfm, pgm, DepthOptions, Limits};
    let mut out = Vec::new();
    for (w, h) in [(33u32, 17u32), (1100, 1000)] {
        let camera = Camera::perspective(w, h, 500.0, 500.0, f64::from(w) / 2.0, f64::from(h) / 2.0).unwrap();
        let n = (w * h) as usize;
        let raw16: Vec<u16> = (0..n).map(|i| (i.wrapping_mul(2_654_435_761) >> 7) as u16).collect();
        let special = [
            0.0,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            3.0e38,
            1.0e-40,
            0.5,
            1234.5,
        ];
        let raw32: Vec<f32> = (0..n)
            .map(|i| special[i % special.len()] * (1.0 + (i % 13) as f32))
            .collect();
        let files = [pgm::encode16(w, h, &raw16), encode_pfm(w, h, &raw32)];
        for bytes in &files {
            for (scale, offset) in [(0.001, 0.0), (1.0, -100.0), (1.0e30, 0.0), (-2.0, 5.0)] {
                let options = DepthOptions {
                    scale,
                    offset,
                    ..Default::default()
                };
                let depth = decode_depth(bytes, &options, &camera, &Limits::default()).unwrap();
                assert!(depth.z.iter().all(|z| z.is_finite() && *z >= 0.0));
                out.extend(depth.z.iter().map(|z| z.to_bits()));
            }
        }
    }
    out
}

/// No limit makes a tier run that the CPU lacks, nor one above the limit.
/// (Called from the one test: the limit is global, and tests run side by
/// side.)
fn check_limits() {
    use dmesh_engine::simd::{limit, tier_in_use, Tier};
    for tier in Tier::ALL {
        limit(tier);
        let used = tier_in_use();
        assert!(used <= tier, "limit {tier:?} ran {used:?}");
        assert!(used.available(), "{used:?} is not on this CPU");
    }
    limit(Tier::Avx512);
}
