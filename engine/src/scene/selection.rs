//! Which reference views serve a novel camera, and with what weights:
//! DMesh Sec. 6.2 (views whose direction is within 135 degrees of the novel
//! one) or Verlani et al.'s limited set (within 40 degrees).
//!
//! The weight of view `i` is the product of
//! - the angular weight of DMesh: 1 below 45 degrees between the view
//!   directions, `cos(beta - 45 deg)` above (so 0 at 135 degrees);
//! - a positional weight `1 / (1 + d_i / d_mean)`, with `d_i` the distance
//!   between the reference and novel centres and `d_mean` their mean over the
//!   candidates (DMesh leaves the function open; this one is scale-free and
//!   smooth, and 1 for a reference at the novel centre);
//!
//! normalised to sum to 1. Views with weight 0 are dropped; at most
//! `max_views` are kept, heaviest first.

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

/// Selects among `views` for `novel`, keeping at most `max_views`.
pub fn select_views(novel: &Camera, views: &[Camera], rule: SelectionRule, max_views: usize) -> Result<Vec<Weighted>> {
    let limit = match rule {
        SelectionRule::Dmesh { max_angle_deg } if (0.0..=180.0).contains(&max_angle_deg) => max_angle_deg,
        SelectionRule::Dmesh { max_angle_deg } => {
            return Err(Error::invalid(format!(
                "max_angle_deg is {max_angle_deg}; it must be between 0 and 180"
            )))
        }
        SelectionRule::Limited => 40.0,
    };
    let n = direction(novel);
    let candidates: Vec<(usize, f64, f64)> = views
        .iter()
        .enumerate()
        .filter_map(|(i, v)| {
            let beta = direction(v).dot(n).clamp(-1.0, 1.0).acos().to_degrees();
            (beta < limit).then(|| (i, beta, (v.translation - novel.translation).length()))
        })
        .collect();
    if candidates.is_empty() {
        return Ok(Vec::new());
    }
    let mean = candidates.iter().map(|c| c.2).sum::<f64>() / candidates.len() as f64;
    let mut weighted: Vec<Weighted> = candidates
        .iter()
        .map(|&(index, beta, d)| {
            let angular = if beta < 45.0 {
                1.0
            } else {
                (beta - 45.0).to_radians().cos().max(0.0)
            };
            let positional = if mean > 0.0 { 1.0 / (1.0 + d / mean) } else { 1.0 };
            Weighted {
                index,
                weight: angular * positional,
            }
        })
        .filter(|w| w.weight > 0.0 && w.weight.is_finite())
        .collect();
    weighted.sort_by(|a, b| b.weight.total_cmp(&a.weight).then(a.index.cmp(&b.index)));
    weighted.truncate(max_views.max(1));
    let total: f64 = weighted.iter().map(|w| w.weight).sum();
    for w in &mut weighted {
        w.weight /= total;
    }
    Ok(weighted)
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
