//! Which held meshes a walkthrough frame fetches: Qu, Wan, Qin and Kaufman's
//! keyframeless workload balancing (Sec. 3.1-3.4), applied to streamed
//! view-dependent meshes, beside the two schemes it improves on.
//!
//! Qu et al. keep an intermediate image whose pixels carry their exact
//! positions (offset buffer) and ages (age buffer); each frame warps it, ray
//! casts the holes, then re-renders as many of the oldest pixels as a fixed
//! per-frame budget allows. Here the held unit is a reference view's mesh:
//! its geometry is exact, so drawing it again from a new eye loses nothing
//! (the offset buffer's role); what goes stale is its level of detail and its
//! frustum. A frame's *holes* are the views it selects that are not held, and
//! held meshes that no longer serve the camera (their stated
//! [`Reach`](dmesh_engine::mesh::Reach): the error bound exceeds the tolerance by more
//! than `stale_factor`, or the frustum sees something they culled). Holes are
//! fetched whatever they cost, as Qu's holes are always ray cast. The
//! *refresh* then re-requests held meshes oldest first while the planned
//! cost, which is the held mesh's own cost (a mesh re-extracted a few frames
//! later at the same tolerance costs about the same), fits in what the budget
//! leaves after the holes' planned cost. The first mesh that does not fit
//! ends the refresh, so the oldest is never passed over for a cheaper one.
//!
//! Nothing is held forever: as Qu et al. (Sec. 3.3) re-render any pixel
//! older than an age threshold (10 frames), a held mesh older than
//! [`Policy::max_age`] frames is *over age*. The refresh reaches over-age
//! meshes first (they are the oldest), and when the budget left cannot pay
//! for the oldest of them, that one is refreshed all the same: one over-age
//! mesh per frame at least, so none is held longer than the cap plus the
//! frames the over-age meshes before it take.
//!
//! The three strategies:
//! - [`Strategy::Full`]: every selected view fetched every frame (what DMesh
//!   Sec. 7.3, Table 3 measured);
//! - [`Strategy::Keyframe`]: every selected view refreshed every `k` frames,
//!   held meshes drawn in between with holes fetched (Qu Fig. 1);
//! - [`Strategy::Balanced`]: holes, then the budgeted oldest-first refresh.

use dmesh_engine::camera::Camera;
use dmesh_engine::mesh::Reach;

/// How a walkthrough chooses what to fetch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Strategy {
    /// Every selected view, every frame.
    Full,
    /// Everything every `every` frames, holes in between.
    Keyframe {
        /// Frames between keyframes (at least 1).
        every: u32,
    },
    /// Holes, then the oldest held meshes within the budget.
    Balanced,
}

impl Strategy {
    /// Its name on the command line and in tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::Full => "full",
            Self::Keyframe { .. } => "keyframe",
            Self::Balanced => "balanced",
        }
    }

    /// The strategies of a comma-separated list of names (`all`: the three),
    /// keyframes every `every` frames.
    pub fn parse_list(list: &str, every: u32) -> anyhow::Result<Vec<Self>> {
        let mut out = Vec::new();
        for name in list.split(',').map(str::trim) {
            match name {
                "all" => out.extend([Self::Full, Self::Keyframe { every }, Self::Balanced]),
                "full" => out.push(Self::Full),
                "keyframe" => out.push(Self::Keyframe { every }),
                "balanced" => out.push(Self::Balanced),
                other => anyhow::bail!("unknown strategy {other:?}; use full, keyframe, balanced or all"),
            }
        }
        Ok(out)
    }
}

/// What a frame's refresh may spend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Triangles fetched.
    Triangles(f64),
    /// Response bytes.
    Bytes(f64),
    /// Request milliseconds (each mesh's last fetch time, summed).
    Millis(f64),
    /// One held mesh's worth of triangles: the largest of the selected held
    /// meshes, so that the oldest always fits when there is no hole.
    OneView,
}

/// What fetching a mesh cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cost {
    /// Triangles.
    pub triangles: f64,
    /// Response bytes.
    pub bytes: f64,
    /// Request wall-clock milliseconds.
    pub ms: f64,
}

/// A held mesh as the policy sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Held {
    /// Frames since it was fetched (0 in the frame that fetched it).
    pub age: u32,
    /// The tolerance it was extracted at, pixels.
    pub tau: f64,
    /// How far it reaches (`None`: a static mesh, which never goes stale).
    pub reach: Option<Reach>,
    /// What it cost.
    pub cost: Cost,
}

