//! Trimmed, coarse-to-fine point-to-point ICP of a scan against the plan.
//!
//! 1. The plan points visible from the initial guess are selected by ray casting (optional).
//! 2. For each stage of the correspondence schedule (distances `max_correspondence_distance *
//!    factor`), iterate: pair each scan point with its nearest plan point, drop pairs beyond the
//!    stage's distance, keep the closest `trim_ratio` share, solve the rigid update in closed form.
//! 3. Report the final pose with its inliers (pairs within `max_correspondence_distance`), RMSE,
//!    and covariance.

use crate::cancel::{self, Cancel};
use crate::error::{check_finite, invalid, IcpError, Result};
use crate::icp::acceleration::{extrapolation, truncated_cost, Update, COOLDOWN};
use crate::icp::candidate_cache::CandidateCache;
use crate::icp::correspondence::{
    find_pairs, trim, trim_auto, TargetSet, AUTO_TRIM_COARSE_SHARE, AUTO_TRIM_MIN_SHARE,
};
use crate::icp::covariance::pose_covariance;
use crate::icp::rigid_solver::{RigidAccumulator, MIN_PAIRS};
use crate::icp::termination::{pair_fingerprint, stage_end, Tolerances};
use crate::icp::visible_through_index::VisibleThroughIndex;
use crate::maps::nearest_wall_index::{NearestWallIndex, SensorView};
use crate::maps::pair::Pair;
use crate::maps::point_map::PointMap;
use crate::pose::Pose2;
use nalgebra::Matrix3;

/// Candidates are fetched within this many times a stage's distance, so a scan point may move
/// by (factor - 1) times the distance before its candidates must be fetched again
/// (see [`CandidateCache`]).
pub const CACHE_RADIUS_FACTOR: f64 = 2.0;

/// Largest stage distance (metres) for which the candidate cache is used.
pub const MAX_CACHED_DISTANCE: f64 = 1.0;

/// The range (metres) of the visibility cast for `scan` (robot frame): `config.visibility_range`,
/// or the scan's farthest point plus the largest stage distance, so that every plan point a scan
/// point could pair with is cast.
pub fn visibility_range(scan: &[[f64; 2]], config: &IcpConfig) -> f64 {
    let range = match config.visibility_range {
        Some(r) => r,
        None => {
            let largest_factor = config.correspondence_schedule.iter().copied().fold(1.0, f64::max);
            let farthest = scan.iter().map(|p| p[0].hypot(p[1])).fold(0.0, f64::max);
            farthest + largest_factor * config.max_correspondence_distance
        }
    };
    // A huge correspondence distance can make the sum overflow; nothing lies beyond a few times
    // the coordinate limit anyway (found by the fuzz target).
    range.min(4.0 * crate::error::MAX_COORDINATE)
}

/// A stage's rejection distance: `factor * max_distance`, but never below `SPACING_FLOOR` plan
/// point spacings (nor above `max_distance`): closer than that, correct pairs are lost to the
/// plan's sampling (a scan point between two samples is half a spacing from both) plus noise.
pub fn stage_distance(factor: f64, max_distance: f64, spacing: f64) -> f64 {
    let floor = (SPACING_FLOOR * spacing).min(max_distance);
    (factor * max_distance).max(floor)
}

/// See [`stage_distance`].
pub const SPACING_FLOOR: f64 = 2.0;

/// Settings of one alignment. Distances in metres, angles in radians.
#[derive(Clone, Debug, PartialEq)]
pub struct IcpConfig {
    /// Pairs farther apart than this are outliers (things not in the plan).
    pub max_correspondence_distance: f64,
    /// Most iterations over all stages.
    pub max_iterations: usize,
    /// Share (0, 1] of the in-range pairs, the closest ones, used by each update (with
    /// `auto_trim`: the most that may be kept).
    pub trim_ratio: f64,
    /// Drop pairs beyond three robust standard deviations of the pair distances at every
    /// iteration ([`crate::icp::correspondence::trim_auto`]); `trim_ratio` caps what is kept.
    pub auto_trim: bool,
    /// A stage stops when a step moves less than this (and rotates less than `rotation_tolerance`).
    pub translation_tolerance: f64,
    /// See `translation_tolerance`. Both zero: every iteration runs.
    pub rotation_tolerance: f64,
    /// Use every k-th scan point for the iterations (all points are scored at the end).
    pub subsample: usize,
    /// Stage distances as factors of `max_correspondence_distance`, applied in order.
    pub correspondence_schedule: Vec<f64>,
    /// Match only against the plan points visible from the initial guess.
    pub use_visibility: bool,
    /// Extrapolate slowly converging iterations (see [`crate::icp::acceleration`]).
    pub accelerate: bool,
    /// Range for the visibility ray casting; `None`: the scan's farthest point plus the largest
    /// stage distance.
    pub visibility_range: Option<f64>,
    /// How nearest plan points are found.
    pub search: CorrespondenceSearch,
}

