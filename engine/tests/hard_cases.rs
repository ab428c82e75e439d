//! Degenerate geometry stays numerically stable: every case builds, extracts
//! at static and view-dependent tolerances from awkward viewpoints, and no
//! NaN or infinity appears in the hierarchy or in any output.

mod common;

use common::*;
use dmesh_engine::camera::{Camera, Projection};
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Lod, Method, Segmentation, StripOrder};
use glam::{DQuat, DVec3};

const W: u32 = 33;
const H: u32 = 17;

fn views(reference: &Camera, on_vertex: DVec3) -> Vec<Camera> {
    let p = Projection::Perspective {
        fx: 40.0,
        fy: 40.0,
        cx: 31.5,
        cy: 23.5,
    };
    let pose = |q: DQuat, t: DVec3| Camera::new(64, 48, p, q, t).unwrap();
    vec![
        *reference,
        pose(DQuat::IDENTITY, on_vertex),                  // eye exactly on a vertex
        pose(DQuat::IDENTITY, DVec3::new(0.0, 0.0, -5.0)), // behind the reference camera
        pose(DQuat::from_rotation_y(std::f64::consts::PI), DVec3::new(0.0, 0.0, -5.0)), // behind, looking back
        pose(DQuat::from_rotation_x(1.2), DVec3::new(0.3, -2.0, 1.0)), // steep, from above
        Camera::new(
            64,
            48,
            Projection::Perspective {
                fx: 1e-3,
                fy: 1e-3,
                cx: 31.5,
                cy: 23.5,
            },
            DQuat::IDENTITY,
            DVec3::ZERO,
        )
        .unwrap(),
        Camera::new(
            64,
            48,
            Projection::Perspective {
                fx: 1e7,
                fy: 1e7,
                cx: 31.5,
                cy: 23.5,
            },
            DQuat::IDENTITY,
            DVec3::ZERO,
        )
        .unwrap(),
        Camera::new(
            64,
            48,
            Projection::Orthographic {
                sx: 1e-6,
                sy: 1e-6,
                cx: 31.5,
                cy: 23.5,
            },
            DQuat::IDENTITY,
            DVec3::new(0.0, 0.0, -1.0),
        )
        .unwrap(),
    ]
}

fn check(name: &str, depth: &DepthImage, cam: &Camera) {
    for seg in [
        Segmentation::default(),
        Segmentation {
            method: Method::Connectedness { kappa: 1.0 },
            lambda: 0.0,
        },
        Segmentation {
            method: Method::Disparity { sigma: 0.05 },
            lambda: 0.0,
        },
        Segmentation {
            method: Method::None,
            lambda: 0.0,
        },
    ] {
        let h = Hierarchy::build(depth, cam, &seg).unwrap_or_else(|e| panic!("{name}: build failed: {e}"));
        let g = *h.grid();
        for y in 0..g.gh() {
            for x in 0..g.gw() {
                assert!(
                    h.error((x, y)).is_finite(),
                    "{name}: error at ({x},{y}) is {}",
                    h.error((x, y))
                );
                assert!(h.radius((x, y)).is_finite(), "{name}: radius at ({x},{y})");
                assert!(h.position((x, y)).is_finite(), "{name}: position at ({x},{y})");
            }
        }
        assert_monotone(&h);
        for eps in [0.0, 1e-9, 1e-3, 1.0, 1e12] {
            let m = h.extract(Lod::Epsilon(eps)).unwrap();
            assert_finite(&m, W, H);
            assert_conforming(&m);
            assert_strips_match(&m);
            assert_epsilon_bound(&m, depth, eps);
            for order in [StripOrder::Greedy, StripOrder::Tunnelled] {
                let o = h.extract_with(Lod::Epsilon(eps), order).unwrap();
                assert_eq!(o.triangles, m.triangles, "{name}: {order:?}");
                assert_strips_match(&o);
            }
        }
        // A vertex that exists in every mesh: the first valid sample.
        let first = depth.z.iter().position(|&z| z > 0.0).map_or(DVec3::ZERO, |i| {
            let (u, v) = ((i as u32 % W) as f64, (i as u32 / W) as f64);
            cam.to_world(cam.back_project(u, v, f64::from(depth.z[i])))
        });
        for view in views(cam, first) {
            for tau in [0.0, 0.25, 1.0, 1e6] {
                let m = h
                    .extract(Lod::Tau { tau, view: &view })
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
                assert_finite(&m, W, H);
                assert_conforming(&m);
                assert_strips_match(&m);
            }
            // Budgets resolve to a usable tolerance and are met.
            for max in [h.coarsest_triangles(), 100, 10_000] {
                let max = max.max(h.coarsest_triangles());
                let m = h
                    .extract(Lod::Triangles {
                        max: u32::try_from(max).unwrap(),
                        view: Some(&view),
                    })
                    .unwrap_or_else(|e| panic!("{name}: budget {max}: {e}"));
                assert!(m.triangles.len() as u64 <= max, "{name}: budget {max}");
                assert_finite(&m, W, H);
            }
        }
    }
}

