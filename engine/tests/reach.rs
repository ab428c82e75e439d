//! The reach of a view-dependent mesh (`engine/src/mesh/reach.rs`): every sample a
//! mesh does not cover lies in one of its culled spheres, and a camera moved
//! by less than the clearance, at the tolerance times the stated error
//! factor, selects no vertex outside those spheres that the mesh lacks.

mod common;

use std::collections::HashSet;

use common::*;
use dmesh_engine::camera::{Camera, Projection};
use dmesh_engine::mesh::{Hierarchy, Lod, Mesh, Segmentation};
use glam::{DQuat, DVec3};
use proptest::prelude::*;

fn view(eye: DVec3, yaw: f64, pitch: f64) -> Camera {
    let projection = Projection::Perspective {
        fx: 60.0,
        fy: 60.0,
        cx: 31.5,
        cy: 23.5,
    };
    Camera::new(
        64,
        48,
        projection,
        DQuat::from_rotation_y(yaw) * DQuat::from_rotation_x(pitch),
        eye,
    )
    .unwrap()
}

fn in_culled(mesh: &Mesh, p: DVec3) -> bool {
    let reach = mesh.reach.as_ref().expect("a view-dependent mesh has a reach");
    reach
        .culled
        .iter()
        .any(|&[x, y, z, r]| (p - DVec3::new(x, y, z)).length() <= r * (1.0 + 1e-9))
}

/// Grid samples inside or on one of the mesh's triangles.
fn covered(mesh: &Mesh, w: u32, h: u32) -> Vec<bool> {
    let mut out = vec![false; (w * h) as usize];
    for t in &mesh.triangles {
        let p = t.map(|v| ij(mesh, v));
        let area = cross(p[0], p[1], p[2]);
        let ((x0, x1), (y0, y1)) = bounds(&p);
        for y in y0.max(0)..=y1.min(i64::from(h) - 1) {
            for x in x0.max(0)..=x1.min(i64::from(w) - 1) {
                let s = [
                    cross(p[1], p[2], (x, y)),
                    cross(p[2], p[0], (x, y)),
                    cross(p[0], p[1], (x, y)),
                ];
                if s.iter().all(|&v| v * area.signum() >= 0) {
                    out[(y * i64::from(w) + x) as usize] = true;
                }
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn every_uncovered_sample_lies_in_a_culled_sphere(
        eye in (-1.5f64..1.5, -1.0f64..1.0, -2.0f64..1.0),
        yaw in -0.9f64..0.9,
        pitch in -0.5f64..0.5,
        tau in 0.0f64..4.0,
    ) {
        let (w, h) = (65, 49);
        let depth = waves(w, h);
        let hier = Hierarchy::build(&depth, &camera(w, h), &Segmentation::default()).unwrap();
        let cam = view(DVec3::new(eye.0, eye.1, eye.2), yaw, pitch);
        let mesh = hier.extract(Lod::Tau { tau, view: &cam }).unwrap();
        prop_assert!(mesh.reach.as_ref().unwrap().covers(&cam), "a mesh covers its own camera");
        prop_assume!(mesh.dropped_triangles == 0);
        let cov = covered(&mesh, w, h);
        for y in 0..h {
            for x in 0..w {
                if !cov[(y * w + x) as usize] {
                    prop_assert!(in_culled(&mesh, hier.position((x, y))), "sample ({x}, {y}) is neither meshed nor in a culled sphere");
                }
            }
        }
    }

    #[test]
    fn a_camera_within_the_clearance_needs_no_vertex_the_mesh_lacks(
        eye in (-1.0f64..1.0, -0.5f64..0.5, -1.5f64..0.5),
        yaw in -0.5f64..0.5,
        tau in 0.3f64..4.0,
        step in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        along in 0.0f64..0.95,
        turn in -0.2f64..0.2,
    ) {
        let (w, h) = (65, 49);
        let depth = waves(w, h);
        let hier = Hierarchy::build(&depth, &camera(w, h), &Segmentation::default()).unwrap();
        let first = view(DVec3::new(eye.0, eye.1, eye.2), yaw, 0.0);
        let held = hier.extract(Lod::Tau { tau, view: &first }).unwrap();
        let reach = held.reach.clone().unwrap();
        let dir = DVec3::new(step.0, step.1, step.2);
        prop_assume!(dir.length() > 1e-3);
        let moved = match reach.clearance {
            Some(c) => first.translation + dir.normalize() * (c * along),
            None => first.translation + dir,
        };
        let next = view(moved, yaw + turn, 0.0);
        let factor = reach.error_factor(&next).expect("bounded within the clearance");
        prop_assert!(factor.is_finite() && factor >= 0.0);
        let fresh = hier.extract(Lod::Tau { tau: tau * factor * (1.0 + 1e-9), view: &next }).unwrap();
        let have: HashSet<(u16, u16)> = held.vertices.iter().map(|v| (v.i, v.j)).collect();
        for v in &fresh.vertices {
            let p = hier.position((u32::from(v.i), u32::from(v.j)));
            if !in_culled(&held, p) {
                prop_assert!(have.contains(&(v.i, v.j)), "vertex ({}, {}) needed at the moved camera is not held", v.i, v.j);
            }
        }
    }
}

#[test]
fn a_static_mesh_has_no_reach_and_a_view_dependent_one_states_its_camera() {
    let (w, h) = (129, 97);
    let hier = Hierarchy::build(&waves(w, h), &camera(w, h), &Segmentation::default()).unwrap();
    assert!(hier.extract(Lod::Epsilon(0.01)).unwrap().reach.is_none());
    let cam = view(DVec3::new(0.0, 0.0, -1.0), 0.5, 0.0);
    let mesh = hier.extract(Lod::Tau { tau: 1.0, view: &cam }).unwrap();
    let reach = mesh.reach.unwrap();
    assert_eq!(reach.view, cam);
    assert!(reach.clearance.is_some_and(|c| c > 0.0 && c.is_finite()));
    assert!(
        !reach.culled.is_empty(),
        "turned by 0.5 rad, part of the view is culled"
    );
    assert!(reach.covers(&cam));
    // Turned back, the camera looks at what was culled.
    assert!(!reach.covers(&view(DVec3::new(0.0, 0.0, -1.0), 0.0, 0.0)));
}
