//! Shared scenes and mesh checks for the engine's tests.
#![allow(dead_code)]

use std::collections::{HashMap, HashSet};

use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{decode_strips, Hierarchy, Mesh};
use proptest::prelude::*;

/// A grid point in signed coordinates.
type P = (i64, i64);

/// Twice the signed area of `a, b, c`.
pub fn cross(a: P, b: P, c: P) -> i64 {
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// The bounding box of `points`: `((x_min, x_max), (y_min, y_max))`.
pub fn bounds(points: &[P]) -> ((i64, i64), (i64, i64)) {
    let span = |f: fn(&P) -> i64| {
        let v = points.iter().map(f);
        (v.clone().min().unwrap_or(0), v.max().unwrap_or(0))
    };
    (span(|p| p.0), span(|p| p.1))
}

/// A perspective camera with a 60-degree-ish field of view, principal point at the centre.
pub fn camera(w: u32, h: u32) -> Camera {
    let f = f64::from(w.max(h));
    Camera::perspective(w, h, f, f, f64::from(w - 1) / 2.0, f64::from(h - 1) / 2.0).unwrap()
}

/// Depth from a closure over pixel coordinates.
pub fn depth_from(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> DepthImage {
    let z = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect();
    DepthImage::from_z(w, h, z).unwrap()
}

/// A smooth wavy surface at 2-3 m.
pub fn waves(w: u32, h: u32) -> DepthImage {
    depth_from(w, h, |x, y| {
        let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
        2.5 + 0.3 * (6.0 * u).sin() * (4.0 * v).cos() + 0.1 * (17.0 * u + 3.0 * v).sin()
    })
}

/// A step: 1 m on the left half, 2 m on the right.
pub fn step(w: u32, h: u32) -> DepthImage {
    depth_from(w, h, |x, _| if x < w / 2 { 1.0 } else { 2.0 })
}

/// Grid coordinates of a mesh vertex.
pub fn ij(mesh: &Mesh, v: u32) -> (i64, i64) {
    let v = &mesh.vertices[v as usize];
    (i64::from(v.i), i64::from(v.j))
}

fn canon(mut t: [u32; 3]) -> [u32; 3] {
    t.sort_unstable();
    t
}

/// The strips decode to exactly the triangle list (as unordered triangles).
pub fn assert_strips_match(mesh: &Mesh) {
    let mut a: Vec<_> = decode_strips(&mesh.strips).into_iter().map(canon).collect();
    let mut b: Vec<_> = mesh.triangles.iter().copied().map(canon).collect();
    a.sort_unstable();
    b.sort_unstable();
    assert_eq!(a, b, "strips and triangle list differ");
}

/// Everything in the mesh is finite, positive where it must be, inside the image.
pub fn assert_finite(mesh: &Mesh, w: u32, h: u32) {
    for v in &mesh.vertices {
        assert!(v.depth.is_finite() && v.depth > 0.0, "vertex depth {}", v.depth);
        assert!(
            u32::from(v.i) < w && u32::from(v.j) < h,
            "vertex ({}, {}) outside {w}x{h}",
            v.i,
            v.j
        );
        let n = dmesh_engine::mesh::normals::oct_decode(v.normal);
        assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-6);
    }
    for t in &mesh.triangles {
        assert!(t.iter().all(|&i| (i as usize) < mesh.vertices.len()));
    }
}

fn twice_area(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> i64 {
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// Conforming triangulation: non-degenerate, consistently wound, no two
/// triangles overlap, no vertex inside another triangle's edge (no
/// T-junction), every edge used at most twice, and an edge used once has
/// nothing covered on its other side.
pub fn assert_conforming(mesh: &Mesh) {
    let tris: Vec<[(i64, i64); 3]> = mesh.triangles.iter().map(|t| t.map(|v| ij(mesh, v))).collect();
    let used: HashSet<(i64, i64)> = tris.iter().flatten().copied().collect();
    let mut edges: HashMap<(P, P), u32> = HashMap::new();
    // Coverage of points at 1/6 pixel resolution: centroids of the finest triangles.
    let mut covered: HashMap<(i64, i64), u32> = HashMap::new();
    for t in &tris {
        let a2 = twice_area(t[0], t[1], t[2]);
        assert!(a2 < 0, "triangle {t:?} is degenerate or wound the wrong way");
        for k in 0..3 {
            let (p, q) = (t[k], t[(k + 1) % 3]);
            let key = if p < q { (p, q) } else { (q, p) };
            *edges.entry(key).or_default() += 1;
            // Lattice points strictly inside the edge must not be vertices.
            let (dx, dy) = (q.0 - p.0, q.1 - p.1);
            let g = gcd(dx.abs(), dy.abs());
            for s in 1..g {
                let r = (p.0 + dx / g * s, p.1 + dy / g * s);
                assert!(!used.contains(&r), "T-junction: vertex {r:?} inside edge {p:?}-{q:?}");
            }
        }
        let ((x0, x1), (y0, y1)) = bounds(t);
        for cy in y0..y1 {
            for cx in x0..x1 {
                // Four sample points per cell, one inside each quarter triangle,
                // in sixths of a pixel so they never fall on an edge.
                for (ox, oy) in [(3, 1), (5, 3), (3, 5), (1, 3)] {
                    let p6 = (cx * 6 + ox, cy * 6 + oy);
                    if contains6(*t, p6) {
                        *covered.entry(p6).or_default() += 1;
                    }
                }
            }
        }
    }
    assert!(covered.values().all(|&c| c == 1), "overlapping triangles");
    for (&(p, q), &n) in &edges {
        assert!(n <= 2, "edge {p:?}-{q:?} used {n} times");
        if n == 1 {
            // Points just across the midpoint on either side: at most one side covered.
            let (mx6, my6) = ((p.0 + q.0) * 3, (p.1 + q.1) * 3);
            let (nx, ny) = (-(q.1 - p.1).signum(), (q.0 - p.0).signum());
            let probe = |s: i64| {
                tris.iter()
                    .filter(|t| contains6(**t, (mx6 + s * nx, my6 + s * ny)))
                    .count()
            };
            assert!(
                probe(1) + probe(-1) == 1,
                "edge {p:?}-{q:?} is used once but covered on both sides"
            );
        }
    }
}

fn contains6(t: [(i64, i64); 3], p6: (i64, i64)) -> bool {
    let s =
        |a: (i64, i64), b: (i64, i64)| (6 * b.0 - 6 * a.0) * (p6.1 - 6 * a.1) - (6 * b.1 - 6 * a.1) * (p6.0 - 6 * a.0);
    let (d0, d1, d2) = (s(t[0], t[1]), s(t[1], t[2]), s(t[2], t[0]));
    (d0 > 0 && d1 > 0 && d2 > 0) || (d0 < 0 && d1 < 0 && d2 < 0)
}

fn gcd(a: i64, b: i64) -> i64 {
    if b == 0 {
        a.max(1)
    } else {
        gcd(b, a % b)
    }
}

/// The static bound: every sample inside or on an emitted triangle is valid,
/// unsegmented, and within `eps` of the affine interpolation of the corner depths.
pub fn assert_epsilon_bound(mesh: &Mesh, depth: &DepthImage, eps: f64) {
    let w = depth.width as i64;
    for t in &mesh.triangles {
        let c = t.map(|v| ij(mesh, v));
        let z = t.map(|v| f64::from(mesh.vertices[v as usize].depth));
        let a2 = twice_area(c[0], c[1], c[2]) as f64;
        let (x0, x1) = (
            c.iter().map(|p| p.0).min().unwrap(),
            c.iter().map(|p| p.0).max().unwrap(),
        );
        let (y0, y1) = (
            c.iter().map(|p| p.1).min().unwrap(),
            c.iter().map(|p| p.1).max().unwrap(),
        );
        for y in y0..=y1 {
            for x in x0..=x1 {
                let p = (x, y);
                let b0 = twice_area(p, c[1], c[2]) as f64 / a2;
                let b1 = twice_area(c[0], p, c[2]) as f64 / a2;
                let b2 = twice_area(c[0], c[1], p) as f64 / a2;
                if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                    continue;
                }
                let zs = f64::from(depth.z[(y * w + x) as usize]);
                assert!(zs > 0.0, "invalid sample ({x}, {y}) under an emitted triangle");
                let lin = b0 * z[0] + b1 * z[1] + b2 * z[2];
                let dev = (zs - lin).abs();
                assert!(
                    dev <= eps * (1.0 + 1e-5) + zs * 1e-6,
                    "sample ({x}, {y}) deviates {dev} > epsilon {eps}"
                );
            }
        }
    }
}

/// Saturation and nesting: every vertex's error is at least each child's,
/// and its sphere contains each child's.
pub fn assert_monotone(h: &Hierarchy) {
    let g = *h.grid();
    for y in 0..g.gh() {
        for x in 0..g.gw() {
            let Some(d) = g.diamond((x, y)) else { continue };
            for apex in d.apex {
                if !g.contains(apex.0, apex.1) {
                    continue;
                }
                for end in [d.a, d.b] {
                    let (cx, cy) = ((apex.0 + end.0) / 2, (apex.1 + end.1) / 2);
                    if (apex.0 + end.0) % 2 != 0 || (apex.1 + end.1) % 2 != 0 {
                        continue; // leaf children have no vertex
                    }
                    let c = (cx as u32, cy as u32);
                    assert!(h.error((x, y)) >= h.error(c), "error of ({x},{y}) below child {c:?}");
                    let gap = (h.position((x, y)) - h.position(c)).length() + f64::from(h.radius(c));
                    assert!(
                        f64::from(h.radius((x, y))) >= gap * (1.0 - 1e-6),
                        "sphere of ({x},{y}) misses child {c:?}"
                    );
                }
            }
        }
    }
}

/// Random depth images up to `max_side - 1` samples a side: mostly smooth
/// values, with invalid samples (0 and NaN) and a far layer mixed in.
pub fn arb_depth(max_side: u32) -> impl Strategy<Value = (u32, u32, Vec<f32>)> {
    (2u32..max_side, 2u32..max_side).prop_flat_map(|(w, h)| {
        let n = (w * h) as usize;
        let sample = prop_oneof![
            6 => 0.5f32..4.0,
            1 => Just(0.0f32),
            1 => Just(f32::NAN),
            1 => 100.0f32..200.0,
        ];
        (Just(w), Just(h), proptest::collection::vec(sample, n))
    })
}

/// The triangles tile the image rectangle `[0, w-1] x [0, h-1]` exactly:
/// every vertex in it, their areas adding up to its area, every edge used
/// twice except those on its boundary, used once (with `assert_conforming`,
/// no overlap and no T-junction: the union is the rectangle).
pub fn assert_covers_image(mesh: &Mesh, w: u32, h: u32) {
    let (lx, ly) = (i64::from(w) - 1, i64::from(h) - 1);
    let tris: Vec<[(i64, i64); 3]> = mesh.triangles.iter().map(|t| t.map(|v| ij(mesh, v))).collect();
    let mut area2 = 0;
    let mut edges: HashMap<(P, P), u32> = HashMap::new();
    for t in &tris {
        for p in t {
            assert!(
                p.0 >= 0 && p.1 >= 0 && p.0 <= lx && p.1 <= ly,
                "vertex {p:?} outside the {w}x{h} image"
            );
        }
        area2 += twice_area(t[0], t[1], t[2]).abs();
        for k in 0..3 {
            let (p, q) = (t[k], t[(k + 1) % 3]);
            *edges.entry(if p < q { (p, q) } else { (q, p) }).or_default() += 1;
        }
    }
    assert_eq!(area2, 2 * lx * ly, "the triangles do not cover the {w}x{h} image");
    for (&(p, q), &n) in &edges {
        let on_boundary = (p.0 == q.0 && (p.0 == 0 || p.0 == lx)) || (p.1 == q.1 && (p.1 == 0 || p.1 == ly));
        assert_eq!(
            n,
            if on_boundary { 1 } else { 2 },
            "edge {p:?}-{q:?} of the {w}x{h} image"
        );
    }
}
