//! Budgeted level of detail: a mesh chosen for `max_triangles` never has more,
//! static or view-dependent, perspective or orthographic, wherever the eye is;
//! and the chosen tolerance is not needlessly coarse on a plain view.

mod common;

use common::*;
use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Lod, Outlines, Segmentation, StripOrder};
use dmesh_proto::Lod as Chosen;
use glam::{DQuat, DVec3};
use proptest::prelude::*;

/// The budget resolved by the extraction itself; the tolerance it states.
fn extract_budgeted(h: &Hierarchy, max: u64, view: Option<&Camera>) -> (Chosen, usize) {
    let mesh = h
        .extract(Lod::Triangles {
            max: u32::try_from(max).unwrap(),
            view,
        })
        .unwrap();
    assert_conforming(&mesh);
    assert!(
        view.is_some() || matches!(mesh.lod, Chosen::Epsilon(_)),
        "a static budget answered with {:?}",
        mesh.lod
    );
    (mesh.lod, mesh.triangles.len())
}

#[test]
fn static_budgets_are_met_and_nearly_used() {
    let depth = waves(129, 97);
    let h = Hierarchy::build(&depth, &camera(129, 97), &Segmentation::default()).unwrap();
    let full = h.extract(Lod::Epsilon(0.0)).unwrap().triangles.len() as u64;
    for max in [24, 100, 1000, 5000, 20_000, full, 10 * full] {
        let (chosen, got) = extract_budgeted(&h, max, None);
        assert!(got as u64 <= max, "max {max}: {got} triangles with {chosen:?}");
        // The bound counts two triangles per selected vertex, which the
        // interior of a mesh reaches: at least a third of the budget is used.
        if max >= 100 && max <= full {
            assert!(got as u64 * 3 >= max, "max {max}: only {got} triangles with {chosen:?}");
        }
    }
    assert_eq!(extract_budgeted(&h, 10 * full, None).0, Chosen::Epsilon(0.0));
}

/// Doubled area in grid cells of a mesh's triangles.
fn area2(mesh: &dmesh_engine::mesh::Mesh) -> i64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| ij(mesh, v));
            ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).abs()
        })
        .sum()
}

/// A box in front of a wall, 129 x 97: its outline crosses coarse
/// triangles, so every refinement of it forces vertices. Its size, and its
/// hierarchy.
fn box_before_wall() -> (u32, u32, Hierarchy) {
    let (w, h) = (129, 97);
    let depth = depth_from(w, h, |x, y| {
        if (40..90).contains(&x) && (30..70).contains(&y) {
            1.0
        } else {
            3.0
        }
    });
    (
        w,
        h,
        Hierarchy::build(&depth, &camera(w, h), &Segmentation::default()).unwrap(),
    )
}

#[test]
fn a_budget_with_room_keeps_the_outlines_and_a_tight_one_still_fits() {
    let (w, h, hier) = box_before_wall();
    let unsegmented: i64 = (0..w - 1)
        .flat_map(|x| (0..h - 1).map(move |y| (x, y)))
        .map(|c| (0..2).filter(|&half| !hier.cell_segmented(c, half)).count() as i64)
        .sum();
    let outline = hier.coarsest_triangles_with_outlines(Outlines::Refined(1));
    assert!(outline > hier.coarsest_triangles(), "the outline forces vertices");
    let near_side = hier.coarsest_triangles_with_outlines(Outlines::NearSide(1));
    assert!(
        near_side < outline,
        "the wall's side is spared: {near_side} of {outline}"
    );
    // Room for twice the outline's coarsest mesh: every unsegmented cell is
    // covered, and the budget is met.
    for max in [2 * outline, 3 * outline, 20 * outline] {
        let mesh = hier
            .extract(Lod::Triangles {
                max: u32::try_from(max).unwrap(),
                view: None,
            })
            .unwrap();
        assert!(
            mesh.triangles.len() as u64 <= max,
            "max {max}: {}",
            mesh.triangles.len()
        );
        assert_eq!(area2(&mesh), unsegmented, "max {max}: outline eroded");
        assert_conforming(&mesh);
    }
    // Less room: a coarser refinement, or none, and the budget is still met,
    // down to the coarsest mesh; the outline erodes, as DMesh Sec. 5.3's does.
    let mut areas = Vec::new();
    for max in [outline, outline / 2, hier.coarsest_triangles()] {
        let mesh = hier
            .extract(Lod::Triangles {
                max: u32::try_from(max).unwrap(),
                view: None,
            })
            .unwrap();
        assert!(
            mesh.triangles.len() as u64 <= max,
            "max {max}: {}",
            mesh.triangles.len()
        );
        assert_conforming(&mesh);
        areas.push(area2(&mesh));
    }
    assert!(
        areas.windows(2).all(|a| a[0] >= a[1]) && areas[2] < unsegmented,
        "{areas:?}"
    );
    // At a coarse tolerance, refining the near side only keeps every cell
    // of the box, as refining both sides does, for fewer triangles; the
    // next coarser refinement of both sides erodes it.
    let box_area = |mesh: &dmesh_engine::mesh::Mesh| -> i64 {
        let inside = |v: u32| {
            let (x, y) = ij(mesh, v);
            (40..=89).contains(&x) && (30..=69).contains(&y)
        };
        mesh.triangles
            .iter()
            .filter(|t| t.iter().all(|&v| inside(v)))
            .map(|t| {
                let [a, b, c] = t.map(|v| ij(mesh, v));
                ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).abs()
            })
            .sum()
    };
    let box_cells: i64 = (40..89)
        .flat_map(|x| (30..69).map(move |y| (x, y)))
        .map(|c| (0..2).filter(|&half| !hier.cell_segmented(c, half)).count() as i64)
        .sum();
    let at = |outlines| {
        let mesh = hier
            .extract_as(Lod::Epsilon(10.0), StripOrder::Traversal, outlines)
            .unwrap();
        assert_conforming(&mesh);
        mesh
    };
    let (both, near, coarser) = (
        at(Outlines::Refined(1)),
        at(Outlines::NearSide(1)),
        at(Outlines::Refined(2)),
    );
    assert_eq!(box_area(&both), box_cells);
    assert_eq!(box_area(&near), box_cells, "the box's outline eroded");
    assert!(box_area(&coarser) < box_cells);
    assert!(near.triangles.len() < both.triangles.len());
    assert!(area2(&near) < area2(&both), "the wall beside the box is dropped");
    // Dropping outlines at the tolerance the budget chose loses area.
    let kept = hier.extract(Lod::Epsilon(0.05)).unwrap();
    let dropped = hier
        .extract_as(Lod::Epsilon(0.05), StripOrder::Traversal, Outlines::Dropped)
        .unwrap();
    assert_eq!(area2(&kept), unsegmented);
    assert!(area2(&dropped) < unsegmented && dropped.triangles.len() < kept.triangles.len());
}