/// Why a view is a hole.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hole {
    /// Selected and not held.
    Missing,
    /// Its error bound exceeds the tolerance by more than the stale factor.
    Stale,
    /// The frustum sees something it culled.
    Uncovered,
}

/// The walkthrough policy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Policy {
    /// The strategy.
    pub strategy: Strategy,
    /// The refresh budget of [`Strategy::Balanced`].
    pub budget: Budget,
    /// Target tolerance, pixels.
    pub tau: f64,
    /// A held mesh is a hole once its error bound exceeds `tau` times this.
    pub stale_factor: f64,
    /// A held mesh older than this many frames is refreshed before any
    /// younger one, over the budget if need be (`None`: no cap).
    pub max_age: Option<u32>,
}

/// The target tolerance of a walkthrough unless told otherwise, pixels.
pub const DEFAULT_TAU: f64 = 1.0;

/// A held mesh is a hole once its error bound passes `tau` times this, unless told otherwise.
pub const DEFAULT_STALE_FACTOR: f64 = 1.5;
/// The age cap unless told otherwise, frames: Qu et al.'s threshold.
pub const DEFAULT_MAX_AGE: u32 = 10;

impl Policy {
    /// `strategy` under `budget` at [`DEFAULT_TAU`] and [`DEFAULT_STALE_FACTOR`].
    pub fn new(strategy: Strategy, budget: Budget) -> Self {
        Self {
            strategy,
            budget,
            tau: DEFAULT_TAU,
            stale_factor: DEFAULT_STALE_FACTOR,
            max_age: Some(DEFAULT_MAX_AGE),
        }
    }
}

/// A frame's fetches.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    /// Views fetched because they must be, with why.
    pub holes: Vec<(usize, Hole)>,
    /// Held views re-requested, oldest first.
    pub refresh: Vec<usize>,
    /// The budget in its unit (`None` for strategies without one).
    pub budget: Option<f64>,
    /// Planned cost of the holes, in the budget's unit.
    pub planned_holes: f64,
    /// Planned cost of the refresh, in the budget's unit.
    pub planned_refresh: f64,
    /// Whether an over-age mesh was refreshed past the budget.
    pub over_budget: bool,
}

impl Plan {
    /// Every view the frame fetches.
    pub fn fetches(&self) -> impl Iterator<Item = usize> + '_ {
        self.holes.iter().map(|h| h.0).chain(self.refresh.iter().copied())
    }
}

impl Policy {
    fn cost(&self, c: &Cost) -> f64 {
        match self.budget {
            Budget::Triangles(_) | Budget::OneView => c.triangles,
            Budget::Bytes(_) => c.bytes,
            Budget::Millis(_) => c.ms,
        }
    }

    /// Why `held` cannot serve `camera`, if it cannot.
    pub fn hole(&self, held: Option<&Held>, camera: &Camera) -> Option<Hole> {
        let Some(h) = held else {
            return Some(Hole::Missing);
        };
        let Some(reach) = &h.reach else {
            return None;
        };
        match reach.error_factor(camera) {
            Some(f) if f * h.tau <= self.stale_factor * self.tau => {}
            _ => return Some(Hole::Stale),
        }
        (!reach.covers(camera)).then_some(Hole::Uncovered)
    }

    /// The fetches of frame `frame` for `camera`, which draws the views
    /// `selected` (indices into `held`, one entry per reference view).
    pub fn plan(&self, frame: u32, camera: &Camera, selected: &[usize], held: &[Option<Held>]) -> Plan {
        let mut plan = Plan::default();
        if self.strategy == Strategy::Full {
            plan.refresh = selected.to_vec();
            return plan;
        }
        let mut kept = Vec::new();
        for &v in selected {
            match self.hole(held[v].as_ref(), camera) {
                Some(why) => plan.holes.push((v, why)),
                None => kept.push(v),
            }
        }
        match self.strategy {
            Strategy::Full => {}
            Strategy::Keyframe { every } => {
                if frame % every.max(1) == 0 {
                    plan.refresh = kept;
                }
            }
            Strategy::Balanced => {
                let known: Vec<f64> = selected
                    .iter()
                    .filter_map(|&v| held[v].as_ref().map(|h| self.cost(&h.cost)))
                    .collect();
                let mean = if known.is_empty() {
                    0.0
                } else {
                    known.iter().sum::<f64>() / known.len() as f64
                };
                let budget = match self.budget {
                    Budget::Triangles(n) | Budget::Bytes(n) | Budget::Millis(n) => n,
                    Budget::OneView => known.iter().copied().fold(0.0, f64::max),
                };
                plan.budget = Some(budget);
                // A view not held is planned at the mean of those that are.
                plan.planned_holes = plan
                    .holes
                    .iter()
                    .map(|&(v, _)| held[v].as_ref().map_or(mean, |h| self.cost(&h.cost)))
                    .sum();
                let mut left = budget - plan.planned_holes;
                kept.sort_by_key(|&v| (std::cmp::Reverse(held[v].as_ref().map_or(0, |h| h.age)), v));
                for v in kept {
                    let Some(h) = held[v].as_ref().filter(|h| h.age > 0) else {
                        break;
                    };
                    let c = self.cost(&h.cost);
                    // The oldest over-age mesh goes whatever is left.
                    let over_age = self.max_age.is_some_and(|m| h.age > m) && plan.refresh.is_empty();
                    if c > left && !over_age {
                        break;
                    }
                    if c > left {
                        plan.over_budget = true;
                    }
                    left -= c;
                    plan.planned_refresh += c;
                    plan.refresh.push(v);
                }
            }
        }
        plan
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};

