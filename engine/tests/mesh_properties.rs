//! Invariants of the engine: conforming meshes, strips equal to the triangle
//! list, the static epsilon bound over every sample, monotone errors, full
//! resolution at tau = 0, segmentation of step edges, odd sizes.

mod common;

use common::*;
use dmesh_engine::camera::Camera;
use dmesh_engine::image::DepthImage;
use dmesh_engine::mesh::{Hierarchy, Lod, Method, Outlines, Segmentation, StripOrder, Threads};
use proptest::prelude::*;

fn check_all(depth: &DepthImage, cam: &Camera, seg: &Segmentation, eps: f64) {
    let h = Hierarchy::build(depth, cam, seg).unwrap();
    let mesh = h.extract(Lod::Epsilon(eps)).unwrap();
    assert_finite(&mesh, depth.width, depth.height);
    assert_conforming(&mesh);
    assert_strips_match(&mesh);
    assert_epsilon_bound(&mesh, depth, eps);
    for order in [StripOrder::Greedy, StripOrder::Tunnelled] {
        let other = h.extract_with(Lod::Epsilon(eps), order).unwrap();
        assert_eq!(other.triangles, mesh.triangles);
        assert_strips_match(&other);
    }
}

#[test]
fn smooth_surface_at_several_tolerances() {
    let depth = waves(65, 49);
    let cam = camera(65, 49);
    let h = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
    assert_monotone(&h);
    let mut last = usize::MAX;
    for eps in [0.0, 1e-4, 1e-3, 1e-2, 0.1, 1.0] {
        let mesh = h.extract(Lod::Epsilon(eps)).unwrap();
        assert_conforming(&mesh);
        assert_strips_match(&mesh);
        let greedy = h.extract_with(Lod::Epsilon(eps), StripOrder::Greedy).unwrap();
        assert_strips_match(&greedy);
        let tunnelled = h.extract_with(Lod::Epsilon(eps), StripOrder::Tunnelled).unwrap();
        assert_strips_match(&tunnelled);
        if eps < 0.1 {
            assert!(
                greedy.strips.len() < mesh.strips.len(),
                "greedy strips should be shorter at {eps}"
            );
            assert!(
                tunnelled.strips.len() < greedy.strips.len(),
                "tunnelled strips should be shorter at {eps}"
            );
        }
        assert_epsilon_bound(&mesh, &depth, eps);
        assert!(mesh.triangles.len() <= last, "coarser tolerance gave more triangles");
        last = mesh.triangles.len();
    }
    assert!(last < 100, "a 1 m tolerance should leave a coarse mesh, got {last}");
}

#[test]
fn odd_sizes_work() {
    for (w, h) in [(2, 2), (3, 7), (7, 3), (640, 480), (1390, 1110)] {
        let depth = waves(w, h);
        let cam = camera(w, h);
        let eps = if w * h > 100_000 { 0.01 } else { 0.001 };
        let hier = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
        let mesh = hier.extract(Lod::Epsilon(eps)).unwrap();
        assert!(!mesh.triangles.is_empty(), "{w}x{h} gave no triangles");
        assert_finite(&mesh, w, h);
        assert_strips_match(&mesh);
        if w * h <= 400_000 {
            assert_conforming(&mesh);
        }
        assert_epsilon_bound(&mesh, &depth, eps);
    }
}

