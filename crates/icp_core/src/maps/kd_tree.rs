//! A static 2D KD-tree over the plan's points that splits every node across the longer side of
//! its points' bounding box, at the median.
//!
//! Plans are made of straight walls, most of them along the axes: thousands of points share one
//! coordinate. A tree that alternates its split axis (kiddo's `ImmutableKdTree`, used before)
//! cannot split such a run on that coordinate: it kept all of them on one side, and a wall's
//! leaves grew to about `4 sqrt(n)` points, so every query scanned thousands of points on long
//! walls and building a plan of 10^6 points on two 2 km walls took 30 s, 10^7 points 660 s
//! (issue 19). Splitting across the longer side splits a wall along its length, whatever its
//! direction, and leaves hold at most [`LEAF`] points: a query examines a few leaves, and the
//! look-ups of a plan build cost `O(n log n)` in all.
//!
//! Left of a split lie points with a coordinate at most the split value, right of it at least:
//! equal coordinates may fall on both sides, and a query searches the far side whenever the
//! split is closer than its current best. Distances are squared and computed as
//! `dx * dx + dy * dy`. Among points at the same distance the k-nearest query keeps the lowest
//! indices, so that its answer depends on the points, not on the tree's layout (the query for the
//! wall normals, [`Tree2::nearest_n_with_ties`], goes further and keeps every tie at the k-th
//! distance); the nearest and radius queries return the first they meet, which is the same every
//! time.
//!
//! Every query is one descent (`Tree2::descend`), the near child first, the far one
//! when the query may want a point at its distance; what a query does at the leaves and how far it
//! looks is its `Visit`.

/// Most points in a leaf.
pub const LEAF: usize = 8;

/// A point found by a query: its index in the slice the tree was built from and its squared
/// distance to the query, square metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    /// Index of the point in the slice the tree was built from.
    pub item: u32,
    /// Squared distance to the query.
    pub distance: f64,
}

/// A static KD-tree over 2D points (metres); items are indices into the slice it was built from.
#[derive(Clone, Debug, Default)]
pub struct Tree2 {
    /// The points in tree order: every node covers a contiguous range.
    points: Vec<[f64; 2]>,
    /// Their indices in the slice the tree was built from.
    items: Vec<u32>,
    /// Per internal node (heap order: the children of `k` are `2k + 1` and `2k + 2`): the split
    /// value and the axis (0: x, 1: y). A node over `[lo, hi)` splits at `lo + (hi - lo) / 2`.
    splits: Vec<f64>,
    axes: Vec<u8>,
}

impl Tree2 {
    /// Builds the tree of `points`, in `O(n log n)`. Items are `u32`: at most `u32::MAX` points
    /// (a [`crate::PointMap`] checks it).
    pub fn new_from_slice(points: &[[f64; 2]]) -> Self {
        let mut entries: Vec<([f64; 2], u32)> =
            points.iter().enumerate().map(|(i, p)| (*p, i as u32)).collect();
        let mut depth = 0;
        while entries.len().div_ceil(1 << depth) > LEAF {
            depth += 1;
        }
        let nodes = (1usize << depth) - 1;
        let mut tree =
            Self { points: Vec::new(), items: Vec::new(), splits: vec![0.0; nodes], axes: vec![0; nodes] };
        tree.build(&mut entries, 0);
        tree.points = entries.iter().map(|e| e.0).collect();
        tree.items = entries.iter().map(|e| e.1).collect();
        tree
    }

