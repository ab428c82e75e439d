//! Filling the seams a blend leaves (DMesh Sec. 6.3's epsilon-z-buffer
//! blends whole meshes; where every reference segments a surface it sees at
//! a grazing angle, such as a box's vertical edge seen from between two
//! references, no mesh reaches the edge in the novel view and a dashed line
//! of uncovered pixels remains).
//!
//! An uncovered pixel is filled when, along a row, a column or a diagonal,
//! covered pixels lie on both sides with at most `max_gap` uncovered pixels
//! between them (itself included), and the hole is a seam on one surface,
//! not a depth discontinuity: either their depths differ by at most
//! `depth_tolerance` (relative) per pixel between them, or the surface's
//! own depth gradient explains the difference. The gradient is read on
//! each side from the next pixel out; the two sides must agree with each
//! other, and the step across the gap must match their mean, each within
//! the same tolerance. So a floor seen at a grazing angle, whose depth
//! changes faster than the tolerance per pixel, has its seams filled, while
//! a disocclusion (two surfaces whose gradients do not lead from one to the
//! other) stays open. Its colour and depth interpolate those two pixels
//! linearly; of the directions that qualify, the narrowest gap wins (rows
//! first, then columns, then diagonals). A disocclusion wider than
//! `max_gap` in every direction, or one beside a depth jump, is left as it
//! is. Every decision reads the blend before any fill, so the result does
//! not depend on the order pixels are visited in; the browser viewer's fill
//! pass (`clients/web/src/renderer.js`) computes the same.

/// The directions searched, in order of preference.
const DIRECTIONS: [(i64, i64); 4] = [(1, 0), (0, 1), (1, 1), (1, -1)];