    fn camera_at(eye: DVec3) -> Camera {
        dmesh_engine::sim::rig::camera(64, 48, 60.0, eye, eye + DVec3::Z).unwrap()
    }

    fn held(age: u32, triangles: f64, clearance: Option<f64>, culled: Vec<[f64; 4]>) -> Held {
        Held {
            age,
            tau: 1.0,
            reach: Some(Reach {
                view: camera_at(DVec3::ZERO),
                clearance,
                culled,
            }),
            cost: Cost {
                triangles,
                bytes: triangles * 10.0,
                ms: 1.0,
            },
        }
    }

    #[test]
    fn the_refresh_takes_the_oldest_first_and_never_passes_the_budget() {
        let p = Policy::new(Strategy::Balanced, Budget::Triangles(250.0));
        let cam = camera_at(DVec3::ZERO);
        let held: Vec<Option<Held>> = [(3, 100.0), (7, 100.0), (5, 100.0), (9, 300.0)]
            .iter()
            .map(|&(age, t)| Some(held(age, t, Some(10.0), vec![])))
            .collect();
        // The oldest (9) costs more than the whole budget: it ends the refresh.
        let plan = p.plan(1, &cam, &[0, 1, 2, 3], &held);
        assert!(plan.holes.is_empty());
        assert!(plan.refresh.is_empty());
        let plan = p.plan(1, &cam, &[0, 1, 2], &held);
        assert_eq!(plan.refresh, vec![1, 2]);
        assert_eq!(plan.planned_refresh, 200.0);
        assert!(plan.planned_holes + plan.planned_refresh <= plan.budget.unwrap());
    }

    #[test]
    fn an_over_age_mesh_is_refreshed_first_even_past_the_budget() {
        let p = Policy::new(Strategy::Balanced, Budget::Triangles(250.0));
        let cam = camera_at(DVec3::ZERO);
        // The oldest (11 > 10) costs more than the budget: refreshed anyway, alone.
        let views: Vec<Option<Held>> = [(11, 300.0), (5, 100.0)]
            .iter()
            .map(|&(age, t)| Some(held(age, t, Some(10.0), vec![])))
            .collect();
        let plan = p.plan(1, &cam, &[0, 1], &views);
        assert_eq!(plan.refresh, vec![0]);
        assert!(plan.over_budget);
        // Without the cap it blocks the refresh, as before.
        let uncapped = Policy { max_age: None, ..p };
        assert!(uncapped.plan(1, &cam, &[0, 1], &views).refresh.is_empty());
        // Within the cap, nothing passes the budget.
        let young: Vec<Option<Held>> = vec![Some(held(10, 300.0, Some(10.0), vec![]))];
        assert!(p.plan(1, &cam, &[0], &young).refresh.is_empty());
    }

