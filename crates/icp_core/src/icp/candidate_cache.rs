//! Exact nearest-neighbour search for ICP iterations, reusing radius queries.
//!
//! Between ICP iterations a scan point moves a little. For each point the cache keeps the plan
//! points within `radius` of where the point was when they were fetched (its anchor), sorted by
//! their distance to the anchor. If the point is now `m` away from its anchor and
//! `m + max_distance <= radius`, every plan point within `max_distance` of its new position is
//! among those candidates (triangle inequality), so they give exactly the KD-tree's answer for
//! pairs within `max_distance`. Because a candidate `c` is at least `|c - anchor| - m` from the
//! point, the sorted scan stops as soon as that bound exceeds the best distance found: after a
//! handful of candidates once the pose has settled.
//!
//! Points that moved too far are answered by the KD-tree directly. The whole cache is fetched
//! once the scan has settled (while the pose still moves fast, plain KD-tree queries are cheaper
//! than radius queries that would be stale at the next iteration), and fetched again when more
//! than an eighth of the points went stale.

use crate::icp::correspondence::TargetSet;
use crate::maps::bucket_grid::BucketGrid;
use crate::maps::pair::Pair;

/// Candidate plan points per scan point, fetched by radius queries: through a [`BucketGrid`]
/// over a subset target (the visible points), through the KD-tree over the full plan.
#[derive(Debug, Default)]
pub struct CandidateCache {
    radius: f64,
    anchors: Vec<[f64; 2]>,
    /// `offsets[i]..offsets[i + 1]` indexes the candidates of scan point `i`.
    offsets: Vec<u32>,
    /// Per candidate: distance to its anchor (ascending within a point), x, y, plan index.
    candidates: Vec<Candidate>,
    previous: Vec<[f64; 2]>,
    scratch: Vec<Candidate>,
    /// Range-query grid over a subset target, built at the first refill.
    grid: Option<BucketGrid>,
    /// Refetches of the whole cache so far (for tests and diagnostics).
    pub refills: usize,
    /// Calls answered by plain KD-tree queries because the scan had not settled.
    pub direct_passes: usize,
    /// Single points answered by the KD-tree because they had left their candidates' reach.
    pub stale_points: usize,
}

#[derive(Clone, Copy, Debug, Default)]
struct Candidate {
    from_anchor: f64,
    x: f64,
    y: f64,
    index: u32,
}

impl CandidateCache {
    /// An empty cache whose radius queries reach `radius` metres.
    pub fn new(radius: f64) -> Self {
        Self { radius, ..Self::default() }
    }

    /// The radius of the radius queries, metres.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Refetches candidates around `positions`.
    fn refill(&mut self, target: &TargetSet<'_>, positions: &[[f64; 2]]) {
        self.anchors.clear();
        self.anchors.extend_from_slice(positions);
        self.offsets.clear();
        self.candidates.clear();
        self.offsets.push(0);
        let map = target.map();
        if self.grid.is_none() {
            if let TargetSet::Subset { indices, .. } = target {
                let points = indices.iter().map(|&i| (map.points()[i as usize], i));
                self.grid = Some(BucketGrid::new(points, self.radius));
            }
        }
        for q in positions {
            self.scratch.clear();
            let scratch = &mut self.scratch;
            let mut push = |p: [f64; 2], index: u32| {
                let from_anchor = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
                scratch.push(Candidate { from_anchor, x: p[0], y: p[1], index });
            };
            match &self.grid {
                Some(grid) => grid.for_each_within(*q, self.radius, |p, index, _| push(p, index)),
                None => {
                    target.for_each_within(*q, self.radius, |index| push(map.points()[index as usize], index))
                }
            }
            self.scratch
                .sort_unstable_by(|a, b| a.from_anchor.total_cmp(&b.from_anchor).then(a.index.cmp(&b.index)));
            self.candidates.extend_from_slice(&self.scratch);
            self.offsets.push(self.candidates.len() as u32);
        }
        self.refills += 1;
    }

    /// Like [`crate::icp::correspondence::find_pairs`], with the same result, using the cache.
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
        if self.anchors.len() != positions.len() {
            // Fetch once the scan has settled: its points moved less than half the slack since
            // the previous call. Before that, radius queries would go stale at once.
            let settled = self.previous.len() == positions.len()
                && positions
                    .iter()
                    .zip(&self.previous)
                    .all(|(q, p)| (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) <= slack * slack / 4.0);
            self.previous.clear();
            self.previous.extend_from_slice(positions);
            if settled {
                self.refill(target, positions);
            } else {
                crate::icp::correspondence::find_pairs(target, positions, max_distance, out);
                self.direct_passes += 1;
                return;
            }
        }
        self.previous.clear();
        self.previous.extend_from_slice(positions);
        let max_sq = max_distance * max_distance;
        out.clear();
        let mut stale = 0usize;
        for (i, q) in positions.iter().enumerate() {
            let a = self.anchors[i];
            let moved = ((q[0] - a[0]).powi(2) + (q[1] - a[1]).powi(2)).sqrt();
            let best = if moved <= slack {
                let (lo, hi) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
                let mut best = (u32::MAX, max_sq);
                let mut best_d = max_distance;
                for c in &self.candidates[lo..hi] {
                    // Every remaining candidate is at least this far from q.
                    if c.from_anchor - moved > best_d {
                        break;
                    }
                    let d2 = (c.x - q[0]).powi(2) + (c.y - q[1]).powi(2);
                    if d2 < best.1 || (d2 == best.1 && c.index < best.0) {
                        best = (c.index, d2);
                        best_d = d2.sqrt();
                    }
                }
                best
            } else {
                stale += 1;
                target.nearest(*q)
            };
            if best.0 != u32::MAX && best.1 <= max_sq {
                out.push(Pair { source: i as u32, target: best.0, sq_dist: best.1 });
            }
        }
        self.stale_points += stale;
        if stale * 8 > positions.len() {
            // Drop the cache; it is fetched again once the scan settles.
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
                map.tree().for_each_within(&q, r2, |item, _| f(item));
            }
            TargetSet::Subset { indices, tree, .. } => {
                tree.for_each_within(&q, r2, |item, _| f(indices[item as usize]));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::icp::correspondence::find_pairs;
    use crate::maps::point_map::PointMap;
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
        for target in [TargetSet::Full(&map), TargetSet::subset(&map, (0..1200).collect()).unwrap()] {
            let mut positions: Vec<[f64; 2]> =
                (0..500).map(|_| [rng.random_range(-1.0..21.0), rng.random_range(-1.0..7.0)]).collect();
            let mut cache = CandidateCache::new(0.5);
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for step in 0..60 {
                let d = [0.4, 0.2, 0.1][step % 3];
                cache.find_pairs(&target, &positions, d, &mut a);
                find_pairs(&target, &positions, d, &mut b);
                assert_eq!(a.len(), b.len(), "step {step}");
                for (x, y) in a.iter().zip(&b) {
                    assert_eq!(x.source, y.source);
                    assert!((x.sq_dist - y.sq_dist).abs() < 1e-15, "step {step}: {x:?} vs {y:?}");
                }
                let jump = if step % 20 == 19 { 0.3 } else { 0.01 };
                for p in &mut positions {
                    p[0] += rng.random_range(-jump..jump);
                    p[1] += rng.random_range(-jump..jump);
                }
            }
            assert!(cache.refills >= 2, "large jumps should refill the cache");
            assert!(cache.refills < 20, "small drifts should reuse it ({} refills)", cache.refills);
            assert!(cache.stale_points > 0, "the test should exercise stale points");
        }
    }
}
