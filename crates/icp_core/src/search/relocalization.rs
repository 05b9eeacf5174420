//! Relocalization: the global search's hypotheses refined by ICP, ranked, with their ambiguity.
//!
//! Every candidate of [`GlobalMatcher::search`] is aligned by [`align`] from its lattice pose.
//! Refined poses that meet (closer than the search's `nms_distance` and `nms_angle`) are merged,
//! keeping the better. Candidates are ranked by their ICP inlier ratio (share of ALL scan points
//! within `max_correspondence_distance` of a visible plan point), ties by RMSE.
//!
//! The ranking does not pretend certainty: `ambiguity` is the runner-up's inlier ratio over the
//! best's (0 with a single candidate, 1 when two distinct places explain the scan equally well),
//! and the result is `ambiguous` when it is at least `1 - ambiguity_margin`: in a symmetric
//! building the scan alone cannot tell those places apart.

use crate::cancel::Cancel;
use crate::error::{invalid, Result};
use crate::icp::alignment::{align, IcpConfig, IcpResult};
use crate::maps::point_map::PointMap;
use crate::pose::{wrap_angle, Pose2};
use crate::search::global_search::{GlobalMatcher, SearchOutcome, SearchWindow};

/// How the refined candidates are reported.
#[derive(Clone, Debug, PartialEq)]
pub struct RankingConfig {
    /// Most candidates returned (the search may propose more).
    pub max_candidates: usize,
    /// A runner-up within this share of the best's inlier ratio makes the result ambiguous.
    pub ambiguity_margin: f64,
}

impl Default for RankingConfig {
    fn default() -> Self {
        Self { max_candidates: 5, ambiguity_margin: 0.05 }
    }
}

impl RankingConfig {
    /// Checks every value.
    pub fn validate(&self) -> Result<()> {
        if self.max_candidates == 0 {
            return Err(invalid("max_candidates", 0, "must be at least 1"));
        }
        if !(self.ambiguity_margin.is_finite() && (0.0..1.0).contains(&self.ambiguity_margin)) {
            return Err(invalid("ambiguity_margin", self.ambiguity_margin, "must be in [0, 1)"));
        }
        Ok(())
    }
}

/// One refined hypothesis.
#[derive(Clone, Debug, PartialEq)]
pub struct RankedCandidate {
    /// `T_map_base` after ICP.
    pub pose: Pose2,
    /// The ranking score: the ICP inlier ratio, 0..1.
    pub score: f64,
    /// The global search's score of the lattice pose it came from (mean likelihood, 0..1).
    pub search_score: f64,
    /// The search's lattice pose.
    pub search_pose: Pose2,
    /// The ICP alignment from `search_pose`.
    pub alignment: IcpResult,
}

/// Outcome of [`relocalize`].
#[derive(Clone, Debug, PartialEq)]
pub struct Relocalization {
    /// Distinct refined candidates, best first (empty when nothing scored `min_score`).
    pub candidates: Vec<RankedCandidate>,
    /// Runner-up score over best score, 0..1 (0 with fewer than two candidates).
    pub ambiguity: f64,
    /// `ambiguity >= 1 - ambiguity_margin`.
    pub ambiguous: bool,
    /// The global search (its candidates before refinement, rotations, nodes, completeness).
    pub search: SearchOutcome,
}

/// Finds the robot's pose from `scan` (robot frame, metres) with no initial guess: over the whole
/// plan (`window` `None`) or within a window. `matcher` must have been built from `map`.
///
/// `cancel` is polled during the search and the alignments (see [`GlobalMatcher::search`],
/// [`align`]); when it returns true relocalization stops with
/// [`crate::error::IcpError::Interrupted`] (callers that cannot be cancelled pass
/// [`crate::cancel::NEVER`]).
pub fn relocalize(
    map: &PointMap,
    matcher: &GlobalMatcher,
    scan: &[[f64; 2]],
    window: Option<&SearchWindow>,
    icp: &IcpConfig,
    ranking: &RankingConfig,
    cancel: Cancel<'_>,
) -> Result<Relocalization> {
    icp.validate()?;
    ranking.validate()?;
    let search = matcher.search(scan, window, cancel)?;
    refine(map, matcher, scan, search, icp, ranking, cancel)
}