/// Fills seams of at most `max_gap` pixels in an image with a depth per
/// pixel (0 where nothing is covered). Returns the pixels filled.
pub fn fill_small_holes(
    width: u32,
    height: u32,
    rgb: &mut [u8],
    depth: &mut [f32],
    max_gap: u32,
    depth_tolerance: f64,
) -> usize {
    if max_gap == 0 {
        return 0;
    }
    let (w, h) = (i64::from(width), i64::from(height));
    let source_rgb = rgb.to_vec();
    let source_depth = depth.to_vec();
    let at = |x: i64, y: i64| -> Option<usize> { (x >= 0 && y >= 0 && x < w && y < h).then(|| (y * w + x) as usize) };
    let covered = |i: usize| source_depth[i] > 0.0;
    let gap = i64::from(max_gap);
    let mut filled = 0;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if covered(i) {
                continue;
            }
            let mut best: Option<(i64, usize, i64, usize, i64)> = None;
            for (dx, dy) in DIRECTIONS {
                // Nearest covered pixel on each side, at most `gap` away.
                let reach = |sign: i64| {
                    (1..=gap).find_map(|t| {
                        let j = at(x + sign * t * dx, y + sign * t * dy)?;
                        covered(j).then_some((t, j))
                    })
                };
                let (Some((ta, a)), Some((tb, b))) = (reach(1), reach(-1)) else {
                    continue;
                };
                let width_here = ta + tb - 1;
                if width_here > gap {
                    continue;
                }
                let (za, zb) = (f64::from(source_depth[a]), f64::from(source_depth[b]));
                let tol = depth_tolerance * za.min(zb);
                let steps = (ta + tb) as f64;
                // Along +d: b2, b, the gap, a, a2.
                let beyond = |t: i64| at(x + t * dx, y + t * dy).filter(|&j| covered(j));
                let follows_gradient = || match (beyond(ta + 1), beyond(-tb - 1)) {
                    (Some(a2), Some(b2)) => {
                        let sa = f64::from(source_depth[a2]) - za;
                        let sb = zb - f64::from(source_depth[b2]);
                        (sa - sb).abs() <= tol && ((za - zb) - 0.5 * (sa + sb) * steps).abs() <= tol * steps
                    }
                    _ => false,
                };
                // The gradient is read only where the plain rule refuses.
                if (za - zb).abs() > tol * steps && !follows_gradient() {
                    continue;
                }
                if best.is_none_or(|(_, _, _, _, g)| width_here < g) {
                    best = Some((ta, a, tb, b, width_here));
                }
            }
            if let Some((ta, a, tb, b, _)) = best {
                // Linear between the two: the nearer side weighs more.
                let (wa, wb) = (tb as f64 / (ta + tb) as f64, ta as f64 / (ta + tb) as f64);
                for c in 0..3 {
                    let v = wa * f64::from(source_rgb[3 * a + c]) + wb * f64::from(source_rgb[3 * b + c]);
                    rgb[3 * i + c] = (v.clamp(0.0, 255.0) + 0.5) as u8;
                }
                depth[i] = (wa * f64::from(source_depth[a]) + wb * f64::from(source_depth[b])) as f32;
                filled += 1;
            }
        }
    }
    filled
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> Option<(u8, f32)>) -> (Vec<u8>, Vec<f32>) {
        let mut rgb = vec![0u8; (3 * w * h) as usize];
        let mut depth = vec![0f32; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                if let Some((c, z)) = f(x, y) {
                    let i = (y * w + x) as usize;
                    rgb[3 * i..3 * i + 3].fill(c);
                    depth[i] = z;
                }
            }
        }
        (rgb, depth)
    }

    #[test]
    fn a_two_pixel_seam_is_filled_between_its_sides() {
        // Columns 5 and 6 uncovered on one surface: filled, colours interpolated.
        let (mut rgb, mut depth) = image(12, 4, |x, _| {
            (x != 5 && x != 6).then_some((if x < 5 { 40 } else { 100 }, 2.0))
        });
        assert_eq!(fill_small_holes(12, 4, &mut rgb, &mut depth, 2, 0.05), 8);
        assert!(depth.iter().all(|&z| z > 0.0));
        // x = 5 is a third of the way from 40 (x = 4) to 100 (x = 7).
        assert_eq!(rgb[3 * 5], 60);
        assert_eq!(rgb[3 * 6], 80);
    }

    #[test]
    fn wide_holes_and_depth_jumps_are_left_alone() {
        // Three columns wide: over the limit of 2.
        let (mut rgb, mut depth) = image(12, 4, |x, _| (!(4..7).contains(&x)).then_some((50, 2.0)));
        assert_eq!(fill_small_holes(12, 4, &mut rgb, &mut depth, 2, 0.05), 0);
        // One column, but between a pole at 1 m and a wall at 3 m.
        let (mut rgb, mut depth) = image(12, 4, |x, _| (x != 5).then_some((50, if x < 5 { 1.0 } else { 3.0 })));
        assert_eq!(fill_small_holes(12, 4, &mut rgb, &mut depth, 2, 0.05), 0);
        assert_eq!(depth.iter().filter(|&&z| z == 0.0).count(), 4);
        // Nothing to fill with a gap of 0.
        let (mut rgb, mut depth) = image(12, 4, |x, _| (x != 5).then_some((50, 2.0)));
        assert_eq!(fill_small_holes(12, 4, &mut rgb, &mut depth, 0, 0.05), 0);
    }

    /// A floor at a grazing angle: depth grows 12 % per pixel, more than the
    /// 5 % the plain rule allows across a seam; its own gradient explains
    /// the step, so the seam is filled. A disocclusion between two such
    /// ramps at different depths, or a ramp beside a flat wall, stays open.
    #[test]
    fn seams_on_grazing_surfaces_follow_the_gradient_and_disocclusions_stay_open() {
        let ramp = |x: u32| 2.0 * 1.12f32.powi(x as i32);
        let (mut rgb, mut depth) = image(12, 1, |x, _| (x != 5).then_some((50, ramp(x))));
        // The step from x = 4 to x = 6 (0.80 m) is over the plain limit of
        // 5 % per pixel of the nearer depth (0.31 m).
        assert!(ramp(6) - ramp(4) > 0.05 * 2.0 * ramp(4));
        assert_eq!(fill_small_holes(12, 1, &mut rgb, &mut depth, 2, 0.05), 1);
        assert!(
            (depth[5] - ramp(5)).abs() < 0.02 * ramp(5),
            "{} against {}",
            depth[5],
            ramp(5)
        );
        // The same ramp, but the right side a metre further back.
        let (mut rgb, mut depth) = image(12, 1, |x, _| {
            (x != 5).then_some((50, ramp(x) + if x > 5 { 1.0 } else { 0.0 }))
        });
        assert_eq!(fill_small_holes(12, 1, &mut rgb, &mut depth, 2, 0.05), 0);
        // A ramp ending at a flat wall.
        let (mut rgb, mut depth) = image(12, 1, |x, _| {
            (x != 5).then_some((50, if x < 5 { ramp(x) } else { 5.0 }))
        });
        assert_eq!(fill_small_holes(12, 1, &mut rgb, &mut depth, 2, 0.05), 0);
    }

    #[test]
    fn diagonal_seams_are_filled_and_the_border_is_no_side() {
        // A one-pixel diagonal line of holes; its two ends, in the image's
        // corners, have no covered pixel on one side in any direction.
        let (mut rgb, mut depth) = image(10, 10, |x, y| (x != y).then_some((90, 2.0)));
        assert_eq!(fill_small_holes(10, 10, &mut rgb, &mut depth, 2, 0.05), 8);
        assert_eq!(depth[0], 0.0);
        assert!(depth[5 * 10 + 5] > 0.0);
        // A hole at the image's edge has one side only along that axis.
        let (mut rgb, mut depth) = image(6, 1, |x, _| (x != 0).then_some((90, 2.0)));
        assert_eq!(fill_small_holes(6, 1, &mut rgb, &mut depth, 2, 0.05), 0);
    }
}
