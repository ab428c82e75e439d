//! Protocol 6 over the engine's own meshes: decode(encode(mesh)) gives
//! exactly the vertices and triangles extraction produced, and depths within
//! the stated bound, for random depths with holes and steps (so segmentation
//! drops triangles), static and view-dependent tolerances, budgets, odd
//! sizes, perspective and orthographic cameras, every plane count.

use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{decode_strips, Hierarchy, Lod, Segmentation};
use dmesh_engine::wire_compact::{held as held_of, mesh_change, mesh_stream, strip_response};
use dmesh_proto::{Depths, RawGrid};
use proptest::prelude::*;

fn depth(w: u32, h: u32, seed: u64, lattice: bool) -> DepthImage {
    let mut s = seed | 1;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let (a, b, step_at, hole) = (rnd() * 0.4, rnd() * 0.3, rnd(), rnd());
    let z = (0..w * h)
        .map(|k| {
            let (x, y) = (f64::from(k % w) / f64::from(w), f64::from(k / w) / f64::from(h));
            if (x - hole).abs() < 0.05 && y > 0.5 {
                return 0.0;
            }
            let mut z = 2.0 + a * (x * 9.0).sin() + b * y + if x > step_at { 1.0 } else { 0.0 } + 0.002 * rnd();
            if lattice {
                z = (z * 1000.0).round() / 1000.0;
            }
            z as f32
        })
        .collect();
    DepthImage::from_z(w, h, z).unwrap()
}

fn camera(w: u32, h: u32, ortho: bool) -> Camera {
    let (cx, cy) = (f64::from(w - 1) / 2.0, f64::from(h - 1) / 2.0);
    if ortho {
        Camera::orthographic(w, h, 0.01, 0.01, cx, cy).unwrap()
    } else {
        Camera::perspective(w, h, f64::from(w), f64::from(w), cx, cy).unwrap()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn compact_streams_decode_to_the_extracted_mesh(
        w in 2u32..90, h in 2u32..70, seed in any::<u64>(), ortho in any::<bool>(),
        lattice in any::<bool>(), kind in 0u8..3, tol in 0.0f64..0.05, planes in prop::option::of(0u8..18),
    ) {
        let d = depth(w, h, seed, lattice);
        let cam = camera(w, h, ortho);
        let hier = Hierarchy::build(&d, &cam, &Segmentation::default()).unwrap();
        let mut novel = cam;
        novel.translation.x += 0.1;
        let lod = match kind {
            0 => Lod::Epsilon(tol),
            1 => Lod::Tau { tau: tol * 40.0, view: &novel },
            _ => Lod::Triangles { max: u32::try_from(hier.coarsest_triangles() + (tol * 4000.0) as u64).unwrap(), view: None },
        };
        let mesh = hier.extract(lod).unwrap();
        let raw = lattice.then_some(RawGrid { scale: 0.001, offset: 0.0 });
        let s = mesh_stream(&mesh, hier.grid(), "s", "v", &cam, raw, planes, "\"e\"".into()).unwrap();
        let bytes = dmesh_proto::to_bincode(&s).unwrap();
        let back: dmesh_proto::MeshStream = dmesh_proto::from_bincode(&bytes).unwrap();
        let r = strip_response(&back, Some(&novel)).unwrap();
        let ij: Vec<(u16, u16)> = r.vertices.iter().map(|v| (v.i, v.j)).collect();
        let want: Vec<(u16, u16)> = mesh.vertices.iter().map(|v| (v.i, v.j)).collect();
        prop_assert_eq!(ij, want);
        prop_assert_eq!(decode_strips(&r.indices.to_u32()), mesh.triangles.clone());
        let Depths::Exact(z) = &r.depths else { panic!("exact depths expected") };
        let bound = back.max_error;
        for (a, v) in z.iter().zip(&mesh.vertices) {
            prop_assert!(a.is_finite() && *a > 0.0);
            prop_assert!((a - v.depth).abs() <= bound, "{} vs {} beyond {}", a, v.depth, bound);
        }
        if lattice && planes.is_none() {
            prop_assert_eq!(bound, 0.0, "all planes on a lattice are lossless");
        }
        for v in &r.vertices {
            prop_assert!(u32::from(v.i) < w && u32::from(v.j) < h);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// A change between two of the engine's meshes of one view (another
    /// tolerance, a moved camera), applied to the held one as the client
    /// decoded it, is exactly the whole new mesh's decode.
    #[test]
    fn changes_between_engine_meshes_are_exact(
        w in 2u32..90, h in 2u32..70, seed in any::<u64>(), ortho in any::<bool>(), lattice in any::<bool>(),
        tols in (0.05f64..8.0, 0.05f64..8.0), shift in -0.3f64..0.3, planes in prop::option::of(0u8..18),
    ) {
        let d = depth(w, h, seed, lattice);
        let cam = camera(w, h, ortho);
        let hier = Hierarchy::build(&d, &cam, &Segmentation::default()).unwrap();
        let (mut before, mut after) = (cam, cam);
        before.translation.x += 0.1;
        after.translation.x += 0.1 + shift;
        let raw = lattice.then_some(RawGrid { scale: 0.001, offset: 0.0 });
        let held_mesh = hier.extract(Lod::Tau { tau: tols.0, view: &before }).unwrap();
        let held = mesh_stream(&held_mesh, hier.grid(), "s", "v", &cam, raw, planes, String::new())
            .unwrap()
            .decode()
            .unwrap();
        let mesh = hier.extract(Lod::Tau { tau: tols.1, view: &after }).unwrap();
        let whole = mesh_stream(&mesh, hier.grid(), "s", "v", &cam, raw, planes, String::new()).unwrap();
        let change = mesh_change(&mesh, hier.grid(), "s", "v", &cam, raw, planes, String::new(), &held).unwrap();
        // What the server codes against (the held mesh derived, not decoded) gives the same change.
        let derived = held_of(&held_mesh, raw, planes);
        let same = mesh_change(&mesh, hier.grid(), "s", "v", &cam, raw, planes, String::new(), &derived).unwrap();
        prop_assert_eq!(&same, &change);
        let got = change.apply(&held).unwrap();
        let want = whole.decode().unwrap();
        prop_assert_eq!(&got.shape, &want.shape);
        prop_assert_eq!(&got.depths, &want.depths);
        prop_assert_eq!(got.max_error, want.max_error);
        prop_assert_eq!(change.reuses_depths, planes.is_none() && held.lattice == want.lattice);
    }
}

#[test]
fn a_large_full_resolution_mesh_round_trips() {
    let (w, h) = (641, 481);
    let d = depth(w, h, 5, true);
    let cam = camera(w, h, false);
    let hier = Hierarchy::build(&d, &cam, &Segmentation::default()).unwrap();
    let mesh = hier.extract(Lod::Epsilon(0.0)).unwrap();
    assert!(mesh.triangles.len() > 500_000);
    let raw = Some(RawGrid {
        scale: 0.001,
        offset: 0.0,
    });
    let s = mesh_stream(&mesh, hier.grid(), "s", "v", &cam, raw, None, "\"e\"".into()).unwrap();
    let decoded = s.decode().unwrap();
    assert_eq!(decoded.shape.triangles, mesh.triangles);
    let exact: Vec<f32> = mesh.vertices.iter().map(|v| v.depth).collect();
    assert_eq!(decoded.depths, exact);
}
