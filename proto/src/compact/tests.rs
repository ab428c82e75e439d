//! Round trips of the compact stream over random conforming meshes: a walk
//! that splits at random (the rules' implications respected, as a server's
//! monotone selection does) and leaves leaves out at random.

use proptest::prelude::*;

use super::forest::{Decide, Forest, Node, Pt, Symbol};
use super::*;
use crate::camera::{Pose, Projection};

/// A random walk's decisions from a seed: split with probability `split`
/// (coarse triangles more often), skip a leaf with probability `skip`.
struct Random {
    state: u64,
    split: f64,
    skip: f64,
    corners: Vec<[Pt; 3]>,
}

impl Random {
    fn next(&mut self) -> f64 {
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        (self.state >> 11) as f64 / (1u64 << 53) as f64
    }
}

impl Decide for Random {
    type Error = ();
    fn decide(&mut self, node: &Node, implied: bool) -> Result<Symbol, ()> {
        if implied {
            return Ok(Symbol::Split);
        }
        let span = node.l.0.abs_diff(node.r.0).max(node.l.1.abs_diff(node.r.1));
        if !node.is_cell() && self.next() < self.split + 0.05 * f64::from(span.ilog2()) {
            return Ok(Symbol::Split);
        }
        Ok(if self.next() < self.skip {
            Symbol::Skip
        } else {
            Symbol::Emit
        })
    }
    fn emit(&mut self, corners: [Pt; 3]) -> Result<(), ()> {
        self.corners.push(corners);
        Ok(())
    }
}

fn random_mesh(f: &Forest, seed: u64, split: f64, skip: f64) -> Vec<[Pt; 3]> {
    let mut r = Random {
        state: seed | 1,
        split,
        skip,
        corners: Vec::new(),
    };
    f.walk(&mut r).unwrap();
    r.corners
}

fn camera(width: u32, height: u32) -> Camera {
    Camera {
        width,
        height,
        projection: Projection::Perspective {
            fx: 100.0,
            fy: 100.0,
            cx: f64::from(width) / 2.0,
            cy: f64::from(height) / 2.0,
        },
        pose: Pose::default(),
    }
}

fn input<'a>(
    f: Forest,
    ij: &'a [(u16, u16)],
    depths: &'a [f32],
    triangles: &'a [[u32; 3]],
    raw: Option<RawGrid>,
) -> MeshInput<'a> {
    MeshInput {
        scene: "s",
        view: "v",
        lod: Lod::Epsilon(0.01),
        camera: camera(f.gw(), f.gh()),
        extract_ms: 0.5,
        forest: f,
        ij,
        depths,
        triangles,
        cuts: &[],
        raw_grid: raw,
        reach: None,
        planes: None,
        etag: "\"x\"".into(),
    }
}