/// The build counts the valid samples as the image does (a service reports
/// the build's count and no longer scans the image for it), holes and
/// values that are not depths included, on odd sizes and on both threads'
/// layouts.
#[test]
fn the_build_counts_the_valid_samples_of_the_image() {
    for (w, h) in [(2, 2), (3, 7), (33, 17), (640, 480)] {
        let mut depth = waves(w, h);
        let bad = [0.0, -1.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
        for (i, z) in depth.z.iter_mut().enumerate() {
            if i % 7 == 3 {
                *z = bad[i % bad.len()];
            }
        }
        // `z` is public: the build reads whatever it holds as the image's
        // conversion would have left it.
        let want = depth.z.iter().filter(|z| z.is_finite() && **z > 0.0).count();
        assert_eq!(DepthImage::from_z(w, h, depth.z.clone()).unwrap().valid_count(), want);
        assert!(want > 0 && want < depth.z.len(), "{w}x{h}: the image needs holes");
        for threads in [Threads::Single, Threads::Parallel] {
            let hier = Hierarchy::build_with(&depth, &camera(w, h), &Segmentation::default(), threads).unwrap();
            assert_eq!(hier.stats().valid_samples, want, "{w}x{h} {threads:?}");
        }
    }
}

#[test]
fn tau_zero_is_full_resolution_minus_segmented_triangles() {
    let (w, h) = (33, 21);
    let depth = depth_from(w, h, |x, y| {
        if x > 20 && y < 9 {
            1.0
        } else if (x + y) % 11 == 0 {
            0.0
        } else {
            3.0
        }
    });
    let cam = camera(w, h);
    let hier = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
    for lod in [Lod::Tau { tau: 0.0, view: &cam }, Lod::Epsilon(0.0)] {
        let mesh = hier.extract(lod).unwrap();
        let mut want = 0;
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                want += (0..2).filter(|&k| !hier.cell_segmented((x, y), k)).count();
            }
        }
        assert!(hier.stats().segmented_triangles > 0);
        assert_eq!(mesh.triangles.len(), want);
        assert_eq!(
            mesh.triangles.len() + hier.stats().segmented_triangles,
            2 * (w as usize - 1) * (h as usize - 1)
        );
        assert_conforming(&mesh);
        assert_strips_match(&mesh);
    }
}

#[test]
fn step_edge_has_no_rubber_sheet_with_orthogonality_at_5_degrees() {
    let (w, h) = (64, 40);
    let depth = step(w, h);
    let cam = camera(w, h);
    let seg = Segmentation {
        method: Method::Orthogonality { omega_deg: 5.0 },
        lambda: 0.02,
    };
    let hier = Hierarchy::build(&depth, &cam, &seg).unwrap();
    let view = Camera::new(
        w,
        h,
        cam.projection,
        glam::DQuat::from_rotation_y(0.2),
        glam::DVec3::new(-0.5, 0.0, 0.1),
    )
    .unwrap();
    for lod in [
        Lod::Epsilon(0.0),
        Lod::Epsilon(0.01),
        Lod::Epsilon(10.0),
        Lod::Tau { tau: 1.0, view: &view },
        Lod::Tau { tau: 50.0, view: &view },
    ] {
        let mesh = hier.extract(lod).unwrap();
        assert!(!mesh.triangles.is_empty());
        for t in &mesh.triangles {
            let z = t.map(|v| mesh.vertices[v as usize].depth);
            let spread = z.iter().copied().fold(f32::MIN, f32::max) - z.iter().copied().fold(f32::MAX, f32::min);
            assert!(spread < 0.5, "rubber sheet {t:?} with depths {z:?} at {lod:?}");
        }
        assert_conforming(&mesh);
    }
    // And the hole converges: at epsilon 0 only the full-resolution flagged
    // triangles (one column of cells) are missing.
    let full = hier.extract(Lod::Epsilon(0.0)).unwrap();
    assert_eq!(
        full.triangles.len(),
        2 * (w as usize - 1) * (h as usize - 1) - 2 * (h as usize - 1)
    );
}

#[test]
fn every_segmentation_method_cuts_the_step() {
    let (w, h) = (32, 16);
    let depth = step(w, h);
    let cam = camera(w, h);
    for method in [
        Method::Orthogonality { omega_deg: 5.0 },
        Method::Disparity { sigma: 0.1 },
        Method::Connectedness { kappa: 1.0 },
    ] {
        let hier = Hierarchy::build(&depth, &cam, &Segmentation { method, lambda: 0.02 }).unwrap();
        let segmented = hier.stats().segmented_triangles;
        assert!(
            segmented >= 2 * (h as usize - 1),
            "{method:?} segmented only {segmented}"
        );
        assert!(
            segmented <= 6 * (h as usize - 1),
            "{method:?} segmented {segmented}: too many"
        );
    }
    let none = Hierarchy::build(
        &depth,
        &cam,
        &Segmentation {
            method: Method::None,
            lambda: 0.0,
        },
    )
    .unwrap();
    assert_eq!(none.stats().segmented_triangles, 0);
}

