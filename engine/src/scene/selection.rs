//! Which reference views serve a novel camera, and with what weights:
//! DMesh Sec. 6.2 (views whose direction is within 135 degrees of the novel
//! one) or Verlani et al.'s limited set (within 40 degrees), weighted as in
//! Unstructured Lumigraph Rendering (Buehler et al., SIGGRAPH 2001, Sec. 4)
//! so that the weights are continuous in the camera (DMesh Fig. 22: smooth
//! rotation, no popping).
//!
//! Each reference `i` gets a score `g_i`, the product of
//! - an angular term, DMesh's ramp scaled to the rule's limit `L`: 1 up to
//!   `L / 3` between the view directions, then `cos` falling to 0 at `L`
//!   (for DMesh's 135 degrees: 1 below 45, `cos(beta - 45 deg)` above);
//! - a positional term `1 / (1 + d_i / d_mean)`, with `d_i` the distance
//!   between the reference and novel centres and `d_mean` its mean over all
//!   references (scale-free, 1 for a reference at the novel centre).
//!
//! Like ULR's penalties, each score is measured against the first one left
//! out: with `t` the `(k + 1)`-th best score (`k = max_views`; 0 when fewer
//! views score above 0), the weight is `max(0, g_i - t)`, normalised to sum
//! to 1. A view's weight so reaches 0 exactly as it leaves the selected
//! set, at the angle limit or at the cut, and every term is continuous in
//! the camera. A view whose share would be under [`MIN_SHARE`] is left out
//! (its mesh is not worth fetching), which moves the weights by at most
//! that much per view. (The previous rule took `d_mean` over the views inside the
//! limit and cut at `k` views with their whole weight: steps of up to 0.175
//! of the total weight per 0.1 degree of an orbit.)

use glam::DVec3;

use crate::camera::Camera;
use crate::error::{Error, Result};

/// The selection rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SelectionRule {
    /// DMesh: views within `max_angle_deg` (135 by default) of the novel direction.
    Dmesh {
        /// Largest angle between view directions, degrees.
        max_angle_deg: f64,
    },
    /// Verlani: the limited set, views within 40 degrees.
    Limited,
}

/// A selected view: its index in the candidate list and its normalised weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weighted {
    /// Index into the candidates passed to [`select_views`].
    pub index: usize,
    /// Weight in `(0, 1]`; the weights of one selection sum to 1.
    pub weight: f64,
}

fn direction(c: &Camera) -> DVec3 {
    (c.rotation * DVec3::Z).normalize_or(DVec3::Z)
}

/// The angle limit of `rule`, degrees, or why it is not one.
pub(crate) fn limit_deg(rule: SelectionRule) -> Result<f64> {
    match rule {
        SelectionRule::Dmesh { max_angle_deg } if (0.0..=180.0).contains(&max_angle_deg) => Ok(max_angle_deg),
        SelectionRule::Dmesh { max_angle_deg } => Err(Error::invalid(format!(
            "max_angle_deg is {}; it must be between 0 and 180",
            crate::error::Shown(max_angle_deg)
        ))),
        SelectionRule::Limited => Ok(40.0),
    }
}

/// Every view's score for `novel` (0 at or beyond the angle limit).
fn scores(novel: &Camera, views: &[Camera], limit: f64) -> Vec<f64> {
    let n = direction(novel);
    let d: Vec<f64> = views
        .iter()
        .map(|v| (v.translation - novel.translation).length())
        .collect();
    let mean = d.iter().sum::<f64>() / views.len().max(1) as f64;
    let flat = limit / 3.0;
    views
        .iter()
        .zip(&d)
        .map(|(v, &d)| {
            let beta = direction(v).dot(n).clamp(-1.0, 1.0).acos().to_degrees();
            let angular = if beta <= flat {
                1.0
            } else if beta < limit {
                ((beta - flat) / (limit - flat) * std::f64::consts::FRAC_PI_2)
                    .cos()
                    .max(0.0)
            } else {
                0.0
            };
            let positional = if mean > 0.0 { 1.0 / (1.0 + d / mean) } else { 1.0 };
            let g = angular * positional;
            if g.is_finite() {
                g
            } else {
                0.0
            }
        })
        .collect()
}

/// The score of the first view left out: the `(k + 1)`-th best (0 when
/// fewer views score above 0).
fn cut(scores: &[f64], k: usize) -> f64 {
    let mut sorted = scores.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    sorted.get(k).copied().unwrap_or(0.0)
}

/// Selects among `views` for `novel`, keeping at most `max_views`.
pub fn select_views(novel: &Camera, views: &[Camera], rule: SelectionRule, max_views: usize) -> Result<Vec<Weighted>> {
    let limit = limit_deg(rule)?;
    let k = max_views.max(1);
    let g = scores(novel, views, limit);
    let t = cut(&g, k);
    let mut weighted: Vec<Weighted> = g
        .iter()
        .enumerate()
        .filter(|&(_, &g)| g > t)
        .map(|(index, &g)| Weighted { index, weight: g - t })
        .collect();
    if weighted.is_empty() {
        // No score stands above the cut: the best views tie (or none scores
        // above 0). Share the weight among the tied best, at most k.
        let best = g.iter().copied().fold(0.0, f64::max);
        if best <= 0.0 {
            return Ok(Vec::new());
        }
        weighted = g
            .iter()
            .enumerate()
            .filter(|&(_, &g)| g == best)
            .take(k)
            .map(|(index, _)| Weighted { index, weight: 1.0 })
            .collect();
    }
    weighted.sort_by(|a, b| b.weight.total_cmp(&a.weight).then(a.index.cmp(&b.index)));
    // A view whose share is negligible (one just entering or leaving) is
    // not worth its mesh: dropping it moves at most MIN_SHARE per view.
    let total: f64 = weighted.iter().map(|w| w.weight).sum();
    weighted.retain(|w| w.weight >= MIN_SHARE * total);
    let total: f64 = weighted.iter().map(|w| w.weight).sum();
    for w in &mut weighted {
        w.weight /= total;
    }
    Ok(weighted)
}