/// How the nearest plan point of a scan point is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CorrespondenceSearch {
    /// The plan's precomputed nearest-wall index ([`crate::maps::nearest_wall_index`]): a few
    /// nanoseconds per look-up. `use_visibility` refuses pairings with the far face of a wall
    /// ([`crate::visibility::wall_facing`]) instead of ray casting. Alignments whose largest stage distance
    /// exceeds the index's reach, or plans whose index cannot be built, use the KD-tree.
    #[default]
    WallIndex,
    /// Exact KD-tree queries (against the points visible from the initial guess with
    /// `use_visibility`), reused across iterations by a [`CandidateCache`].
    KdTree,
}

impl Default for IcpConfig {
    fn default() -> Self {
        Self {
            max_correspondence_distance: 0.25,
            max_iterations: 30,
            trim_ratio: 1.0,
            auto_trim: false,
            translation_tolerance: 1e-4,
            rotation_tolerance: 1e-4,
            subsample: 1,
            correspondence_schedule: vec![1.0, 0.5, 0.25],
            use_visibility: true,
            accelerate: true,
            visibility_range: None,
            search: CorrespondenceSearch::default(),
        }
    }
}

fn positive_finite(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(invalid(name, v, "must be a positive finite number"))
    }
}

impl IcpConfig {
    /// Checks every value; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        positive_finite("max_correspondence_distance", self.max_correspondence_distance)?;
        if self.max_iterations == 0 {
            return Err(invalid("max_iterations", 0, "must be at least 1"));
        }
        if !(self.trim_ratio > 0.0 && self.trim_ratio <= 1.0) {
            return Err(invalid("trim_ratio", self.trim_ratio, "must be in (0, 1]"));
        }
        for (name, v) in [
            ("translation_tolerance", self.translation_tolerance),
            ("rotation_tolerance", self.rotation_tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(name, v, "must be a finite number >= 0 (0 disables it)"));
            }
        }
        if self.subsample == 0 {
            return Err(invalid("subsample", 0, "must be at least 1"));
        }
        if self.correspondence_schedule.is_empty() {
            return Err(invalid("correspondence_schedule", "[]", "needs at least one stage"));
        }
        for &f in &self.correspondence_schedule {
            positive_finite("correspondence_schedule factor", f)?;
        }
        if let Some(r) = self.visibility_range {
            positive_finite("visibility_range", r)?;
        }
        Ok(())
    }

    fn tolerances(&self) -> Tolerances {
        Tolerances { translation: self.translation_tolerance, rotation: self.rotation_tolerance }
    }
}

/// Outcome of one alignment.
#[derive(Clone, Debug, PartialEq)]
pub struct IcpResult {
    /// `T_map_base`: the robot's pose in the map.
    pub pose: Pose2,
    /// The last stage ended on the tolerances or at a fixed point, not on the iteration budget.
    pub converged: bool,
    /// Iterations run over all stages.
    pub iterations: usize,
    /// Scan points within `max_correspondence_distance` of a (visible) plan point at `pose`.
    pub num_inliers: usize,
    /// `num_inliers` over all scan points.
    pub inlier_ratio: f64,
    /// Root mean square distance of the inliers to their plan points, metres (NaN without inliers).
    pub rmse: f64,
    /// Covariance over (x, y, yaw); `inf` on the diagonal when the pose is not constrained.
    pub covariance: Matrix3<f64>,
    /// The wall-normal constraint `H = sum J J^T` of the inliers (see
    /// [`crate::icp::covariance::PoseUncertainty::constraint`]).
    pub constraint: Matrix3<f64>,
    /// Per input scan point: is it an inlier.
    pub inlier_mask: Vec<bool>,
    /// Plan points matched against (the visible ones, or all).
    pub num_target_points: usize,
}