#[test]
fn lambda_gate_keeps_small_relief() {
    // A 1 mm bump on a 2 m wall is rough surface, not a discontinuity.
    let (w, h) = (32, 32);
    let depth = depth_from(w, h, |x, y| if (x / 4 + y / 4) % 2 == 0 { 2.0 } else { 2.001 });
    let cam = camera(w, h);
    let gated = Hierarchy::build(
        &depth,
        &cam,
        &Segmentation {
            method: Method::Orthogonality { omega_deg: 80.0 },
            lambda: 0.01,
        },
    )
    .unwrap();
    assert_eq!(gated.stats().segmented_triangles, 0);
    let ungated = Hierarchy::build(
        &depth,
        &cam,
        &Segmentation {
            method: Method::Orthogonality { omega_deg: 80.0 },
            lambda: 0.0,
        },
    )
    .unwrap();
    assert!(ungated.stats().segmented_triangles > 0);
}

#[test]
fn view_dependent_meshes_are_conforming_and_coarsen_with_distance() {
    let (w, h) = (129, 97);
    let depth = waves(w, h);
    let cam = camera(w, h);
    let hier = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
    let near = cam;
    let far = Camera::new(
        w,
        h,
        cam.projection,
        glam::DQuat::IDENTITY,
        glam::DVec3::new(0.0, 0.0, -20.0),
    )
    .unwrap();
    let m_near = hier.extract(Lod::Tau { tau: 1.0, view: &near }).unwrap();
    let m_far = hier.extract(Lod::Tau { tau: 1.0, view: &far }).unwrap();
    for m in [&m_near, &m_far] {
        assert_conforming(m);
        assert_strips_match(m);
        assert_finite(m, w, h);
    }
    assert!(m_far.triangles.len() < m_near.triangles.len());
    // Looking away: everything is culled.
    let away = Camera::new(
        w,
        h,
        cam.projection,
        glam::DQuat::from_rotation_y(std::f64::consts::PI),
        glam::DVec3::ZERO,
    )
    .unwrap();
    assert!(hier
        .extract(Lod::Tau { tau: 1.0, view: &away })
        .unwrap()
        .triangles
        .is_empty());
}

/// On one thread, and on two at a size where level 1 of the pass is
/// shared (its lower band's planes held beside the level's).
#[test]
fn hierarchy_stays_within_24_bytes_per_grid_vertex() {
    for (n, threads) in [(513, Threads::Single), (1281, Threads::Parallel)] {
        let depth = waves(n, n);
        let hier = Hierarchy::build_with(&depth, &camera(n, n), &Segmentation::default(), threads).unwrap();
        let s = hier.stats();
        assert!(
            s.heap_bytes <= 24 * s.grid_vertices,
            "{n}: {} bytes for {} vertices",
            s.heap_bytes,
            s.grid_vertices
        );
        assert!(
            s.build_peak_bytes <= 24 * s.grid_vertices + 64 * 1024,
            "{n}: build peak {} for {} vertices",
            s.build_peak_bytes,
            s.grid_vertices
        );
    }
}

/// Error, radius and depth bits and the two cell flags of one grid vertex.
type VertexAnswer = (u32, u32, u32, bool, bool);

/// Everything a hierarchy answers, as comparable values.
fn answers(h: &Hierarchy) -> (Vec<VertexAnswer>, dmesh_engine::mesh::Mesh) {
    let g = *h.grid();
    let per_vertex = (0..g.gh())
        .flat_map(|y| (0..g.gw()).map(move |x| (x, y)))
        .map(|p| {
            (
                h.error(p).to_bits(),
                h.radius(p).to_bits(),
                h.depth(p).to_bits(),
                h.cell_segmented(p, 0),
                h.cell_segmented(p, 1),
            )
        })
        .collect();
    (per_vertex, h.extract(Lod::Epsilon(0.0)).unwrap())
}

/// One thread and two build the same hierarchy, on a small grid, on one
/// of ten levels (1025 x 1025), where how many of the coarse levels'
/// deviations the helper computes ahead of the pass depends on timing,
/// and on one whose level 1 the helper shares (1281 x 1281, 1.6 million
/// grid vertices), where which thread takes its lower band does.
#[test]
fn one_thread_and_two_build_the_same_hierarchy() {
    for (w, h) in [(97, 61), (1025, 1025), (1281, 1281)] {
        one_thread_and_two_agree(w, h);
    }
}