#[test]
fn what_budgets_add_is_counted_in_the_bound_charged_up_front() {
    let (_, _, hier) = box_before_wall();
    let (built, bound) = (hier.heap_bytes(), hier.heap_bytes_bound());
    // A tolerance needs no statistics.
    hier.extract(Lod::Epsilon(0.01)).unwrap();
    let after_tolerance = hier.heap_bytes();
    // Every outline and its statistics, and the plain ones.
    let mut sizes = vec![];
    for finest in [1, 2, 4, 8, 16, 32] {
        for outlines in [Outlines::Refined(finest), Outlines::NearSide(finest)] {
            let max = 4 * hier.coarsest_triangles_with_outlines(outlines);
            hier.extract_as(
                Lod::Triangles {
                    max: u32::try_from(max).unwrap(),
                    view: None,
                },
                StripOrder::default(),
                outlines,
            )
            .unwrap();
            sizes.push(hier.heap_bytes());
        }
    }
    // The cutting errors and the cuts they fitted.
    let before_cut = hier.heap_bytes();
    hier.extract_as(Lod::Epsilon(0.01), StripOrder::default(), Outlines::Cut)
        .unwrap();
    assert!(hier.heap_bytes() > before_cut, "the cutting errors are added");
    let all = hier.heap_bytes();
    assert!(after_tolerance > built, "the outline a tolerance keeps is added");
    assert!(
        all > after_tolerance + 12 * 16_000,
        "each outline's statistics are added: {after_tolerance} -> {all}"
    );
    assert!(all <= bound, "{all} bytes kept, {bound} charged");
    assert_eq!(hier.heap_bytes_bound(), bound, "the bound is constant");
    assert!(sizes.windows(2).all(|w| w[0] <= w[1]));
}

#[test]
fn a_budget_below_the_coarsest_mesh_is_an_error() {
    let depth = waves(65, 65);
    let h = Hierarchy::build(&depth, &camera(65, 65), &Segmentation::default()).unwrap();
    let err = h.lod_for_triangles(1, None).unwrap_err().to_string();
    assert!(err.contains("max_triangles is 1"), "{err}");
}

#[test]
fn view_dependent_budgets_choose_tau_from_afar_and_epsilon_from_inside() {
    let depth = waves(129, 129);
    let cam = camera(129, 129);
    let h = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
    let far = Camera::new(128, 128, cam.projection, DQuat::IDENTITY, DVec3::new(0.2, 0.1, -3.0)).unwrap();
    let (chosen, got) = extract_budgeted(&h, 4000, Some(&far));
    assert!(matches!(chosen, Chosen::Tau(t) if t > 0.0), "{chosen:?}");
    assert!(got <= 4000);
    // An eye on the surface: no distance bound, so the static bound answers.
    let p = depth.z[64 * 129 + 64];
    let on = Camera::new(
        128,
        128,
        cam.projection,
        DQuat::IDENTITY,
        DVec3::new(0.0, 0.0, f64::from(p)),
    )
    .unwrap();
    let (chosen, got) = extract_budgeted(&h, 4000, Some(&on));
    assert!(matches!(chosen, Chosen::Epsilon(_)), "{chosen:?}");
    assert!(got <= 4000);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn budgets_are_never_exceeded(
        (w, h, z) in arb_depth(40),
        max in prop_oneof![2u64..50, 50u64..5000],
        eye in (-5.0f64..5.0, -5.0f64..5.0, -10.0f64..5.0),
        yaw in -3.2f64..3.2,
        ortho in any::<bool>(),
        with_view in any::<bool>(),
    ) {
        let depth = DepthImage::from_z(w, h, z).unwrap();
        let cam = camera(w, h);
        let hier = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
        let projection = if ortho {
            dmesh_engine::camera::Projection::Orthographic { sx: 0.01, sy: 0.01, cx: 32.0, cy: 24.0 }
        } else {
            cam.projection
        };
        let view = Camera::new(64, 48, projection, DQuat::from_rotation_y(yaw), DVec3::new(eye.0, eye.1, eye.2)).unwrap();
        let view = with_view.then_some(&view);
        match hier.lod_for_triangles(max, view) {
            Ok(_) => {
                let (chosen, got) = extract_budgeted(&hier, max, view);
                prop_assert!(got as u64 <= max, "max {}: {} triangles with {:?}", max, got, chosen);
            }
            Err(e) => {
                // Only when the coarsest mesh could exceed the budget.
                prop_assert!(e.to_string().contains("coarsest"), "{}", e);
                prop_assert!(max < hier.coarsest_triangles(), "{}", e);
            }
        }
    }
}
