//! Correspondences: every (transformed) scan point paired with its nearest plan point, kept only
//! when nearer than a maximum distance (furniture, people and robots are not in the plan).

use crate::maps::kd_tree::Tree2;
use crate::maps::pair::Pair;
use crate::maps::point_map::PointMap;

/// The plan points a scan is matched against: all of them, or a subset (e.g. the visible ones)
/// with its own KD-tree. Either way results are reported as indices into the full plan.
#[derive(Debug)]
pub enum TargetSet<'a> {
    /// Every point of the plan.
    Full(&'a PointMap),
    /// A subset of the plan.
    Subset {
        /// The plan.
        map: &'a PointMap,
        /// Plan indices of the subset.
        indices: Vec<u32>,
        /// KD-tree over the subset (items index into `indices`).
        tree: Tree2,
    },
}

impl<'a> TargetSet<'a> {
    /// The subset of `map` given by `indices` (plan indices), or `None` when `indices` is empty.
    pub fn subset(map: &'a PointMap, indices: Vec<u32>) -> Option<Self> {
        if indices.is_empty() {
            return None;
        }
        let pts: Vec<[f64; 2]> = indices.iter().map(|&i| map.points()[i as usize]).collect();
        let tree = Tree2::new_from_slice(&pts);
        Some(Self::Subset { map, indices, tree })
    }

    /// The whole plan.
    pub fn map(&self) -> &'a PointMap {
        match self {
            Self::Full(map) | Self::Subset { map, .. } => map,
        }
    }

    /// Number of candidate points.
    pub fn len(&self) -> usize {
        match self {
            Self::Full(map) => map.len(),
            Self::Subset { indices, .. } => indices.len(),
        }
    }

    /// Never true: both variants hold at least one point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Plan index and squared distance of the candidate nearest to `q`.
    #[inline]
    pub fn nearest(&self, q: [f64; 2]) -> (u32, f64) {
        match self {
            Self::Full(map) => map.nearest(q),
            Self::Subset { indices, tree, .. } => {
                let nn = tree.nearest_one(&q);
                (indices[nn.item as usize], nn.distance)
            }
        }
    }
}

/// Pairs every point of `transformed` (scan points already in the map frame) with its nearest
/// target, keeping pairs closer than `max_distance` metres. `out` is cleared first.
pub fn find_pairs(target: &TargetSet<'_>, transformed: &[[f64; 2]], max_distance: f64, out: &mut Vec<Pair>) {
    out.clear();
    let max_sq = max_distance * max_distance;
    for (i, q) in transformed.iter().enumerate() {
        let (t, d2) = target.nearest(*q);
        if d2 <= max_sq {
            out.push(Pair { source: i as u32, target: t, sq_dist: d2 });
        }
    }
}

/// Keeps the `ratio` share (rounded up, at least `min_keep`) of `pairs` with the smallest
/// distances; order afterwards is unspecified. A ratio of 1 keeps everything.
pub fn trim(pairs: &mut Vec<Pair>, ratio: f64, min_keep: usize) {
    if ratio >= 1.0 || pairs.len() <= min_keep {
        return;
    }
    let keep = ((pairs.len() as f64 * ratio).ceil() as usize).clamp(min_keep, pairs.len());
    pairs.select_nth_unstable_by(keep - 1, |a, b| a.sq_dist.total_cmp(&b.sq_dist));
    pairs.truncate(keep);
}

/// Pairs farther than this many robust standard deviations of the pair distances are dropped by
/// [`trim_auto`].
pub const AUTO_TRIM_SIGMAS: f64 = 3.0;
/// Smallest share of the in-range pairs [`trim_auto`] keeps in the last stage of the schedule.
pub const AUTO_TRIM_MIN_SHARE: f64 = 0.2;
/// Smallest share of the in-range pairs [`trim_auto`] keeps in the earlier, coarser stages.
pub const AUTO_TRIM_COARSE_SHARE: f64 = 0.6;