fn one_thread_and_two_agree(w: u32, h: u32) {
    let mut depth = step(w, h);
    // Invalid samples and a ramp, so normals, quality and flags all vary.
    for (i, z) in depth.z.iter_mut().enumerate() {
        if i % 37 == 0 {
            *z = 0.0;
        } else {
            *z += (i % w as usize) as f32 * 1e-3;
        }
    }
    for method in [
        Method::Orthogonality { omega_deg: 5.0 },
        Method::Connectedness { kappa: 0.5 },
        Method::None,
    ] {
        let seg = Segmentation {
            method,
            ..Segmentation::default()
        };
        let one = Hierarchy::build_with(&depth, &camera(w, h), &seg, Threads::Single).unwrap();
        let two = Hierarchy::build_with(&depth, &camera(w, h), &seg, Threads::Parallel).unwrap();
        let (a, b) = (answers(&one), answers(&two));
        assert!(
            a.1.vertices.iter().any(|v| v.rho > 0),
            "{method:?}: no quality computed"
        );
        assert!(a.0 == b.0, "{method:?}: per-vertex data differ");
        let (ma, mb) = (&a.1, &b.1);
        assert!(
            ma.vertices == mb.vertices && ma.triangles == mb.triangles && ma.strips == mb.strips,
            "{method:?}: meshes differ"
        );
        // The helper keeps the coarse levels' deviations until they are used.
        assert!(one.stats().build_peak_bytes <= two.stats().build_peak_bytes);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn random_depths_give_conforming_bounded_meshes((w, h, z) in arb_depth(24), eps in prop_oneof![Just(0.0), 0.0f64..0.5, 1.0f64..100.0], omega in 0.0f64..30.0) {
        let depth = DepthImage::from_z(w, h, z).unwrap();
        let seg = Segmentation { method: Method::Orthogonality { omega_deg: omega }, lambda: 0.01 };
        check_all(&depth, &camera(w, h), &seg, eps);
        let hier = Hierarchy::build(&depth, &camera(w, h), &seg).unwrap();
        assert_monotone(&hier);
    }

    #[test]
    fn random_depths_build_the_same_on_one_thread_and_two((w, h, z) in arb_depth(24), kappa in prop_oneof![Just(None), (0.1f64..2.0).prop_map(Some)]) {
        let depth = DepthImage::from_z(w, h, z).unwrap();
        let method = kappa.map_or(Method::Orthogonality { omega_deg: 5.0 }, |kappa| Method::Connectedness { kappa });
        let seg = Segmentation { method, lambda: 0.01 };
        let one = Hierarchy::build_with(&depth, &camera(w, h), &seg, Threads::Single).unwrap();
        let two = Hierarchy::build_with(&depth, &camera(w, h), &seg, Threads::Parallel).unwrap();
        let (a, b) = (answers(&one), answers(&two));
        prop_assert!(a.0 == b.0, "per-vertex data differ");
        prop_assert!(a.1.vertices == b.1.vertices && a.1.triangles == b.1.triangles && a.1.strips == b.1.strips);
    }

    #[test]
    fn random_views_give_conforming_finite_meshes(
        (w, h, z) in arb_depth(24),
        tau in prop_oneof![Just(0.0), 0.0f64..4.0, 10.0f64..1000.0],
        eye in (-5.0f64..5.0, -5.0f64..5.0, -10.0f64..5.0),
        yaw in -3.2f64..3.2,
    ) {
        let depth = DepthImage::from_z(w, h, z).unwrap();
        let cam = camera(w, h);
        let hier = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
        let view = Camera::new(64, 48, cam.projection, glam::DQuat::from_rotation_y(yaw), glam::DVec3::new(eye.0, eye.1, eye.2)).unwrap();
        let mesh = hier.extract(Lod::Tau { tau, view: &view }).unwrap();
        assert_finite(&mesh, w, h);
        assert_conforming(&mesh);
        assert_strips_match(&mesh);
        for order in [StripOrder::Greedy, StripOrder::Tunnelled] {
            assert_strips_match(&hier.extract_with(Lod::Tau { tau, view: &view }, order).unwrap());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Keeping outlines (the default extraction, `Outlines::Kept`) keeps
    /// every guarantee of the extraction (finite, conforming, strips, the
    /// epsilon bound) and drops nothing but the segmented cells: the mesh
    /// covers exactly the unsegmented halves of the image's cells, at any
    /// tolerance.
    #[test]
    fn refining_edges_covers_every_unsegmented_cell_and_stays_conforming(
        (w, h, z) in arb_depth(24),
        eps in prop_oneof![Just(0.0), 0.0f64..0.5, 1.0f64..100.0],
    ) {
        let depth = DepthImage::from_z(w, h, z).unwrap();
        let cam = camera(w, h);
        let hier = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
        let mesh = hier.extract(Lod::Epsilon(eps)).unwrap();
        assert_finite(&mesh, w, h);
        assert_conforming(&mesh);
        assert_strips_match(&mesh);
        assert_epsilon_bound(&mesh, &depth, eps);
        let area2: i64 = mesh
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| ij(&mesh, v));
                ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).abs()
            })
            .sum();
        let unsegmented = (0..w - 1)
            .flat_map(|x| (0..h - 1).map(move |y| (x, y)))
            .map(|c| (0..2).filter(|&half| !hier.cell_segmented(c, half)).count() as i64)
            .sum::<i64>();
        prop_assert_eq!(area2, unsegmented);
        // Never fewer triangles than the extraction that drops coarse ones,
        // and a partial refinement in between, conforming too.
        let as_dmesh = |o| hier.extract_as(Lod::Epsilon(eps), StripOrder::Traversal, o).unwrap();
        let plain = as_dmesh(Outlines::Dropped);
        let partial = as_dmesh(Outlines::Refined(2));
        assert_conforming(&partial);
        assert_epsilon_bound(&partial, &depth, eps);
        prop_assert!(mesh.triangles.len() >= partial.triangles.len());
        prop_assert!(partial.triangles.len() >= plain.triangles.len());
        // Refining only the near side of each outline: conforming and
        // within epsilon, between the two in triangles, and every
        // unsegmented cell on the near surface's side is still covered.
        let near = as_dmesh(Outlines::NearSide(1));
        assert_conforming(&near);
        assert_epsilon_bound(&near, &depth, eps);
        prop_assert!(near.triangles.len() <= mesh.triangles.len());
        prop_assert!(near.triangles.len() >= plain.triangles.len());
        let covered = covered_cells(&hier, &near);
        for (cell, half) in near_side_cells(&hier, w, h) {
            prop_assert!(covered.contains(&(cell, half)), "cell {:?} half {} uncovered", cell, half);
        }
    }
}

