//! Trimmed, coarse-to-fine point-to-point ICP of a scan against the plan.
//!
//! 1. The plan points visible from the initial guess are selected by ray casting (optional).
//! 2. For each stage of the correspondence schedule (distances `max_correspondence_distance *
//!    factor`), iterate: pair each scan point with its nearest plan point, drop pairs beyond the
//!    stage's distance, keep the closest `trim_ratio` share, solve the rigid update in closed form.
//! 3. Report the final pose with its inliers (pairs within `max_correspondence_distance`), RMSE,
//!    and covariance.
//!
//! The settings and the schedule of stages they imply are in [`crate::icp::icp_config`]; this
//! module holds the loop over the stages and the final scoring.

use crate::cancel::{self, Cancel};
use crate::error::{check_finite, invalid, IcpError, Result};
use crate::icp::acceleration::{extrapolation, truncated_cost, Update, COOLDOWN};
use crate::icp::candidate_cache::CandidateCache;
use crate::icp::correspondence::{
    find_pairs, trim, trim_auto, TargetSet, AUTO_TRIM_COARSE_SHARE, AUTO_TRIM_MIN_SHARE,
};
use crate::icp::covariance::{pose_covariance, InlierPair};
use crate::icp::rigid_solver::{RigidAccumulator, MIN_PAIRS};
use crate::icp::termination::{pair_fingerprint, stage_end};
use crate::icp::visible_through_index::VisibleThroughIndex;
use crate::maps::nearest_wall_index::{NearestWallIndex, SensorView};
use crate::maps::pair::Pair;
use crate::maps::point_map::PointMap;
use crate::pose::Pose2;
use nalgebra::Matrix3;

pub use crate::icp::icp_config::{stage_distance, visibility_range, SPACING_FLOOR};
pub use crate::icp::icp_config::{CorrespondenceSearch, IcpConfig};

/// Candidates are fetched within this many times a stage's distance, so a scan point may move
/// by (factor - 1) times the distance before its candidates must be fetched again
/// (see [`CandidateCache`]).
pub const CACHE_RADIUS_FACTOR: f64 = 2.0;

/// Largest stage distance (metres) for which the candidate cache is used.
pub const MAX_CACHED_DISTANCE: f64 = 1.0;

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
        inlier_pairs.push(InlierPair { beam: p.source, point: moved[p.source as usize], target: p.target });
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
mod tests;