/// A smooth surface with a step, in metres, or on a millimetre lattice.
fn depth_at((x, y): Pt, lattice: bool) -> f32 {
    let z = 2.0 + 0.3 * (f64::from(x) * 0.21).sin() + 0.002 * f64::from(y) + if x > 9 { 1.5 } else { 0.0 };
    if lattice {
        ((z * 1000.0).round() / 1000.0) as f32
    } else {
        z as f32
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn decode_of_encode_is_the_mesh(
        side_log in 1u32..5, m in 1u32..4, n in 1u32..3, seed in any::<u64>(),
        split in 0.0f64..0.9, skip in 0.0f64..0.4, lattice in any::<bool>(), planes in 0u8..20,
    ) {
        let f = Forest { side: 1 << side_log, m, n };
        let corners = random_mesh(&f, seed, split, skip);
        let want = connectivity::assemble(&f, &corners);
        let ij: Vec<(u16, u16)> = want.vertices.iter().map(|&(x, y)| (x as u16, y as u16)).collect();
        let depths: Vec<f32> = want.vertices.iter().map(|&p| depth_at(p, lattice)).collect();
        let raw = lattice.then_some(RawGrid { scale: 0.001, offset: 0.0 });
        let mut inp = input(f, &ij, &depths, &want.triangles, raw);
        inp.planes = Some(planes);
        let stream = encode(inp).unwrap();
        // Through bincode, as it travels.
        let bytes = crate::to_bincode(&MeshBody::Mesh(Box::new(stream.clone()))).unwrap();
        let MeshBody::Mesh(back) = crate::from_bincode::<MeshBody>(&bytes).unwrap() else { panic!("not a mesh") };
        let got = back.decode().unwrap();
        prop_assert_eq!(&got.shape, &want);
        let bound = got.max_error;
        for (a, b) in got.depths.iter().zip(&depths) {
            prop_assert!(a.is_finite() && *a > 0.0);
            prop_assert!((a - b).abs() <= bound, "{} vs {} beyond {}", a, b, bound);
        }
        // All planes: lossless on the lattice, within f32 rounding otherwise.
        let full = {
            let mut i = input(f, &ij, &depths, &want.triangles, raw);
            i.planes = None;
            encode(i).unwrap().decode().unwrap()
        };
        if lattice {
            prop_assert_eq!(&full.depths, &depths);
        } else {
            for (a, b) in full.depths.iter().zip(&depths) {
                prop_assert!((a - b).abs() <= 1e-5 * b.abs(), "{} vs {}", a, b);
            }
        }
        // The first b planes of the full stream are the b-plane stream.
        let all = { let mut i = input(f, &ij, &depths, &want.triangles, raw); i.planes = None; encode(i).unwrap() };
        let mut cut = all.clone();
        cut.planes.truncate(usize::from(planes));
        prop_assert_eq!(cut.decode().unwrap().depths, got.depths);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A change applied to the held mesh decodes to exactly what the whole
    /// new mesh decodes to, reusing the held depths when both are complete.
    #[test]
    fn changes_applied_to_the_held_mesh_are_the_new_mesh(
        side_log in 1u32..5, m in 1u32..4, n in 1u32..3, seeds in any::<(u64, u64)>(), same_seed in any::<bool>(),
        split in (0.0f64..0.9, 0.0f64..0.9), skip in (0.0f64..0.3, 0.0f64..0.3), lattice in any::<bool>(),
        planes in (proptest::option::of(0u8..20), proptest::option::of(0u8..20)),
    ) {
        let f = Forest { side: 1 << side_log, m, n };
        let raw = lattice.then_some(RawGrid { scale: 0.001, offset: 0.0 });
        let mesh = |seed: u64, split: f64, skip: f64| {
            let shape = connectivity::assemble(&f, &random_mesh(&f, seed, split, skip));
            let ij: Vec<(u16, u16)> = shape.vertices.iter().map(|&(x, y)| (x as u16, y as u16)).collect();
            let depths: Vec<f32> = shape.vertices.iter().map(|&p| depth_at(p, lattice)).collect();
            (shape, ij, depths)
        };
        let (h, h_ij, h_depths) = mesh(seeds.0, split.0, skip.0);
        let (want, ij, depths) = mesh(if same_seed { seeds.0 } else { seeds.1 }, split.1, skip.1);
        let mut held_input = input(f, &h_ij, &h_depths, &h.triangles, raw);
        held_input.planes = planes.0;
        let held = encode(held_input).unwrap().decode().unwrap();
        let whole = |planes: Option<u8>| {
            let mut i = input(f, &ij, &depths, &want.triangles, raw);
            i.planes = planes;
            i
        };
        let change = encode_change(whole(planes.1), &held).unwrap();
        // Through bincode, as it travels.
        let bytes = crate::to_bincode(&MeshBody::Change(Box::new(change.clone()))).unwrap();
        let MeshBody::Change(back) = crate::from_bincode::<MeshBody>(&bytes).unwrap() else { panic!("not a change") };
        let got = back.apply(&held).unwrap();
        let single = encode(whole(planes.1)).unwrap().decode().unwrap();
        prop_assert_eq!(&got.shape, &want);
        // The same mesh; only the count of planes the change itself carried differs.
        prop_assert_eq!(&got, &DecodedMesh { planes: got.planes, ..single.clone() });
        prop_assert_eq!(change.reuses_depths, held.complete && planes.1.is_none() && held.lattice == single.lattice);
    }
}

#[test]
fn a_refinement_costs_about_its_new_vertices() {
    // A coarse mesh refined: the change's bytes against the whole fine mesh.
    let f = Forest { side: 32, m: 2, n: 2 };
    let fine = connectivity::assemble(&f, &random_mesh(&f, 11, 0.6, 0.0));
    let ij: Vec<(u16, u16)> = fine.vertices.iter().map(|&(x, y)| (x as u16, y as u16)).collect();
    let depths: Vec<f32> = fine.vertices.iter().map(|&p| depth_at(p, true)).collect();
    let raw = Some(RawGrid {
        scale: 0.001,
        offset: 0.0,
    });
    let whole = encode(input(f, &ij, &depths, &fine.triangles, raw)).unwrap();
    let same = encode_change(input(f, &ij, &depths, &fine.triangles, raw), &whole.decode().unwrap()).unwrap();
    let size = |b: MeshBody| crate::to_bincode(&b).unwrap().len();
    let (whole_bytes, same_bytes) = (
        size(MeshBody::Mesh(Box::new(whole))),
        size(MeshBody::Change(Box::new(same.clone()))),
    );
    assert!(same.reuses_depths);
    // Every bit predicted: zero bytes, and no depths.
    assert!(same
        .mesh
        .connectivity
        .split
        .iter()
        .chain(&same.mesh.connectivity.leaf)
        .all(|&b| b == 0));
    assert!(same.mesh.exact.is_empty() && same.mesh.planes.iter().all(|p| p.is_empty()));
    assert!(same_bytes * 2 < whole_bytes, "{same_bytes} of {whole_bytes}");
}

#[test]
fn errors_shrink_as_planes_arrive() {
    let f = Forest { side: 16, m: 2, n: 1 };
    let corners = random_mesh(&f, 7, 0.7, 0.0);
    let shape = connectivity::assemble(&f, &corners);
    let ij: Vec<(u16, u16)> = shape.vertices.iter().map(|&(x, y)| (x as u16, y as u16)).collect();
    let depths: Vec<f32> = shape
        .vertices
        .iter()
        .map(|&p| depth_at(p, false) + 0.01 * (p.1 % 3) as f32)
        .collect();
    let error = |planes: Option<u8>| {
        let mut i = input(f, &ij, &depths, &shape.triangles, None);
        i.planes = planes;
        let s = encode(i).unwrap();
        assert_eq!(s.decode().unwrap().max_error, s.max_error);
        (s.max_error, s.total_planes)
    };
    let (all, total) = error(None);
    assert!(total >= 15, "{total} planes");
    let (e0, e2, e10) = (error(Some(0)).0, error(Some(2)).0, error(Some(10)).0);
    assert!(e0 > 0.0);
    assert!(e10 < e2 / 64.0, "{e2} {e10}");
    assert!(all < 1e-5, "{all}");
}

#[test]
fn planes_extend_a_held_mesh_to_the_whole_one() {
    let f = Forest { side: 8, m: 1, n: 1 };
    let corners = random_mesh(&f, 3, 0.6, 0.1);
    let shape = connectivity::assemble(&f, &corners);
    let ij: Vec<(u16, u16)> = shape.vertices.iter().map(|&(x, y)| (x as u16, y as u16)).collect();
    let depths: Vec<f32> = shape.vertices.iter().map(|&p| depth_at(p, false)).collect();
    let all = encode(input(f, &ij, &depths, &shape.triangles, None)).unwrap();
    let mut held = all.clone();
    held.planes.truncate(4);
    held.etag = "\"four\"".into();
    let update = PlaneUpdate {
        version: COMPACT_VERSION,
        first: 4,
        planes: all.planes[4..].to_vec(),
        max_error: all.max_error,
    };
    let mut late = update.clone();
    late.first = 5;
    assert!(held.clone().apply(late, all.etag.clone()).is_err());
    let mut long = update.clone();
    long.planes.push(vec![0]);
    assert!(held.clone().apply(long, all.etag.clone()).is_err());
    held.apply(update, all.etag.clone()).unwrap();
    assert_eq!(held, all);
}

#[test]
fn meshes_that_are_no_walk_are_refused() {
    let f = Forest { side: 4, m: 1, n: 1 };
    let ij = [(0, 0), (4, 0), (0, 4), (1, 1)];
    let depths = [1.0f32; 4];
    // A triangle that is no bintree triangle.
    let bad = [[0, 1, 3]];
    assert!(encode(input(f, &ij, &depths, &bad, None)).is_err());
    // A root triangle drawn with a piece of itself.
    let ij = [(0, 0), (4, 0), (4, 4), (2, 2), (2, 0)];
    let overlap = [[0, 1, 2], [0, 3, 4]];
    let e = encode(input(f, &ij, &[1.0; 5], &overlap, None)).unwrap_err();
    assert!(e.0.contains("conform") || e.0.contains("not a triangle"), "{e}");
}

#[test]
fn garbage_fails_with_a_reason_never_a_panic() {
    let f = Forest { side: 8, m: 2, n: 1 };
    let corners = random_mesh(&f, 11, 0.5, 0.2);
    let shape = connectivity::assemble(&f, &corners);
    let ij: Vec<(u16, u16)> = shape.vertices.iter().map(|&(x, y)| (x as u16, y as u16)).collect();
    let depths: Vec<f32> = shape.vertices.iter().map(|&p| depth_at(p, false)).collect();
    let good = encode(input(f, &ij, &depths, &shape.triangles, None)).unwrap();
    let mut s = good.clone();
    s.triangles += 1;
    assert!(s.decode().is_err());
    let mut s = good.clone();
    s.connectivity.split.pop();
    assert!(s.decode().is_err());
    let mut s = good.clone();
    s.exact.push(0);
    assert!(s.decode().is_err());
    let mut s = good.clone();
    s.escapes.push(0);
    assert!(s.decode().is_err());
    let mut s = good.clone();
    s.root_side = 6;
    assert!(s.decode().is_err());
    let mut s = good.clone();
    s.levels[3].step = f32::NAN;
    assert!(s.decode().is_err());
    let mut s = good;
    s.roots_x = 1 << 20;
    assert!(s.decode().is_err());
}

#[test]
fn culled_spheres_stay_within_their_quantised_ones() {
    let spheres: Vec<[f64; 4]> = (0..100)
        .map(|k| {
            let t = f64::from(k);
            [t.sin() * 3.0, t * 0.01, 2.0 + t.cos(), 0.05 + 0.001 * t]
        })
        .collect();
    let r = reach::compact_reach(&spheres, Some(1.5));
    assert!(r.culled.len() <= MAX_COMPACT_CULLED);
    let stream_culled = MeshStream {
        reach: Some(r),
        ..encode(input(Forest { side: 2, m: 1, n: 1 }, &[], &[], &[], None)).unwrap()
    }
    .culled();
    for s in &spheres {
        let held = stream_culled.iter().any(|c| {
            let d = ((c[0] - s[0]).powi(2) + (c[1] - s[1]).powi(2) + (c[2] - s[2]).powi(2)).sqrt();
            d + s[3] <= c[3]
        });
        assert!(held, "{s:?} is in no decoded sphere");
    }
}