/// Aligns `scan` (points in the robot frame, metres) to `map` starting from `initial`
/// (`T_map_base` guess).
///
/// `visible` are the plan points visible from `initial` already cast (for instance
/// [`crate::visibility::wall_view::WallView::visible`], cast once for the alignment and the occlusion of
/// returns): the KD-tree search with `use_visibility` matches against them instead of casting its
/// own. `None` casts them here. Other searches ignore them. An index that is not a plan point is
/// an error.
///
/// `cancel` is polled before every iteration (and while the plan's nearest-wall index is built,
/// when this alignment is the first to need it); when it returns true the alignment stops with
/// [`IcpError::Interrupted`]: a budget of `max_iterations` that would run for hours can still be
/// stopped. Callers that cannot be cancelled pass [`cancel::NEVER`].
pub fn align(
    map: &PointMap,
    scan: &[[f64; 2]],
    initial: Pose2,
    config: &IcpConfig,
    visible: Option<&[u32]>,
    cancel: Cancel<'_>,
) -> Result<IcpResult> {
    if let Some(&bad) = visible.and_then(|v| v.iter().find(|&&i| i as usize >= map.len())) {
        return Err(invalid("visible point index", bad, "must index a plan point"));
    }
    config.validate()?;
    if scan.is_empty() {
        return Err(IcpError::Empty { what: "scan" });
    }
    check_finite("scan", scan)?;
    if !initial.is_finite() {
        return Err(invalid("initial_pose", format!("{initial:?}"), "must be finite"));
    }
    check_finite("initial_pose", &[[initial.x, initial.y]])?;
    let used: Vec<[f64; 2]> = scan.iter().step_by(config.subsample).copied().collect();
    if used.len() < MIN_PAIRS {
        return Err(IcpError::TooFewPoints {
            what: "scan (after subsampling)",
            got: used.len(),
            need: MIN_PAIRS,
        });
    }
    let largest_factor = config.correspondence_schedule.iter().copied().fold(1.0, f64::max);
    let largest_distance = largest_factor * config.max_correspondence_distance;
    let indexed = match config.search {
        CorrespondenceSearch::WallIndex => match map.wall_index(cancel) {
            Err(IcpError::Interrupted) => return Err(IcpError::Interrupted),
            built => built.ok().filter(|w| largest_distance <= w.reach()),
        },
        CorrespondenceSearch::KdTree => None,
    };
    let target = if indexed.is_some() {
        TargetSet::Full(map)
    } else if config.use_visibility {
        let visible = match visible {
            Some(given) => given.to_vec(),
            None => map.visible_from(initial, visibility_range(scan, config))?,
        };
        if visible.len() >= MIN_PAIRS {
            TargetSet::subset(map, visible).unwrap_or(TargetSet::Full(map))
        } else {
            TargetSet::Full(map)
        }
    } else {
        TargetSet::Full(map)
    };

    // Matching against the visible subset: the plan's index still answers every look-up whose
    // nearest wall point is visible (the same pairs, at a fraction of the cost).
    // (When the index is already built, by the index search or a caller: it answers the same pairs
    // as the subset's KD-tree, 0.1-0.4 ms faster per update on the real logs, but building it
    // takes 0.3-1.6 s on their plans, more than a log of 1,000-2,000 scans gains, and built on a
    // thread beside the tracking it stalled updates by 30-40 ms while it allocated.)
    let through_index = match (indexed, &target) {
        (None, TargetSet::Subset { .. }) => {
            map.built_wall_index().and_then(|w| VisibleThroughIndex::new(w, &target, largest_distance))
        }
        _ => None,
    };

    let tolerances = config.tolerances();
    // Lever arm that turns a rotation into metres for the extrapolation: RMS range of the scan.
    let scan_radius =
        (used.iter().map(|p| p[0] * p[0] + p[1] * p[1]).sum::<f64>() / used.len() as f64).sqrt();
    let stages = config.correspondence_schedule.len();
    // Wrapped here: a Pose2 built from its public fields may carry any yaw, and a result whose
    // iterations stop at once (too few pairs) returns it unchanged.
    let mut pose = Pose2::new(initial.x, initial.y, initial.yaw);
    let mut iterations = 0usize;
    let mut converged = false;
    let mut moved = Vec::with_capacity(used.len());
    let mut pairs: Vec<Pair> = Vec::with_capacity(used.len());
    // Beyond a metre a candidate list holds whole rooms: plain KD-tree queries are cheaper.
    let use_cache = indexed.is_none() && through_index.is_none() && largest_distance <= MAX_CACHED_DISTANCE;
    let mut cache = CandidateCache::new(CACHE_RADIUS_FACTOR * largest_distance);
    let bearings = if indexed.is_some() { SensorView::bearings_of(&used) } else { Vec::new() };
    'stages: for (stage, factor) in config.correspondence_schedule.iter().enumerate() {
        let distance = stage_distance(*factor, config.max_correspondence_distance, map.spacing());
        let end = stage_end(stage, stages, config.max_iterations);
        converged = false;
        let mut previous_fingerprint = None;
        let mut last_update: Option<Update> = None;
        // Pose before an extrapolation and the cost it must not exceed.
        let mut pending: Option<(Pose2, f64)> = None;
        let mut cooldown = 0usize;
        while iterations < end {
            cancel::check(cancel)?;
            pose.transform_points(&used, &mut moved);
            if let Some(wall) = indexed {
                let view = config.use_visibility.then(|| SensorView::new(&bearings, pose.yaw));
                wall.find_pairs(&moved, distance, view, &mut pairs);
            } else if let Some(through) = &through_index {
                through.find_pairs(&target, &moved, distance, &mut pairs);
            } else if use_cache {
                cache.find_pairs(&target, &moved, distance, &mut pairs);
            } else {
                find_pairs(&target, &moved, distance, &mut pairs);
            }
            if let Some((before, bound)) = pending.take() {
                if truncated_cost(&pairs, used.len(), distance) > bound {
                    // The jump made the fit worse: go back and spend this iteration there.
                    pose = before;
                    last_update = None;
                    cooldown = COOLDOWN;
                    iterations += 1;
                    continue;
                }
            }
            let cost = truncated_cost(&pairs, used.len(), distance);
            if config.auto_trim {
                // Before the last stage the fit may still be far off and the inliers' residuals
                // large: keep at least AUTO_TRIM_COARSE_SHARE of the pairs there.
                let least = if stage + 1 == stages { AUTO_TRIM_MIN_SHARE } else { AUTO_TRIM_COARSE_SHARE };
                trim_auto(&mut pairs, config.trim_ratio, least, MIN_PAIRS);
            } else {
                trim(&mut pairs, config.trim_ratio, MIN_PAIRS);
            }
            let acc = RigidAccumulator::of_pairs(&pairs, &moved, map.points());
            let Some(step) = acc.solve() else {
                // Too few pairs to continue: keep the pose reached so far.
                converged = false;
                break 'stages;
            };
            pose = step.compose(&pose);
            iterations += 1;
            let fingerprint = pair_fingerprint(&pairs);
            let fixed_point = previous_fingerprint == Some(fingerprint);
            previous_fingerprint = Some(fingerprint);
            converged = fixed_point || tolerances.is_small(&step);
            if converged && !tolerances.disabled() {
                break;
            }
            // Pairs there are: the step was solved from them.
            let centroid = acc.source_mean().unwrap_or_default();
            let update = Update::new(&step, centroid);
            if config.accelerate && cooldown == 0 && !fixed_point {
                if let Some(jump) =
                    last_update.as_ref().and_then(|prev| extrapolation(prev, &update, scan_radius))
                {
                    pending = Some((pose, cost));
                    pose = jump.compose(&pose);
                }
            }
            cooldown = cooldown.saturating_sub(1);
            last_update = Some(update);
        }
    }
    let search = match (indexed, &through_index) {
        (Some(wall), _) => Search::Indexed(wall),
        (None, Some(through)) => Search::ThroughIndex(through),
        (None, None) if use_cache && config.subsample == 1 => Search::Cached(&mut cache),
        (None, None) => Search::Plain,
    };
    let outcome = LoopOutcome { pose, converged, iterations };
    Ok(score(map, &target, search, scan, config, outcome))
}