/// The unit cells' halves that a mesh covers, as (min corner, half).
fn covered_cells(hier: &Hierarchy, mesh: &dmesh_engine::mesh::Mesh) -> std::collections::HashSet<((u32, u32), usize)> {
    let mut out = std::collections::HashSet::new();
    for t in &mesh.triangles {
        let p = t.map(|v| ij(mesh, v));
        let ((x0, x1), (y0, y1)) = bounds(&p);
        for y in y0..y1 {
            for x in x0..x1 {
                // A cell's half is covered when its centroid (times 3) is
                // inside the triangle (times 3).
                for half in 0..2 {
                    let d = hier.grid().cell((x as u32, y as u32));
                    let c = [d.a, d.b, d.apex[half]];
                    let g = (c.iter().map(|q| q.0).sum::<i64>(), c.iter().map(|q| q.1).sum::<i64>());
                    let s = [0, 1, 2].map(|k| {
                        cross(
                            (3 * p[k].0, 3 * p[k].1),
                            (3 * p[(k + 1) % 3].0, 3 * p[(k + 1) % 3].1),
                            g,
                        )
                    });
                    if s.iter().all(|&v| v > 0) || s.iter().all(|&v| v < 0) {
                        out.insert(((x as u32, y as u32), half));
                    }
                }
            }
        }
    }
    out
}