    fn build(&mut self, entries: &mut [([f64; 2], u32)], node: usize) {
        if entries.len() <= LEAF {
            return;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (p, _) in entries.iter() {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let axis = usize::from(hi[1] - lo[1] > hi[0] - lo[0]);
        let mid = entries.len() / 2;
        entries.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
        self.splits[node] = entries[mid].0[axis];
        self.axes[node] = axis as u8;
        let (left, right) = entries.split_at_mut(mid);
        self.build(left, 2 * node + 1);
        self.build(right, 2 * node + 2);
    }

    /// Number of points.
    pub fn size(&self) -> usize {
        self.points.len()
    }

    /// The point nearest to `q` (item 0 at an infinite distance when the tree is empty).
    #[inline]
    pub fn nearest_one(&self, q: &[f64; 2]) -> Neighbour {
        let mut nearest = Nearest { best: Neighbour { item: 0, distance: f64::INFINITY } };
        self.descend(q, &mut nearest);
        nearest.best
    }

    /// The `k` points nearest to `q` (all of them when there are fewer), nearest first; among
    /// points at the same distance the lowest indices come first (except among points on `q`
    /// itself, taken as met), so the answer depends on the points, not on the tree's layout.
    pub fn nearest_n(&self, q: &[f64; 2], k: usize) -> Vec<Neighbour> {
        self.nearest_n_counted(q, k).0
    }

    /// [`Tree2::nearest_n`] and the number of points it examined (the work of the query).
    pub fn nearest_n_counted(&self, q: &[f64; 2], k: usize) -> (Vec<Neighbour>, usize) {
        let mut nearest =
            NearestN { k, found: Vec::with_capacity(k.min(self.points.len()) + 1), examined: 0 };
        if k > 0 {
            self.descend(q, &mut nearest);
        }
        (nearest.found, nearest.examined)
    }

    /// The `k` points nearest to `q` and every other point as near as the `k`-th of them: all the
    /// points within `d_k * (1 + tolerance)` (squared distances, `d_k` the `k`-th smallest), or all
    /// the points when there are fewer than `k`. One query that returns exactly what
    /// [`Tree2::within_unsorted`] returns for that radius, in the same order (the order of the
    /// descent), where [`Tree2::nearest_n`] would keep only some of the ties at the `k`-th distance.
    pub fn nearest_n_with_ties(&self, q: &[f64; 2], k: usize, tolerance: f64) -> Vec<Neighbour> {
        let mut nearest =
            NearestWithTies { k, widen: 1.0 + tolerance, found: Vec::with_capacity(2 * k), met: 0 };
        if k > 0 {
            self.descend(q, &mut nearest);
        }
        let mut found = nearest.found;
        found.sort_unstable_by_key(|t| t.met);
        found.into_iter().map(|t| t.neighbour).collect()
    }

    /// Calls `f(item, squared distance)` for every point within `sq_radius` (squared, inclusive)
    /// of `q`, in no particular order.
    #[inline]
    pub fn for_each_within(&self, q: &[f64; 2], sq_radius: f64, f: impl FnMut(u32, f64)) {
        self.descend(q, &mut Within { sq_radius, f });
    }

    /// The points within `sq_radius` (squared, inclusive) of `q`, in no particular order.
    pub fn within_unsorted(&self, q: &[f64; 2], sq_radius: f64) -> Vec<Neighbour> {
        let mut out = Vec::new();
        self.for_each_within(q, sq_radius, |item, distance| out.push(Neighbour { item, distance }));
        out
    }

    /// The one descent of every query: from the root, the child on `q`'s side of the split first,
    /// then the other child when `visit` may want a point at its distance; `visit` sees the leaves.
    #[inline]
    fn descend<V: Visit>(&self, q: &[f64; 2], visit: &mut V) {
        if !self.points.is_empty() {
            self.descend_in(q, 0, 0, self.points.len(), [0.0; 2], 0.0, visit);
        }
    }

    /// [`Tree2::descend`] below `node`, which covers `[lo, hi)`. `off` holds, per axis, how far
    /// `q` lies outside the node's cell along it (0 inside), and `rd` is their sum of squares: the
    /// squared distance from `q` to the cell, a bound no point of the node can beat.
    #[allow(clippy::too_many_arguments)]
    fn descend_in<V: Visit>(
        &self,
        q: &[f64; 2],
        node: usize,
        lo: usize,
        hi: usize,
        mut off: [f64; 2],
        rd: f64,
        visit: &mut V,
    ) {
        if hi - lo <= LEAF {
            visit.leaf(q, &self.points[lo..hi], &self.items[lo..hi]);
            return;
        }
        let axis = self.axes[node] as usize;
        let diff = q[axis] - self.splits[node];
        let mid = lo + (hi - lo) / 2;
        let (near, far) = if diff < 0.0 {
            ((2 * node + 1, lo, mid), (2 * node + 2, mid, hi))
        } else {
            ((2 * node + 2, mid, hi), (2 * node + 1, lo, mid))
        };
        self.descend_in(q, near.0, near.1, near.2, off, rd, visit);
        let far_rd = rd - off[axis] * off[axis] + diff * diff;
        if visit.reaches(far_rd) {
            off[axis] = diff.abs();
            self.descend_in(q, far.0, far.1, far.2, off, far_rd, visit);
        }
    }
}

/// What one kind of query does with the leaves a descent reaches, and how far it looks.
trait Visit {
    /// Takes in the points of a leaf (with their items), in tree order.
    fn leaf(&mut self, q: &[f64; 2], points: &[[f64; 2]], items: &[u32]);
    /// Whether a node at squared distance `rd` from the query may hold a point the query wants.
    fn reaches(&self, rd: f64) -> bool;
}

/// [`Tree2::nearest_one`]: the first point met at the smallest distance.
struct Nearest {
    best: Neighbour,
}

impl Visit for Nearest {
    #[inline(always)]
    fn leaf(&mut self, q: &[f64; 2], points: &[[f64; 2]], items: &[u32]) {
        for (p, &item) in points.iter().zip(items) {
            let d = sq_dist(q, p);
            if d < self.best.distance {
                self.best = Neighbour { item, distance: d };
            }
        }
    }

    #[inline(always)]
    fn reaches(&self, rd: f64) -> bool {
        rd < self.best.distance
    }
}

/// [`Tree2::nearest_n`]: the `k` nearest so far, ordered by distance, then index.
struct NearestN {
    k: usize,
    found: Vec<Neighbour>,
    examined: usize,
}

impl Visit for NearestN {
    #[inline(always)]
    fn leaf(&mut self, q: &[f64; 2], points: &[[f64; 2]], items: &[u32]) {
        // Ordered by distance, then index: among points at the k-th distance the lowest indices
        // are kept, whatever the tree's layout.
        let before = |n: &Neighbour, d: f64, item: u32| n.distance < d || (n.distance == d && n.item < item);
        let (k, found) = (self.k, &mut self.found);
        self.examined += points.len();
        for (p, &item) in points.iter().zip(items) {
            let d = sq_dist(q, p);
            let candidate = Neighbour { item, distance: d };
            if found.len() < k || before(&candidate, found[k - 1].distance, found[k - 1].item) {
                let at = found.partition_point(|n| before(n, d, item));
                found.insert(at, candidate);
                found.truncate(k);
            }
        }
    }

    #[inline(always)]
    fn reaches(&self, rd: f64) -> bool {
        // Beyond a split exactly at the k-th distance may lie a tie of lower index, unless that
        // distance is 0: points on the query itself are taken as met (so that copies of a point
        // cost no more than one).
        let bound = if self.found.len() < self.k { f64::INFINITY } else { self.found[self.k - 1].distance };
        rd < bound || (rd == bound && bound > 0.0)
    }
}

/// A point [`Tree2::nearest_n_with_ties`] keeps, and when the descent met it.
struct Met {
    neighbour: Neighbour,
    met: u32,
}

/// [`Tree2::nearest_n_with_ties`]: every point met within `widen` times the `k`-th distance so
/// far, ordered by distance (the `k`-th only shrinks, so what is dropped stays out).
struct NearestWithTies {
    k: usize,
    widen: f64,
    found: Vec<Met>,
    met: u32,
}

impl NearestWithTies {
    /// The squared distance within which points are kept: infinite until `k` are met.
    #[inline(always)]
    fn reach(&self) -> f64 {
        match self.found.get(self.k - 1) {
            Some(kth) => kth.neighbour.distance * self.widen,
            None => f64::INFINITY,
        }
    }
}

impl Visit for NearestWithTies {
    #[inline(always)]
    fn leaf(&mut self, q: &[f64; 2], points: &[[f64; 2]], items: &[u32]) {
        for (p, &item) in points.iter().zip(items) {
            let d = sq_dist(q, p);
            let met = self.met;
            self.met += 1;
            if d <= self.reach() {
                let at = self.found.partition_point(|t| t.neighbour.distance <= d);
                self.found.insert(at, Met { neighbour: Neighbour { item, distance: d }, met });
                if self.found.len() > self.k {
                    let reach = self.reach();
                    let keep = self.found.partition_point(|t| t.neighbour.distance <= reach);
                    self.found.truncate(keep);
                }
            }
        }
    }

    #[inline(always)]
    fn reaches(&self, rd: f64) -> bool {
        rd <= self.reach()
    }
}

/// [`Tree2::for_each_within`]: every point within the radius, handed to `f`.
struct Within<F> {
    sq_radius: f64,
    f: F,
}

impl<F: FnMut(u32, f64)> Visit for Within<F> {
    #[inline(always)]
    fn leaf(&mut self, q: &[f64; 2], points: &[[f64; 2]], items: &[u32]) {
        for (p, &item) in points.iter().zip(items) {
            let d = sq_dist(q, p);
            if d <= self.sq_radius {
                (self.f)(item, d);
            }
        }
    }

    #[inline(always)]
    fn reaches(&self, rd: f64) -> bool {
        rd <= self.sq_radius
    }
}

#[inline(always)]
fn sq_dist(q: &[f64; 2], p: &[f64; 2]) -> f64 {
    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
    dx * dx + dy * dy
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn brute(points: &[[f64; 2]], q: &[f64; 2]) -> Vec<(f64, u32)> {
        let mut all: Vec<(f64, u32)> =
            points.iter().enumerate().map(|(i, p)| (sq_dist(q, p), i as u32)).collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        all
    }

    /// Random points, two long axis-aligned walls, a lattice with ties everywhere, and duplicates.
    fn point_sets() -> Vec<Vec<[f64; 2]>> {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let random =
            (0..3000).map(|_| [rng.random_range(-5.0..25.0), rng.random_range(-5.0..25.0)]).collect();
        let walls = (0..4000).map(|i| [(i / 2) as f64 * 0.01, (i % 2) as f64 * 3.0]).collect();
        let lattice = (0..2500).map(|i| [(i % 50) as f64 * 0.05, (i / 50) as f64 * 0.05]).collect();
        let mut duplicates: Vec<[f64; 2]> = vec![[1.0, 2.0]; 500];
        duplicates.extend((0..500).map(|i| [i as f64 * 0.02, 2.0]));
        vec![random, walls, lattice, duplicates, vec![[0.5, 0.5]], Vec::new()]
    }

    #[test]
    fn queries_match_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        for points in point_sets() {
            let tree = Tree2::new_from_slice(&points);
            assert_eq!(tree.size(), points.len());
            for _ in 0..300 {
                let q = [rng.random_range(-2.0..22.0), rng.random_range(-2.0..22.0)];
                let q = if rng.random_bool(0.3) && !points.is_empty() {
                    points[rng.random_range(0..points.len())]
                } else {
                    q
                };
                let all = brute(&points, &q);
                let one = tree.nearest_one(&q);
                match all.first() {
                    Some(&(d, _)) => {
                        assert_eq!(one.distance, d);
                        assert_eq!(sq_dist(&q, &points[one.item as usize]), d);
                    }
                    None => assert_eq!(one.distance, f64::INFINITY),
                }
                for k in [1, 2, 6, 20] {
                    let n = tree.nearest_n(&q, k);
                    assert_eq!(n.len(), k.min(points.len()));
                    for (i, nb) in n.iter().enumerate() {
                        assert_eq!(nb.distance, all[i].0, "k {k}, rank {i}");
                        assert_eq!(sq_dist(&q, &points[nb.item as usize]), nb.distance);
                    }
                    let expected: Vec<u32> = all.iter().take(k).map(|a| a.1).collect();
                    let got: Vec<u32> = n.iter().map(|nb| nb.item).collect();
                    if all.get(k - 1).is_none_or(|a| a.0 > 0.0) {
                        assert_eq!(got, expected, "k {k}: the lowest indices among ties");
                    }
                    let mut items: Vec<u32> = n.iter().map(|nb| nb.item).collect();
                    items.sort_unstable();
                    items.dedup();
                    assert_eq!(items.len(), n.len(), "an item twice");
                }
                let r2: f64 = rng.random_range(0.0..4.0);
                let mut within: Vec<(f64, u32)> =
                    tree.within_unsorted(&q, r2).iter().map(|n| (n.distance, n.item)).collect();
                within.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                let expected: Vec<(f64, u32)> = all.iter().copied().filter(|&(d, _)| d <= r2).collect();
                assert_eq!(within, expected);
            }
        }
    }

    /// The query that keeps ties at the k-th distance returns what a k-nearest query and a radius
    /// query at the k-th distance (widened by the tolerance) return together, in the radius
    /// query's order; all points when there are fewer than k.
    #[test]
    fn nearest_with_ties_is_knn_then_a_radius_query() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for points in point_sets() {
            let tree = Tree2::new_from_slice(&points);
            for _ in 0..300 {
                let q = if rng.random_bool(0.5) && !points.is_empty() {
                    points[rng.random_range(0..points.len())]
                } else {
                    [rng.random_range(-2.0..22.0), rng.random_range(-2.0..22.0)]
                };
                for (k, tolerance) in [(1, 0.0), (6, 1e-9), (6, 0.0), (20, 1e-3)] {
                    let got = tree.nearest_n_with_ties(&q, k, tolerance);
                    let knn = tree.nearest_n(&q, k);
                    if knn.len() < k {
                        let mut all: Vec<u32> = got.iter().map(|n| n.item).collect();
                        all.sort_unstable();
                        assert_eq!(all, (0..points.len() as u32).collect::<Vec<_>>());
                        continue;
                    }
                    let reach = knn[k - 1].distance * (1.0 + tolerance);
                    assert_eq!(got, tree.within_unsorted(&q, reach), "k {k}, {q:?}");
                    let brute = brute(&points, &q);
                    assert_eq!(got.len(), brute.iter().filter(|&&(d, _)| d <= reach).count());
                }
            }
        }
    }