    /// Frames of a walkthrough where holes take the whole budget every
    /// frame: with the cap no held mesh gets older than the cap plus the
    /// frames the over-age meshes ahead of it take; without it they age
    /// for ever.
    #[test]
    fn no_mesh_is_held_past_the_cap_plus_its_wait() {
        let cam = camera_at(DVec3::ZERO);
        for cap in [Some(10), None] {
            let p = Policy {
                max_age: cap,
                ..Policy::new(Strategy::Balanced, Budget::Triangles(100.0))
            };
            // Views 0..4 held, view 4 never held (a hole costing the mean, 100: the whole budget).
            let mut views: Vec<Option<Held>> = (0..4).map(|k| Some(held(k, 100.0, Some(10.0), vec![]))).collect();
            views.push(None);
            let mut oldest = 0;
            for frame in 0..100 {
                for h in views.iter_mut().flatten() {
                    h.age += 1;
                }
                let plan = p.plan(frame, &cam, &[0, 1, 2, 3, 4], &views);
                for &v in &plan.refresh {
                    views[v].as_mut().unwrap().age = 0;
                }
                views[4] = None;
                oldest = oldest.max(views.iter().flatten().map(|h| h.age).max().unwrap());
            }
            match cap {
                Some(cap) => assert!(oldest <= cap + 4, "oldest {oldest}"),
                None => assert!(oldest >= 100, "without a cap they age: {oldest}"),
            }
        }
    }

    #[test]
    fn holes_are_fetched_apart_from_the_budget_and_shrink_the_refresh() {
        let p = Policy::new(Strategy::Balanced, Budget::Triangles(250.0));
        let cam = camera_at(DVec3::ZERO);
        let mut views = vec![Some(held(4, 100.0, Some(10.0), vec![])); 3];
        views.push(None);
        // A missing view is planned at the mean held cost (100): one refresh fits.
        let plan = p.plan(1, &cam, &[0, 1, 2, 3], &views);
        assert_eq!(plan.holes, vec![(3, Hole::Missing)]);
        assert_eq!(plan.refresh.len(), 1);
        // Holes past the budget are still all fetched; nothing is refreshed.
        let p = Policy::new(Strategy::Balanced, Budget::Triangles(50.0));
        let plan = p.plan(1, &cam, &[0, 1, 2, 3], &views);
        assert_eq!(plan.holes.len(), 1);
        assert!(plan.refresh.is_empty());
    }

    #[test]
    fn a_moved_eye_makes_a_stale_hole_and_a_culled_part_in_view_an_uncovered_one() {
        let p = Policy::new(Strategy::Balanced, Budget::OneView);
        let near = held(1, 10.0, Some(1.0), vec![]);
        // d = 0.2 of a clearance of 1: factor 1.25 <= 1.5.
        assert_eq!(p.hole(Some(&near), &camera_at(DVec3::new(0.2, 0.0, 0.0))), None);
        // d = 0.5: factor 2 > 1.5.
        assert_eq!(
            p.hole(Some(&near), &camera_at(DVec3::new(0.5, 0.0, 0.0))),
            Some(Hole::Stale)
        );
        assert_eq!(
            p.hole(Some(&near), &camera_at(DVec3::new(1.0, 0.0, 0.0))),
            Some(Hole::Stale)
        );
        let culled = held(1, 10.0, None, vec![[0.0, 0.0, 5.0, 0.5]]);
        assert_eq!(p.hole(Some(&culled), &camera_at(DVec3::ZERO)), Some(Hole::Uncovered));
        let mut away = camera_at(DVec3::ZERO);
        away.rotation = DQuat::from_rotation_y(std::f64::consts::PI) * away.rotation;
        assert_eq!(p.hole(Some(&culled), &away), None);
        assert_eq!(p.hole(None, &away), Some(Hole::Missing));
    }

    #[test]
    fn strategy_lists_parse_by_name_and_refuse_unknown_ones() {
        let all = Strategy::parse_list("all", 4).unwrap();
        assert_eq!(
            all,
            vec![Strategy::Full, Strategy::Keyframe { every: 4 }, Strategy::Balanced]
        );
        assert_eq!(
            Strategy::parse_list(" balanced,full", 4).unwrap(),
            vec![Strategy::Balanced, Strategy::Full]
        );
        assert!(Strategy::parse_list("full,fast", 4)
            .unwrap_err()
            .to_string()
            .contains("\"fast\""));
    }

    #[test]
    fn keyframes_refresh_everything_every_k_frames_and_full_every_frame() {
        let cam = camera_at(DVec3::ZERO);
        let views = vec![Some(held(2, 10.0, Some(10.0), vec![])); 3];
        let k = Policy::new(Strategy::Keyframe { every: 4 }, Budget::OneView);
        assert_eq!(k.plan(8, &cam, &[0, 1, 2], &views).refresh, vec![0, 1, 2]);
        assert!(k.plan(9, &cam, &[0, 1, 2], &views).refresh.is_empty());
        let f = Policy::new(Strategy::Full, Budget::OneView);
        assert_eq!(f.plan(9, &cam, &[0, 2], &views).refresh, vec![0, 2]);
    }
}