/// The cells' halves the near-side refinement must keep, read from the
/// definition (`surface_side.rs`): unsegmented, with a corner that is a near
/// corner of a segmented one (at most halfway from its nearest depth to its
/// farthest, or any valid corner beside an invalid one).
fn near_side_cells(hier: &Hierarchy, w: u32, h: u32) -> Vec<((u32, u32), usize)> {
    let z = |p: (i64, i64)| hier.depth((p.0 as u32, p.1 as u32));
    let corners = |cell: (u32, u32), half: usize| {
        let d = hier.grid().cell(cell);
        [d.a, d.b, d.apex[half]]
    };
    let cells: Vec<((u32, u32), usize)> = (0..w - 1)
        .flat_map(|x| (0..h - 1).flat_map(move |y| [((x, y), 0), ((x, y), 1)]))
        .collect();
    let mut near = std::collections::HashSet::new();
    for &(cell, half) in &cells {
        if hier.cell_segmented(cell, half) {
            let zs = corners(cell, half).map(z);
            let lo = zs.iter().copied().fold(f32::MAX, f32::min);
            let hi = zs.iter().copied().fold(0f32, f32::max);
            for (p, zp) in corners(cell, half).into_iter().zip(zs) {
                if zp > 0.0 && (lo <= 0.0 || zp <= 0.5 * (lo + hi)) {
                    near.insert(p);
                }
            }
        }
    }
    cells
        .into_iter()
        .filter(|&(cell, half)| {
            !hier.cell_segmented(cell, half) && corners(cell, half).iter().any(|p| near.contains(p))
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Padding is outside the image, not invalid data in it: with
    /// segmentation off on fully valid depth, at every tolerance, static or
    /// view-dependent, perspective or orthographic, the mesh tiles the image
    /// rectangle whatever its size.
    #[test]
    fn padded_sizes_tile_the_image_at_every_tolerance(
        w in 2u32..72,
        h in 2u32..72,
        relief in 0.0f32..0.5,
        ortho in any::<bool>(),
        eps in prop_oneof![Just(0.0), 1e-4f64..0.05, 1.0f64..10.0, Just(1e9)],
        tau in prop_oneof![Just(0.0), 0.1f64..4.0, 8.0f64..1e6],
    ) {
        let depth = depth_from(w, h, |x, y| 2.0 + relief * ((x as f32 * 0.37).sin() + (y as f32 * 0.23).cos()));
        let cam = if ortho { Camera::orthographic(w, h, 0.01, 0.01, 0.0, 0.0).unwrap() } else { camera(w, h) };
        let seg = Segmentation { method: Method::None, lambda: 0.01 };
        let hier = Hierarchy::build(&depth, &cam, &seg).unwrap();
        assert_monotone(&hier);
        for lod in [Lod::Epsilon(eps), Lod::Tau { tau, view: &cam }] {
            let mesh = hier.extract(lod).unwrap();
            assert_conforming(&mesh);
            assert_covers_image(&mesh, w, h);
            assert_strips_match(&mesh);
        }
        // A budget that the coarsest mesh meets is met.
        let coarsest = hier.coarsest_triangles();
        let mesh = hier.extract(Lod::Triangles { max: u32::try_from(coarsest).unwrap(), view: None }).unwrap();
        prop_assert!(mesh.triangles.len() as u64 <= coarsest);
        assert_covers_image(&mesh, w, h);
    }
}

/// The case the defect was seen on: an orthographic height field whose size
/// is not `m * 2^k + 1`, at epsilon = 8 with segmentation off.
#[test]
fn an_orthographic_height_field_keeps_its_border_at_coarse_tolerances() {
    let (w, h) = (300, 201);
    let depth = depth_from(w, h, |x, y| {
        10.0 + ((x as f32 / 17.0).sin() * (y as f32 / 13.0).cos()) * 3.0
    });
    let cam = Camera::orthographic(w, h, 1.0, 1.0, 0.0, 0.0).unwrap();
    let hier = Hierarchy::build(
        &depth,
        &cam,
        &Segmentation {
            method: Method::None,
            lambda: 0.02,
        },
    )
    .unwrap();
    assert!(
        hier.grid().gw() > w || hier.grid().gh() > h,
        "the size must need padding"
    );
    for eps in [0.0, 0.5, 8.0, 1e6] {
        let mesh = hier.extract(Lod::Epsilon(eps)).unwrap();
        assert_conforming(&mesh);
        assert_covers_image(&mesh, w, h);
    }
}
