//! Exact nearest *visible* plan points, answered mostly by the plan's nearest-wall index.
//!
//! The KD-tree search pairs a scan point with the nearest plan point among those visible from the
//! initial guess (ray cast through the plan, [`crate::visibility::visible_points`]). The nearest-wall index
//! gives the nearest plan point of the whole plan in about 10 ns. Whenever that point is visible it is
//! also the nearest visible one, since the visible points are a subset of the plan; only the
//! look-ups whose nearest point is hidden need the subset's KD-tree. The pairs are the ones
//! [`crate::icp::correspondence::find_pairs`] finds on the visible subset (up to ties), at a fraction
//! of the cost: in tracking almost every return lies on a visible wall face.

use crate::icp::correspondence::TargetSet;
use crate::maps::nearest_wall_index::NearestWallIndex;
use crate::maps::pair::Pair;

/// The visible subset of a plan, with the plan's nearest-wall index in front of its KD-tree.
#[derive(Debug)]
pub struct VisibleThroughIndex<'a> {
    index: &'a NearestWallIndex,
    /// Per plan point: visible from the guess.
    visible: Vec<bool>,
}

impl<'a> VisibleThroughIndex<'a> {
    /// For a `target` subset of the plan the `index` was built on; `None` for the whole plan (the
    /// index alone answers that) or when the index does not cover `max_distance`.
    pub fn new(index: &'a NearestWallIndex, target: &TargetSet<'_>, max_distance: f64) -> Option<Self> {
        let TargetSet::Subset { map, indices, .. } = target else {
            return None;
        };
        if max_distance.is_nan() || max_distance > index.reach() {
            return None;
        }
        let mut visible = vec![false; map.len()];
        for &i in indices {
            visible[i as usize] = true;
        }
        Some(Self { index, visible })
    }

    /// Pairs every point of `transformed` (map frame) with its nearest point of `target` (the
    /// subset this was built for) when nearer than `max_distance` metres. `out` is cleared first.
    pub fn find_pairs(
        &self,
        target: &TargetSet<'_>,
        transformed: &[[f64; 2]],
        max_distance: f64,
        out: &mut Vec<Pair>,
    ) {
        // The plan's nearest points first, in the index's batched pass: beyond `max_distance`
        // of the whole plan, nothing visible is nearer either.
        self.index.find_pairs(transformed, max_distance, None, out);
        let max_sq = max_distance.min(self.index.reach()).powi(2);
        let mut kept = 0usize;
        for k in 0..out.len() {
            let mut pair = out[k];
            if !self.visible[pair.target as usize] {
                let (t, d2) = target.nearest(transformed[pair.source as usize]);
                if d2 > max_sq {
                    continue;
                }
                pair = Pair { source: pair.source, target: t, sq_dist: d2 };
            }
            out[kept] = pair;
            kept += 1;
        }
        out.truncate(kept);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cancel;
    use crate::icp::correspondence::find_pairs;
    use crate::maps::point_map::PointMap;
    use crate::pose::Pose2;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Two rooms side by side with 0.2 m walls sampled every 4 cm on both faces, and a partition.
    fn rooms() -> PointMap {
        let mut pts = Vec::new();
        let mut segment = |a: [f64; 2], b: [f64; 2]| {
            let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / 0.04).ceil() as usize;
            for k in 0..=n {
                let t = k as f64 / n as f64;
                pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        };
        for (x0, x1) in [(0.0, 6.0), (6.2, 12.0)] {
            segment([x0, 0.0], [x1, 0.0]);
            segment([x0, 5.0], [x1, 5.0]);
            segment([x0, 0.0], [x0, 5.0]);
            segment([x1, 0.0], [x1, 5.0]);
        }
        segment([-0.2, -0.2], [12.2, -0.2]);
        segment([-0.2, 5.2], [12.2, 5.2]);
        segment([3.0, 2.0], [3.0, 3.5]);
        PointMap::new(pts, None).unwrap()
    }

    #[test]
    fn gives_the_pairs_of_the_kd_tree_on_the_visible_subset() {
        let map = rooms();
        let index = map.wall_index(cancel::NEVER).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut hidden_lookups = 0usize;
        for trial in 0..20 {
            let from = Pose2::new(rng.random_range(0.5..11.5), rng.random_range(0.5..4.5), 0.0);
            let visible = map.visible_from(from, 30.0).unwrap();
            let target = TargetSet::subset(&map, visible).unwrap();
            let distance = [0.1, 0.25, 0.5][trial % 3];
            let through = VisibleThroughIndex::new(index, &target, distance).unwrap();
            let queries: Vec<[f64; 2]> =
                (0..2000).map(|_| [rng.random_range(-0.5..12.5), rng.random_range(-0.5..5.5)]).collect();
            let (mut expected, mut got) = (Vec::new(), Vec::new());
            find_pairs(&target, &queries, distance, &mut expected);
            through.find_pairs(&target, &queries, distance, &mut got);
            assert_eq!(expected.len(), got.len(), "trial {trial}");
            for (e, g) in expected.iter().zip(&got) {
                assert_eq!(e.source, g.source);
                assert!((e.sq_dist - g.sq_dist).abs() < 1e-12, "trial {trial}: {e:?} vs {g:?}");
            }
            hidden_lookups += queries
                .iter()
                .filter(|q| index.nearest(**q).is_some_and(|(t, _)| !through.visible[t as usize]))
                .count();
        }
        // The other room's walls are hidden: many look-ups went to the KD-tree, and agreed.
        assert!(hidden_lookups > 5000, "{hidden_lookups}");
    }

    #[test]
    fn only_for_subsets_within_the_reach() {
        let map = rooms();
        let index = map.wall_index(cancel::NEVER).unwrap();
        assert!(VisibleThroughIndex::new(index, &TargetSet::Full(&map), 0.25).is_none());
        let target =
            TargetSet::subset(&map, map.visible_from(Pose2::new(2.0, 2.0, 0.0), 30.0).unwrap()).unwrap();
        assert!(VisibleThroughIndex::new(index, &target, index.reach() + 0.01).is_none());
        assert!(VisibleThroughIndex::new(index, &target, f64::NAN).is_none());
        assert!(VisibleThroughIndex::new(index, &target, index.reach()).is_some());
    }
}