/// Keeps the pairs whose distance is within [`AUTO_TRIM_SIGMAS`] robust standard deviations of
/// the typical pair distance: `sigma = 1.4826 * median distance` (the median absolute deviation
/// of a zero-centred distance). Pairs on the walls dominate the median as long as they are most
/// of the in-range pairs, so a crowd of people or furniture near the walls, whose distances to
/// the plan are larger, is cut; clean scans lose only their extreme tail. At most a `max_ratio`
/// share and at least a `min_share` of the pairs (and `min_keep`) are kept.
pub fn trim_auto(pairs: &mut Vec<Pair>, max_ratio: f64, min_share: f64, min_keep: usize) {
    let n = pairs.len();
    if n <= min_keep {
        return;
    }
    // Selections rather than a sort: the median and the kept share need no order beyond them (a
    // full sort was a tenth of a tracking alignment's time).
    let by_distance = |a: &Pair, b: &Pair| a.sq_dist.total_cmp(&b.sq_dist);
    let most = ((n as f64 * max_ratio).ceil() as usize).clamp(min_keep, n);
    let least = ((n as f64 * min_share).ceil() as usize).clamp(min_keep, most);
    let median = pairs.select_nth_unstable_by(n / 2, by_distance).1.sq_dist.sqrt();
    let limit = AUTO_TRIM_SIGMAS * 1.4826 * median;
    let within = pairs.iter().filter(|p| p.sq_dist <= limit * limit).count();
    let keep = within.clamp(least, most);
    if keep == 0 {
        pairs.clear();
    } else if keep < n {
        pairs.select_nth_unstable_by(keep - 1, by_distance);
        pairs.truncate(keep);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line_map() -> PointMap {
        PointMap::new((0..101).map(|i| [i as f64 * 0.1, 0.0]).collect(), None).unwrap()
    }

    #[test]
    fn rejects_pairs_beyond_max_distance() {
        let map = line_map();
        let target = TargetSet::Full(&map);
        let scan = [[1.0, 0.1], [2.0, 0.3], [3.05, -0.2]];
        let mut pairs = Vec::new();
        find_pairs(&target, &scan, 0.25, &mut pairs);
        assert_eq!(pairs.iter().map(|p| p.source).collect::<Vec<_>>(), vec![0, 2]);
        assert_eq!(pairs[0].target, 10);
        assert!((pairs[0].sq_dist - 0.01).abs() < 1e-12);
        assert!((pairs[1].sq_dist - (0.05f64.powi(2) + 0.04)).abs() < 1e-12);
    }

    #[test]
    fn subset_reports_plan_indices() {
        let map = line_map();
        let target = TargetSet::subset(&map, vec![50, 51, 52]).unwrap();
        assert_eq!(target.len(), 3);
        let (idx, d2) = target.nearest([0.0, 0.0]);
        assert_eq!(idx, 50);
        assert!((d2 - 25.0).abs() < 1e-9);
        assert!(TargetSet::subset(&map, vec![]).is_none());
    }

    #[test]
    fn auto_trim_keeps_clean_pairs_and_drops_a_crowd() {
        let pair = |source: u32, d: f64| Pair { source, target: 0, sq_dist: d * d };
        // 100 points, all paired within 1 cm: nothing is dropped.
        let mut clean: Vec<Pair> = (0..100).map(|i| pair(i, 0.0001 * i as f64)).collect();
        trim_auto(&mut clean, 1.0, AUTO_TRIM_MIN_SHARE, 3);
        assert_eq!(clean.len(), 100);
        // 60 inliers within 1 cm and 40 crowd points 10-20 cm away: the crowd goes.
        let mut crowded: Vec<Pair> = (0..60).map(|i| pair(i, 0.0001 * i as f64)).collect();
        crowded.extend((60..100).map(|i| pair(i, 0.1 + 0.0025 * (i - 60) as f64)));
        trim_auto(&mut crowded, 1.0, AUTO_TRIM_MIN_SHARE, 3);
        assert_eq!(crowded.len(), 60);
        assert!(crowded.iter().all(|p| p.sq_dist < 1e-4));
        // The bounds: at most max_ratio, at least the minimum share.
        let mut capped: Vec<Pair> = (0..100).map(|i| pair(i, 0.0001 * i as f64)).collect();
        trim_auto(&mut capped, 0.5, AUTO_TRIM_MIN_SHARE, 3);
        assert_eq!(capped.len(), 50);
        let mut spread: Vec<Pair> = (0..100).map(|i| pair(i, 0.01 * 1.1f64.powi(i as i32))).collect();
        trim_auto(&mut spread, 1.0, AUTO_TRIM_MIN_SHARE, 3);
        assert!(spread.len() >= 20);
        let mut coarse: Vec<Pair> = (0..100).map(|i| pair(i, 0.01 * 1.1f64.powi(i as i32))).collect();
        trim_auto(&mut coarse, 1.0, AUTO_TRIM_COARSE_SHARE, 3);
        assert!(coarse.len() >= 60);
    }

    #[test]
    fn auto_trim_keeps_what_the_sorted_rule_keeps_in_any_order() {
        use rand::{Rng, SeedableRng};
        use rand_chacha::ChaCha8Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for trial in 0..200 {
            let n = rng.random_range(1..400);
            let crowd = rng.random_range(0.0..0.7);
            let pairs: Vec<Pair> = (0..n)
                .map(|i| {
                    let d: f64 = if rng.random_bool(crowd) {
                        rng.random_range(0.05..0.25)
                    } else {
                        rng.random_range(0.0..0.02)
                    };
                    Pair { source: i as u32, target: 0, sq_dist: d * d }
                })
                .collect();
            let (ratio, share) =
                ([1.0, 0.8][trial % 2], [AUTO_TRIM_MIN_SHARE, AUTO_TRIM_COARSE_SHARE][trial % 3 % 2]);
            // The rule on sorted pairs: the median, then the prefix within three robust sigmas.
            let mut sorted = pairs.clone();
            sorted.sort_by(|a, b| a.sq_dist.total_cmp(&b.sq_dist));
            let expected = if n <= 3 {
                n
            } else {
                let most = ((n as f64 * ratio).ceil() as usize).clamp(3, n);
                let least = ((n as f64 * share).ceil() as usize).clamp(3, most);
                let limit = AUTO_TRIM_SIGMAS * 1.4826 * sorted[n / 2].sq_dist.sqrt();
                sorted.partition_point(|p| p.sq_dist <= limit * limit).clamp(least, most)
            };
            let mut kept = pairs.clone();
            trim_auto(&mut kept, ratio, share, 3);
            assert_eq!(kept.len(), expected, "trial {trial}");
            let mut got: Vec<f64> = kept.iter().map(|p| p.sq_dist).collect();
            got.sort_by(f64::total_cmp);
            let want: Vec<f64> = sorted[..expected].iter().map(|p| p.sq_dist).collect();
            assert_eq!(got, want, "trial {trial}");
        }
    }

    #[test]
    fn trim_keeps_the_closest_share() {
        let mut pairs: Vec<Pair> =
            (0..10).map(|i| Pair { source: i, target: i, sq_dist: (9 - i) as f64 }).collect();
        trim(&mut pairs, 0.3, 2);
        let mut kept: Vec<u32> = pairs.iter().map(|p| p.source).collect();
        kept.sort_unstable();
        assert_eq!(kept, vec![7, 8, 9]);
        let mut few = pairs.clone();
        trim(&mut few, 0.1, 2);
        assert_eq!(few.len(), 2);
    }
}