/// The candidates of a finished search (`search`, of `scan` with `matcher`; see
/// [`crate::search::global_search::SearchRun`]) refined by ICP on `map` and ranked, as [`relocalize`]
/// does after its search.
///
/// `cancel` is polled during the alignments (see [`align`]); when it returns true refinement stops
/// with [`crate::error::IcpError::Interrupted`] (callers that cannot be cancelled pass
/// [`crate::cancel::NEVER`]).
pub fn refine(
    map: &PointMap,
    matcher: &GlobalMatcher,
    scan: &[[f64; 2]],
    search: SearchOutcome,
    icp: &IcpConfig,
    ranking: &RankingConfig,
    cancel: Cancel<'_>,
) -> Result<Relocalization> {
    icp.validate()?;
    ranking.validate()?;
    let mut refined = Vec::with_capacity(search.candidates.len());
    for c in &search.candidates {
        let alignment = align(map, scan, c.pose, icp, None, cancel)?;
        refined.push(RankedCandidate {
            pose: alignment.pose,
            score: alignment.inlier_ratio,
            search_score: c.score,
            search_pose: c.pose,
            alignment,
        });
    }
    refined.sort_by(|a, b| b.score.total_cmp(&a.score).then(a.alignment.rmse.total_cmp(&b.alignment.rmse)));
    let cfg = matcher.config();
    let mut candidates: Vec<RankedCandidate> = Vec::with_capacity(refined.len());
    for r in refined {
        let seen = candidates.iter().any(|c| {
            (c.pose.x - r.pose.x).hypot(c.pose.y - r.pose.y) < cfg.nms_distance
                && wrap_angle(c.pose.yaw - r.pose.yaw).abs() < cfg.nms_angle
        });
        if !seen {
            candidates.push(r);
        }
    }
    candidates.truncate(ranking.max_candidates);
    let ambiguity = match candidates.as_slice() {
        [best, second, ..] if best.score > 0.0 => second.score / best.score,
        _ => 0.0,
    };
    let ambiguous = candidates.len() >= 2 && ambiguity >= 1.0 - ranking.ambiguity_margin;
    Ok(Relocalization { candidates, ambiguity, ambiguous, search })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cancel;
    use crate::error::IcpError;
    use crate::search::global_search::tests::{asymmetric_floor, scan_from, segment};
    use crate::search::global_search::GlobalSearchConfig;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn setup(points: Vec<[f64; 2]>) -> (PointMap, GlobalMatcher) {
        let map = PointMap::new(points, None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        (map, matcher)
    }

    /// `relocalize` of the whole plan with the default ICP and ranking settings.
    fn relocalize_with_defaults(
        map: &PointMap,
        matcher: &GlobalMatcher,
        scan: &[[f64; 2]],
    ) -> Relocalization {
        let (icp, ranking) = (IcpConfig::default(), RankingConfig::default());
        relocalize(map, matcher, scan, None, &icp, &ranking, cancel::NEVER).unwrap()
    }

    #[test]
    fn refines_the_best_candidate_to_the_true_pose() {
        let (map, matcher) = setup(asymmetric_floor());
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let truth = Pose2::new(3.7, 6.1, -1.3);
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let out = relocalize_with_defaults(&map, &matcher, &scan);
        let best = &out.candidates[0];
        assert!((best.pose.x - truth.x).hypot(best.pose.y - truth.y) < 0.02, "{:?}", best.pose);
        assert!(wrap_angle(best.pose.yaw - truth.yaw).abs() < 0.005, "{:?}", best.pose);
        assert!(best.score > 0.95, "{}", best.score);
        assert!(!out.ambiguous, "ambiguity {}", out.ambiguity);
        assert!(out.ambiguity < 0.95);
        assert!(out.candidates.windows(2).all(|w| w[0].score >= w[1].score));
    }

    #[test]
    fn a_symmetric_room_is_ambiguous() {
        let mut pts = Vec::new();
        for (a, b) in [
            ([0.0, 0.0], [10.0, 0.0]),
            ([10.0, 0.0], [10.0, 6.0]),
            ([10.0, 6.0], [0.0, 6.0]),
            ([0.0, 6.0], [0.0, 0.0]),
        ] {
            segment(&mut pts, a, b);
        }
        let (map, matcher) = setup(pts);
        let mut rng = ChaCha8Rng::seed_from_u64(22);
        let truth = Pose2::new(2.6, 4.1, 2.0);
        let scan = scan_from(&map, truth, &mut rng, 0.005);
        let out = relocalize_with_defaults(&map, &matcher, &scan);
        assert!(out.candidates.len() >= 2);
        assert!(out.ambiguous, "ambiguity {}", out.ambiguity);
        assert!(out.ambiguity > 0.95);
        let mirrored = Pose2::new(10.0 - truth.x, 6.0 - truth.y, truth.yaw + std::f64::consts::PI);
        for p in [truth, mirrored] {
            assert!(
                out.candidates[..2].iter().any(|c| (c.pose.x - p.x).hypot(c.pose.y - p.y) < 0.03
                    && wrap_angle(c.pose.yaw - p.yaw).abs() < 0.01),
                "{p:?} not among the top two"
            );
        }
    }

    #[test]
    fn rejects_bad_settings() {
        let (map, matcher) = setup(asymmetric_floor());
        let scan: Vec<[f64; 2]> =
            (0..40).map(|i| [(i as f64 * 0.2).cos() * 3.0, (i as f64 * 0.2).sin()]).collect();
        let icp = IcpConfig::default();
        for bad in [
            RankingConfig { max_candidates: 0, ..RankingConfig::default() },
            RankingConfig { ambiguity_margin: 1.0, ..RankingConfig::default() },
            RankingConfig { ambiguity_margin: f64::NAN, ..RankingConfig::default() },
        ] {
            assert!(matches!(
                relocalize(&map, &matcher, &scan, None, &icp, &bad, cancel::NEVER),
                Err(IcpError::InvalidParameter { .. })
            ));
        }
        let bad_icp = IcpConfig { max_iterations: 0, ..icp };
        assert!(matches!(
            relocalize(&map, &matcher, &scan, None, &bad_icp, &RankingConfig::default(), cancel::NEVER),
            Err(IcpError::InvalidParameter { name: "max_iterations", .. })
        ));
    }
}