    #[test]
    fn the_same_query_gives_the_same_answer() {
        let points = &point_sets()[2];
        let (a, b) = (Tree2::new_from_slice(points), Tree2::new_from_slice(points));
        for q in [[0.025, 0.025], [1.0, 1.0], [0.05, 0.075]] {
            assert_eq!(a.nearest_one(&q), b.nearest_one(&q));
            assert_eq!(a.nearest_n(&q, 6), b.nearest_n(&q, 6));
        }
    }

    /// The work of queries on points along two straight walls (the geometry that made the
    /// alternating tree's leaves grow with the square root of the wall's points): the points a
    /// 6-nearest query examines, on average, stay the same when the walls hold 100 times more
    /// points, a handful of leaves.
    #[test]
    fn queries_on_long_axis_aligned_walls_examine_a_few_leaves_whatever_their_length() {
        let mean_work = |n: usize| {
            let points: Vec<[f64; 2]> =
                (0..n).map(|i| [(i / 2) as f64 * 0.01, (i % 2) as f64 * 3.0]).collect();
            let tree = Tree2::new_from_slice(&points);
            let work: Vec<usize> =
                points.iter().step_by(97).map(|p| tree.nearest_n_counted(p, 6).1).collect();
            (work.iter().sum::<usize>() as f64 / work.len() as f64, work.into_iter().max().unwrap_or(0))
        };
        let ((small, small_max), (large, large_max)) = (mean_work(10_000), mean_work(1_000_000));
        assert!(small <= 5.0 * LEAF as f64 && large <= 1.2 * small, "{small} then {large} points per query");
        // The worst query meets the ancestors whose split lies within its reach: a few more.
        assert!(large_max <= 16 * LEAF && large_max <= 2 * small_max, "worst {small_max} then {large_max}");
    }
}