/// How the final scoring finds its pairs.
enum Search<'a> {
    Indexed(&'a NearestWallIndex),
    /// The visible subset, through the plan's index.
    ThroughIndex(&'a VisibleThroughIndex<'a>),
    /// The iterations ran on every scan point, so the cache holds candidates for all of them.
    Cached(&'a mut CandidateCache),
    Plain,
}

/// Where the iterations ended.
struct LoopOutcome {
    pose: Pose2,
    converged: bool,
    iterations: usize,
}

/// Final scoring of all scan points at `pose`: inliers, RMSE, covariance.
fn score(
    map: &PointMap,
    target: &TargetSet<'_>,
    search: Search<'_>,
    scan: &[[f64; 2]],
    config: &IcpConfig,
    LoopOutcome { pose, converged, iterations }: LoopOutcome,
) -> IcpResult {
    let mut moved = Vec::with_capacity(scan.len());
    pose.transform_points(scan, &mut moved);
    let mut pairs = Vec::with_capacity(scan.len());
    let d = config.max_correspondence_distance;
    match search {
        Search::Indexed(wall) => {
            let bearings = SensorView::bearings_of(scan);
            let view = config.use_visibility.then(|| SensorView::new(&bearings, pose.yaw));
            wall.find_pairs(&moved, d, view, &mut pairs)
        }
        Search::ThroughIndex(through) => through.find_pairs(target, &moved, d, &mut pairs),
        Search::Cached(cache) if d <= cache.radius() => cache.find_pairs(target, &moved, d, &mut pairs),
        _ => find_pairs(target, &moved, d, &mut pairs),
    }
    let mut inlier_mask = vec![false; scan.len()];
    let mut sum_sq = 0.0;
    let mut inlier_pairs = Vec::with_capacity(pairs.len());
    for p in &pairs {
        inlier_mask[p.source as usize] = true;
        sum_sq += p.sq_dist;
        inlier_pairs.push((moved[p.source as usize], p.target));
    }
    let num_inliers = pairs.len();
    let rmse = if num_inliers > 0 { (sum_sq / num_inliers as f64).sqrt() } else { f64::NAN };
    let uncertainty = pose_covariance(map, map.normals(), &pose, &inlier_pairs);
    IcpResult {
        pose,
        converged,
        iterations,
        num_inliers,
        inlier_ratio: num_inliers as f64 / scan.len() as f64,
        rmse,
        covariance: uncertainty.covariance,
        constraint: uncertainty.constraint,
        inlier_mask,
        num_target_points: target.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Wall points of an L-shaped pair of rooms with 0.2 m thick walls, every 0.05 m on both faces.
    fn rooms() -> Vec<[f64; 2]> {
        let mut pts = Vec::new();
        let mut segment = |a: [f64; 2], b: [f64; 2]| {
            let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            let n = (len / 0.05).round() as usize;
            for i in 0..=n {
                let t = i as f64 / n as f64;
                pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        };
        for (a, b) in [
            ([0.0, 0.0], [8.0, 0.0]),
            ([8.0, 0.0], [8.0, 5.0]),
            ([8.0, 5.0], [0.0, 5.0]),
            ([0.0, 5.0], [0.0, 0.0]),
            ([-0.2, -0.2], [8.2, -0.2]),
            ([8.2, -0.2], [8.2, 5.2]),
            ([8.2, 5.2], [-0.2, 5.2]),
            ([-0.2, 5.2], [-0.2, -0.2]),
            ([3.0, 0.0], [3.0, 3.0]),
            ([3.2, 0.0], [3.2, 3.0]),
            ([3.0, 3.0], [3.2, 3.0]),
        ] {
            segment(a, b);
        }
        pts
    }

    /// A scan seen from `truth` (robot frame): points on the visible wall faces, placed at random
    /// along the wall (as beams would hit it, not on the plan's sample points), with uniform
    /// noise of `noise` metres.
    fn scan_from(map: &PointMap, truth: Pose2, rng: &mut ChaCha8Rng, noise: f64) -> Vec<[f64; 2]> {
        let inv = truth.inverse();
        map.visible_from(truth, 20.0)
            .unwrap()
            .iter()
            .map(|&i| {
                let q = map.points()[i as usize];
                let n = map.normals()[i as usize];
                let along = rng.random_range(-0.02..=0.02);
                let w = [q[0] - n[1] * along, q[1] + n[0] * along];
                let p = inv.transform_point(w);
                [p[0] + rng.random_range(-noise..=noise), p[1] + rng.random_range(-noise..=noise)]
            })
            .collect()
    }

    #[test]
    fn recovers_known_transform_from_offset_guess() {
        let map = PointMap::new(rooms(), None).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let truth = Pose2::new(5.5, 2.2, 0.4);
        let scan = scan_from(&map, truth, &mut rng, 0.0);
        let guess = Pose2::new(5.7, 2.05, 0.45);
        let res = align(&map, &scan, guess, &IcpConfig::default(), None, cancel::NEVER).unwrap();
        // Point-to-point pairs with 5 cm plan spacing: a few millimetres of discretisation error.
        assert!((res.pose.x - truth.x).abs() < 0.005, "{:?}", res.pose);
        assert!((res.pose.y - truth.y).abs() < 0.005, "{:?}", res.pose);
        assert!((res.pose.yaw - truth.yaw).abs() < 0.002, "{:?}", res.pose);
        assert!(res.converged);
        assert_eq!(res.num_inliers, scan.len());
        assert!(res.rmse < 0.02, "rmse {}", res.rmse);
    }

    #[test]
    fn zero_tolerances_run_every_iteration() {
        let map = PointMap::new(rooms(), None).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let truth = Pose2::new(5.0, 2.5, -0.2);
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let cfg = IcpConfig {
            translation_tolerance: 0.0,
            rotation_tolerance: 0.0,
            max_iterations: 17,
            ..IcpConfig::default()
        };
        let res = align(&map, &scan, Pose2::new(5.1, 2.4, -0.15), &cfg, None, cancel::NEVER).unwrap();
        assert_eq!(res.iterations, 17);
        assert!(res.converged, "a fixed point should be reached within 17 iterations");
        let early =
            align(&map, &scan, Pose2::new(5.1, 2.4, -0.15), &IcpConfig::default(), None, cancel::NEVER)
                .unwrap();
        assert!(
            early.iterations < IcpConfig::default().max_iterations,
            "tolerances should stop early, ran {}",
            early.iterations
        );
        assert!((early.pose.x - res.pose.x).abs() < 1e-3);
    }

    #[test]
    fn a_cancel_hook_stops_an_endless_budget_and_a_silent_one_changes_nothing() {
        let map = PointMap::new(rooms(), None).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let scan = scan_from(&map, Pose2::new(5.0, 2.5, -0.2), &mut rng, 0.01);
        let guess = Pose2::new(5.1, 2.4, -0.15);
        for search in [CorrespondenceSearch::WallIndex, CorrespondenceSearch::KdTree] {
            // Zero tolerances: every one of usize::MAX iterations would run (for centuries).
            let endless = IcpConfig {
                translation_tolerance: 0.0,
                rotation_tolerance: 0.0,
                max_iterations: usize::MAX,
                search,
                ..IcpConfig::default()
            };
            let polls = std::cell::Cell::new(0usize);
            let after_200 = || {
                polls.set(polls.get() + 1);
                polls.get() > 200
            };
            let out = align(&map, &scan, guess, &endless, None, &after_200);
            assert_eq!(out, Err(IcpError::Interrupted));
            // It stopped at the first poll that asked: no iteration ran after it.
            assert_eq!(polls.get(), 201);
            let bounded = IcpConfig { max_iterations: 17, ..endless };
            let polls = std::cell::Cell::new(0usize);
            let counting = || {
                polls.set(polls.get() + 1);
                false
            };
            let res = align(&map, &scan, guess, &bounded, None, &counting).unwrap();
            assert_eq!(res, align(&map, &scan, guess, &bounded, None, cancel::NEVER).unwrap());
            // At least once per iteration (the index, built already, polls no more).
            assert!(polls.get() >= 17, "{} polls", polls.get());
        }
    }

    #[test]
    fn an_interrupted_index_build_is_not_kept() {
        let map = PointMap::new(rooms(), None).unwrap();
        let scan = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
        let out = align(&map, &scan, Pose2::new(5.0, 2.5, 0.0), &IcpConfig::default(), None, &|| true);
        assert_eq!(out, Err(IcpError::Interrupted));
        assert!(map.built_wall_index().is_none());
        assert!(map.wall_index(cancel::NEVER).is_ok() && map.built_wall_index().is_some());
    }

    #[test]
    fn budget_exhaustion_is_not_convergence() {
        let map = PointMap::new(rooms(), None).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let truth = Pose2::new(5.0, 2.5, 0.0);
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let cfg = IcpConfig { max_iterations: 1, ..IcpConfig::default() };
        let res = align(&map, &scan, Pose2::new(5.2, 2.4, 0.05), &cfg, None, cancel::NEVER).unwrap();
        assert_eq!(res.iterations, 1);
        assert!(!res.converged);
    }

    #[test]
    fn outliers_beyond_max_distance_are_ignored() {
        let map = PointMap::new(rooms(), None).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let truth = Pose2::new(6.0, 1.5, 0.1);
        let mut scan = scan_from(&map, truth, &mut rng, 0.005);
        let clean = scan.len();
        // A cabinet 0.5 m from the wall: not in the plan.
        for i in 0..150 {
            scan.push(truth.inverse().transform_point([4.0 + i as f64 * 0.01, 4.5]));
        }
        let res = align(&map, &scan, Pose2::new(6.1, 1.6, 0.12), &IcpConfig::default(), None, cancel::NEVER)
            .unwrap();
        assert!((res.pose.x - truth.x).abs() < 0.01 && (res.pose.y - truth.y).abs() < 0.01, "{:?}", res.pose);
        assert!(res.inlier_mask[clean..].iter().all(|&m| !m), "cabinet points counted as inliers");
        assert!(res.num_inliers >= clean * 95 / 100);
    }

    #[test]
    fn a_huge_correspondence_distance_finishes_and_matches_the_plain_search() {
        // Without outlier rejection (every pair counts) the candidate cache is skipped.
        let map = PointMap::new(rooms(), None).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let truth = Pose2::new(5.0, 2.0, 0.1);
        let scan = scan_from(&map, truth, &mut rng, 0.005);
        let cfg =
            IcpConfig { max_correspondence_distance: 50.0, use_visibility: false, ..IcpConfig::default() };
        let res = align(&map, &scan, Pose2::new(5.05, 2.05, 0.12), &cfg, None, cancel::NEVER).unwrap();
        assert_eq!(res.num_inliers, scan.len());
        assert!((res.pose.x - truth.x).abs() < 0.02 && (res.pose.y - truth.y).abs() < 0.02, "{:?}", res.pose);
    }

    #[test]
    fn the_result_yaw_is_wrapped_even_when_no_iteration_runs() {
        // Found by the core fuzz target `align`: an unwrapped initial yaw (-1e9 rad, set through
        // the public fields) came back as the result's yaw when the scan found no pairs.
        let map = PointMap::new(rooms(), None).unwrap();
        let initial = Pose2 { x: 1e6, y: 1e6, yaw: -1e9 };
        let res = align(
            &map,
            &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            initial,
            &IcpConfig::default(),
            None,
            cancel::NEVER,
        )
        .unwrap();
        assert_eq!(res.iterations, 0);
        assert!(
            res.pose.yaw > -std::f64::consts::PI && res.pose.yaw <= std::f64::consts::PI,
            "{:?}",
            res.pose
        );
        assert_eq!(res.pose.yaw, crate::pose::wrap_angle(-1e9));
    }

    #[test]
    fn both_correspondence_searches_reach_the_same_pose() {
        let map = PointMap::new(rooms(), None).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        for (truth, guess) in [
            (Pose2::new(5.5, 2.2, 0.4), Pose2::new(5.7, 2.05, 0.45)),
            (Pose2::new(1.5, 2.5, -2.0), Pose2::new(1.4, 2.6, -2.05)),
            (Pose2::new(6.7, 3.9, 2.9), Pose2::new(6.6, 4.0, 2.95)),
        ] {
            let scan = scan_from(&map, truth, &mut rng, 0.01);
            let fast = align(&map, &scan, guess, &IcpConfig::default(), None, cancel::NEVER).unwrap();
            let kd = IcpConfig { search: CorrespondenceSearch::KdTree, ..IcpConfig::default() };
            let exact = align(&map, &scan, guess, &kd, None, cancel::NEVER).unwrap();
            for res in [&fast, &exact] {
                assert!((res.pose.x - truth.x).hypot(res.pose.y - truth.y) < 0.005, "{:?}", res.pose);
            }
            assert!((fast.pose.x - exact.pose.x).hypot(fast.pose.y - exact.pose.y) < 0.002);
            assert!((fast.inlier_ratio - exact.inlier_ratio).abs() < 0.01);
            // The index matches against the whole plan, the KD-tree against the visible subset.
            assert_eq!(fast.num_target_points, map.len());
            assert!(exact.num_target_points < map.len());
        }
    }

    #[test]
    fn a_given_visible_set_is_the_one_matched_against() {
        let map = PointMap::new(rooms(), None).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let (truth, guess) = (Pose2::new(5.5, 2.2, 0.4), Pose2::new(5.6, 2.1, 0.42));
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let kd = IcpConfig { search: CorrespondenceSearch::KdTree, ..IcpConfig::default() };
        // The set the alignment would cast itself: the same result, bit for bit.
        let cast = map.visible_from(guess, visibility_range(&scan, &kd)).unwrap();
        assert_eq!(
            align(&map, &scan, guess, &kd, Some(&cast), cancel::NEVER).unwrap(),
            align(&map, &scan, guess, &kd, None, cancel::NEVER).unwrap()
        );
        // Only the right room's walls (x > 3.1): the scan points on the left room's walls (more
        // than the largest pair distance, 0.25 m, from them) find nothing to pair with.
        let right: Vec<u32> = cast.iter().copied().filter(|&i| map.points()[i as usize][0] > 3.1).collect();
        let seen = align(&map, &scan, guess, &kd, Some(&right), cancel::NEVER).unwrap();
        assert_eq!(seen.num_target_points, right.len());
        let left = scan.iter().filter(|p| truth.transform_point(**p)[0] < 2.8).count();
        assert!(
            left > 20 && seen.num_inliers <= scan.len() - left,
            "{} inliers, {left} on the left",
            seen.num_inliers
        );
        // An index that is not a plan point is refused.
        let bad = [0, map.len() as u32];
        assert!(matches!(
            align(&map, &scan, guess, &kd, Some(&bad), cancel::NEVER),
            Err(IcpError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn rejects_bad_input() {
        let map = PointMap::new(rooms(), None).unwrap();
        let cfg = IcpConfig::default();
        let p = Pose2::new(1.0, 1.0, 0.0);
        assert_eq!(
            align(&map, &[], p, &cfg, None, cancel::NEVER).unwrap_err(),
            IcpError::Empty { what: "scan" }
        );
        assert!(matches!(
            align(&map, &[[0.0, 0.0], [1.0, f64::INFINITY]], p, &cfg, None, cancel::NEVER),
            Err(IcpError::NonFinite { row: 1, .. })
        ));
        assert!(matches!(
            align(&map, &[[0.0, 0.0], [1.0, 0.0]], p, &cfg, None, cancel::NEVER),
            Err(IcpError::TooFewPoints { .. })
        ));
        for bad in [
            IcpConfig { max_correspondence_distance: 0.0, ..cfg.clone() },
            IcpConfig { max_correspondence_distance: f64::NAN, ..cfg.clone() },
            IcpConfig { max_iterations: 0, ..cfg.clone() },
            IcpConfig { trim_ratio: 0.0, ..cfg.clone() },
            IcpConfig { trim_ratio: 1.5, ..cfg.clone() },
            IcpConfig { translation_tolerance: -1.0, ..cfg.clone() },
            IcpConfig { subsample: 0, ..cfg.clone() },
            IcpConfig { correspondence_schedule: vec![], ..cfg.clone() },
            IcpConfig { correspondence_schedule: vec![1.0, -0.5], ..cfg.clone() },
            IcpConfig { visibility_range: Some(0.0), ..cfg.clone() },
        ] {
            assert!(
                matches!(
                    align(&map, &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], p, &bad, None, cancel::NEVER),
                    Err(IcpError::InvalidParameter { .. })
                ),
                "{bad:?}"
            );
        }
    }
}