/// The smallest share of the total weight a selected view carries.
pub const MIN_SHARE: f64 = 1e-4;

/// How far the selected views' scores stand above the cut, summed: the
/// denominator of the weights. Small when the best views nearly tie with
/// the first left out, where the weights change fastest with the camera.
pub fn selection_spread(novel: &Camera, views: &[Camera], rule: SelectionRule, max_views: usize) -> Result<f64> {
    let g = scores(novel, views, limit_deg(rule)?);
    let t = cut(&g, max_views.max(1));
    Ok(g.iter().map(|&g| (g - t).max(0.0)).sum())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use glam::DQuat;

    fn cam(yaw_deg: f64, x: f64) -> Camera {
        let p = Projection::Perspective {
            fx: 100.0,
            fy: 100.0,
            cx: 50.0,
            cy: 50.0,
        };
        Camera::new(
            100,
            100,
            p,
            DQuat::from_rotation_y(yaw_deg.to_radians()),
            DVec3::new(x, 0.0, 0.0),
        )
        .unwrap()
    }

    #[test]
    fn weights_sum_to_one_and_favour_close_aligned_views() {
        let views = [cam(0.0, 0.0), cam(30.0, 1.0), cam(100.0, 1.0), cam(180.0, 0.0)];
        let sel = select_views(
            &cam(10.0, 0.2),
            &views,
            SelectionRule::Dmesh { max_angle_deg: 135.0 },
            5,
        )
        .unwrap();
        let total: f64 = sel.iter().map(|w| w.weight).sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert_eq!(sel[0].index, 0);
        assert!(
            sel.iter().all(|w| w.index != 3),
            "the opposite view is beyond 135 degrees"
        );
        assert_eq!(sel.len(), 3);
    }

    #[test]
    fn limited_set_keeps_views_within_40_degrees_and_max_views_caps() {
        let views = [cam(0.0, 0.0), cam(30.0, 1.0), cam(60.0, 1.0)];
        let sel = select_views(&cam(5.0, 0.0), &views, SelectionRule::Limited, 5).unwrap();
        assert_eq!(sel.iter().map(|w| w.index).collect::<Vec<_>>(), vec![0, 1]);
        let one = select_views(&cam(5.0, 0.0), &views, SelectionRule::Limited, 1).unwrap();
        assert_eq!(one.len(), 1);
        assert_eq!(one[0].weight, 1.0);
    }

    /// The weights' values, not only their order: scores from the angular
    /// ramp and the positional term, less the first left out's, normalised.
    #[test]
    fn weights_are_the_scores_above_the_cut_normalised() {
        // Three views at the novel centre (positional term 1) turned 0, 60
        // and 90 degrees; the limit is 135, the ramp flat to 45.
        let views = [cam(0.0, 0.0), cam(60.0, 0.0), cam(90.0, 0.0)];
        let sel = select_views(&cam(0.0, 0.0), &views, SelectionRule::Dmesh { max_angle_deg: 135.0 }, 2).unwrap();
        let g = |beta: f64| ((beta - 45.0) / 90.0 * std::f64::consts::FRAC_PI_2).cos();
        let (a, b) = (1.0 - g(90.0), g(60.0) - g(90.0));
        assert_eq!(sel.len(), 2);
        assert!((sel[0].weight - a / (a + b)).abs() < 1e-12, "{sel:?}");
        assert!((sel[1].weight - b / (a + b)).abs() < 1e-12, "{sel:?}");
        // The positional term: two aligned views, one at the novel centre and
        // one 2 m away, a third turned 90 degrees at the centre. Mean
        // distance 2/3: scores 1, 1 / (1 + 3) and cos(45 deg).
        let views = [cam(0.0, 0.0), cam(0.0, 2.0), cam(90.0, 0.0)];
        let sel = select_views(&cam(0.0, 0.0), &views, SelectionRule::Dmesh { max_angle_deg: 135.0 }, 1).unwrap();
        assert_eq!(sel.len(), 1);
        assert_eq!((sel[0].index, sel[0].weight), (0, 1.0));
        let all = select_views(&cam(0.0, 0.0), &views, SelectionRule::Dmesh { max_angle_deg: 135.0 }, 5).unwrap();
        let scores = [1.0, 0.25, g(90.0)];
        let total: f64 = scores.iter().sum();
        for w in &all {
            assert!((w.weight - scores[w.index] / total).abs() < 1e-12, "{all:?}");
        }
        // The limited set's ramp: flat to 40 / 3 degrees, 0 at 40.
        let views = [cam(0.0, 0.0), cam(30.0, 0.0)];
        let sel = select_views(&cam(0.0, 0.0), &views, SelectionRule::Limited, 5).unwrap();
        let g30 = ((30.0 - 40.0 / 3.0) / (40.0 - 40.0 / 3.0) * std::f64::consts::FRAC_PI_2).cos();
        assert!((sel[1].weight - g30 / (1.0 + g30)).abs() < 1e-12, "{sel:?}");
    }

    #[test]
    fn nothing_in_range_selects_nothing_and_bad_angles_are_refused() {
        assert!(
            select_views(&cam(0.0, 0.0), &[cam(180.0, 0.0)], SelectionRule::Limited, 3)
                .unwrap()
                .is_empty()
        );
        assert!(select_views(&cam(0.0, 0.0), &[], SelectionRule::Dmesh { max_angle_deg: 200.0 }, 3).is_err());
    }
}
