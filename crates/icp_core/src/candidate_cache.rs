//! Exact nearest-neighbour search for ICP iterations, reusing KD-tree radius queries.
//!
//! Between ICP iterations a scan point moves a little. For each point the cache keeps the plan
//! points within `radius` of where the point was when they were fetched (its anchor). If the point
//! is now `delta` away from its anchor and `delta + max_distance <= radius`, every plan point
//! within `max_distance` of its new position is among those candidates (triangle inequality), so
//! scanning them gives exactly the KD-tree's answer for pairs within `max_distance`. Points that
//! moved farther are re-queried. The whole cache is (re)fetched only once the scan has settled
//! (its points moved less than half the slack since the previous call); while the pose
//! still moves a lot, plain nearest-neighbour queries are cheaper than radius queries that would
//! be stale at the next iteration.

use crate::correspondence::{Pair, TargetSet};
use kiddo::SquaredEuclidean;

/// Candidate plan points per scan point, fetched by KD-tree radius queries.
#[derive(Debug, Default)]
pub struct CandidateCache {
    radius: f64,
    anchors: Vec<[f64; 2]>,
    /// `offsets[i]..offsets[i + 1]` indexes the candidates of scan point `i`.
    offsets: Vec<u32>,
    candidate_points: Vec<[f64; 2]>,
    candidate_indices: Vec<u32>,
    previous: Vec<[f64; 2]>,
    /// Refetches of the whole cache so far (for tests and diagnostics).
    pub refills: usize,
    /// Calls answered by plain KD-tree queries because the scan had not settled.
    pub direct_passes: usize,
    /// Single points re-queried because they had left their candidates' reach.
    pub stale_points: usize,
}

impl CandidateCache {
    /// An empty cache whose radius queries reach `radius` metres.
    pub fn new(radius: f64) -> Self {
        Self {
            radius,
            ..Self::default()
        }
    }

    /// Refetches candidates around `positions`.
    fn refill(&mut self, target: &TargetSet<'_>, positions: &[[f64; 2]]) {
        self.anchors.clear();
        self.anchors.extend_from_slice(positions);
        self.offsets.clear();
        self.candidate_points.clear();
        self.candidate_indices.clear();
        self.offsets.push(0);
        let map = target.map();
        for q in positions {
            target.for_each_within(*q, self.radius, |idx| {
                self.candidate_indices.push(idx);
                self.candidate_points.push(map.points()[idx as usize]);
            });
            self.offsets.push(self.candidate_indices.len() as u32);
        }
        self.refills += 1;
    }

    /// Like [`crate::correspondence::find_pairs`], with the same result, using the cache.
    /// `max_distance` must not exceed the cache radius.
    pub fn find_pairs(
        &mut self,
        target: &TargetSet<'_>,
        positions: &[[f64; 2]],
        max_distance: f64,
        out: &mut Vec<Pair>,
    ) {
        debug_assert!(max_distance <= self.radius);
        let slack = self.radius - max_distance;
        let slack_sq = slack * slack;
        let settled = self.previous.len() == positions.len()
            && positions
                .iter()
                .zip(&self.previous)
                .all(|(q, p)| (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) <= slack_sq / 4.0);
        self.previous.clear();
        self.previous.extend_from_slice(positions);
        let fresh = self.anchors.len() == positions.len();
        if !fresh {
            if !settled {
                crate::correspondence::find_pairs(target, positions, max_distance, out);
                self.direct_passes += 1;
                return;
            }
            self.refill(target, positions);
        }
        let max_sq = max_distance * max_distance;
        out.clear();
        let mut stale = 0usize;
        for (i, q) in positions.iter().enumerate() {
            let a = self.anchors[i];
            let moved_sq = (q[0] - a[0]).powi(2) + (q[1] - a[1]).powi(2);
            let best = if moved_sq <= slack_sq {
                let (lo, hi) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
                let mut best = (u32::MAX, f64::INFINITY);
                for (p, &idx) in self.candidate_points[lo..hi]
                    .iter()
                    .zip(&self.candidate_indices[lo..hi])
                {
                    let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                    if d2 < best.1 || (d2 == best.1 && idx < best.0) {
                        best = (idx, d2);
                    }
                }
                best
            } else {
                stale += 1;
                target.nearest(*q)
            };
            if best.1 <= max_sq {
                out.push(Pair {
                    source: i as u32,
                    target: best.0,
                    sq_dist: best.1,
                });
            }
        }
        self.stale_points += stale;
        if stale * 8 > positions.len() {
            // Drop the cache; it is refetched once the scan settles again.
            self.anchors.clear();
        }
    }
}

impl TargetSet<'_> {
    /// Calls `f` with the plan index of every candidate within `radius` of `q`.
    pub fn for_each_within(&self, q: [f64; 2], radius: f64, mut f: impl FnMut(u32)) {
        let r2 = radius * radius;
        match self {
            TargetSet::Full(map) => {
                for n in map.tree().within_unsorted::<SquaredEuclidean>(&q, r2) {
                    f(n.item);
                }
            }
            TargetSet::Subset { indices, tree, .. } => {
                for n in tree.within_unsorted::<SquaredEuclidean>(&q, r2) {
                    f(indices[n.item as usize]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::correspondence::find_pairs;
    use crate::point_map::PointMap;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn agrees_with_kdtree_search_while_points_drift() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut pts = Vec::new();
        for i in 0..400 {
            let t = i as f64 * 0.05;
            pts.extend([[t, 0.0], [t, 6.0], [0.0, t * 0.3], [20.0, t * 0.3]]);
        }
        pts.extend((0..300).map(|_| [rng.random_range(0.0..20.0), rng.random_range(0.0..6.0)]));
        let map = PointMap::new(pts, None).unwrap();
        for target in [
            TargetSet::Full(&map),
            TargetSet::subset(&map, (0..1200).collect()).unwrap(),
        ] {
            let mut positions: Vec<[f64; 2]> = (0..500)
                .map(|_| [rng.random_range(-1.0..21.0), rng.random_range(-1.0..7.0)])
                .collect();
            let mut cache = CandidateCache::new(0.5);
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for step in 0..40 {
                let d = if step % 3 == 0 { 0.4 } else { 0.2 };
                cache.find_pairs(&target, &positions, d, &mut a);
                find_pairs(&target, &positions, d, &mut b);
                assert_eq!(a.len(), b.len(), "step {step}");
                for (x, y) in a.iter().zip(&b) {
                    assert_eq!(x.source, y.source);
                    assert!(
                        (x.sq_dist - y.sq_dist).abs() < 1e-15,
                        "step {step}: {x:?} vs {y:?}"
                    );
                }
                let jump = if step % 10 == 9 { 0.3 } else { 0.01 };
                for p in &mut positions {
                    p[0] += rng.random_range(-jump..jump);
                    p[1] += rng.random_range(-jump..jump);
                }
            }
            assert!(cache.refills >= 2, "large jumps should refill the cache");
            assert!(
                cache.refills < 20,
                "small drifts should reuse it ({} refills)",
                cache.refills
            );
        }
    }
}