fn perspective() -> Camera {
    Camera::perspective(W, H, 30.0, 30.0, 16.0, 8.0).unwrap()
}

#[test]
fn grazing_plane_at_89_9_degrees() {
    let cam = perspective();
    // Plane whose normal is 89.9 degrees from the optical axis.
    let a = 0.1f64.to_radians();
    let n = DVec3::new(a.cos(), 0.0, a.sin());
    let depth = depth_from(W, H, |x, y| {
        let r = DVec3::new((f64::from(x) - 16.0) / 30.0, (f64::from(y) - 8.0) / 30.0, 1.0);
        (0.5 / n.dot(r)) as f32
    });
    check("grazing perspective", &depth, &cam);
    let ortho = Camera::orthographic(W, H, 0.01, 0.01, 0.0, 0.0).unwrap();
    let slope = 89.9f64.to_radians().tan() * 0.01;
    check(
        "grazing height field",
        &depth_from(W, H, |x, _| (1.0 + slope * f64::from(x)) as f32),
        &ortho,
    );
}

#[test]
fn depth_from_1e_minus_4_to_1e6_in_one_image() {
    let depth = depth_from(W, H, |x, y| {
        10f64.powf(-4.0 + 10.0 * f64::from((x * 7 + y * 13) % 23) / 22.0) as f32
    });
    check("huge range", &depth, &perspective());
    let smooth = depth_from(W, H, |x, _| {
        10f64.powf(-4.0 + 10.0 * f64::from(x) / f64::from(W - 1)) as f32
    });
    check("huge smooth range", &smooth, &perspective());
}

#[test]
fn constant_depth() {
    check("constant", &depth_from(W, H, |_, _| 3.0), &perspective());
}

#[test]
fn a_single_valid_sample_and_none_at_all() {
    let one = depth_from(W, H, |x, y| if (x, y) == (5, 5) { 2.0 } else { 0.0 });
    check("single", &one, &perspective());
    let h = Hierarchy::build(&one, &perspective(), &Segmentation::default()).unwrap();
    assert!(h.extract(Lod::Epsilon(0.0)).unwrap().triangles.is_empty());
    let none = DepthImage::from_z(W, H, vec![f32::NAN; (W * H) as usize]).unwrap();
    check("all invalid", &none, &perspective());
}

#[test]
fn checkerboards_of_invalid_samples() {
    check(
        "checker 1",
        &depth_from(W, H, |x, y| if (x + y) % 2 == 0 { 2.0 } else { 0.0 }),
        &perspective(),
    );
    check(
        "checker 4",
        &depth_from(W, H, |x, y| {
            if (x / 4 + y / 4) % 2 == 0 {
                2.0 + x as f32 * 0.01
            } else {
                f32::INFINITY
            }
        }),
        &perspective(),
    );
}

#[test]
fn zero_length_edges() {
    // Pixel footprints so small that neighbouring samples coincide in x and y.
    let cam = Camera::orthographic(W, H, 1e-290, 1e-290, 0.0, 0.0).unwrap();
    check(
        "coincident footprints",
        &depth_from(W, H, |x, y| 1.0 + ((x * y) % 3) as f32),
        &cam,
    );
    check("coincident constant", &depth_from(W, H, |_, _| 1.0), &cam);
}

#[test]
fn tiny_and_huge_focal_lengths() {
    let wavy = depth_from(W, H, |x, y| {
        2.0 + ((x as f32) * 0.7).sin() * 0.3 + (y as f32 * 0.2).cos()
    });
    check(
        "tiny focal",
        &wavy,
        &Camera::perspective(W, H, 1e-3, 1e-3, 16.0, 8.0).unwrap(),
    );
    check(
        "huge focal",
        &wavy,
        &Camera::perspective(W, H, 1e7, 1e7, 16.0, 8.0).unwrap(),
    );
    check(
        "tiny focal, huge depth",
        &depth_from(W, H, |x, _| 1e6 + x as f32 * 1e4),
        &Camera::perspective(W, H, 1e-3, 1e-3, 16.0, 8.0).unwrap(),
    );
}
