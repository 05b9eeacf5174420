//! Extrapolation of slowly converging ICP (after Besl and McKay's accelerated ICP).
//!
//! Point-to-point ICP often crawls: each update moves the same way as the last, a little less.
//! When two successive updates point the same way (expressed as a translation of the scan's
//! centroid plus a rotation about it, the rotation scaled by the scan's radius so that both are in
//! metres) and the second is shorter by a ratio `r < 1`, the rest of that geometric series,
//! `r / (1 - r)` times the last update (at most [`MAX_FACTOR`]), is applied at once. The caller
//! checks the result at the next iteration with [`truncated_cost`] and returns to the pose before
//! the jump when it made the fit worse.

use crate::maps::pair::Pair;
use crate::pose::Pose2;

/// Largest multiple of the last update that one extrapolation adds.
pub const MAX_FACTOR: f64 = 8.0;
/// Cosine of the largest angle between two updates that still counts as "the same way".
pub const MIN_COSINE: f64 = 0.95;
/// Iterations without extrapolation after one was rejected.
pub const COOLDOWN: usize = 3;

/// An ICP update as a motion of the scan: centroid translation (metres) and rotation (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Update {
    centroid: [f64; 2],
    shift: [f64; 2],
    rotation: f64,
}

impl Update {
    /// `step` (applied as `step * pose`) seen as a motion of points around `centroid` (map frame).
    pub fn new(step: &Pose2, centroid: [f64; 2]) -> Self {
        let moved = step.transform_point(centroid);
        Self { centroid, shift: [moved[0] - centroid[0], moved[1] - centroid[1]], rotation: step.yaw }
    }

    fn vector(&self, radius: f64) -> [f64; 3] {
        [self.shift[0], self.shift[1], self.rotation * radius]
    }

    /// The rigid transform moving points by `factor` times this update (about its centroid).
    pub fn scaled(&self, factor: f64) -> Pose2 {
        let yaw = factor * self.rotation;
        let (s, c) = yaw.sin_cos();
        let [cx, cy] = self.centroid;
        // p -> R (p - c) + c + factor * shift
        Pose2::new(
            cx + factor * self.shift[0] - (c * cx - s * cy),
            cy + factor * self.shift[1] - (s * cx + c * cy),
            yaw,
        )
    }
}

/// The extrapolation to apply after `last` followed `previous`, or `None` when the two updates do
/// not form a shrinking series in one direction. `radius` (metres) weighs rotation against shift.
pub fn extrapolation(previous: &Update, last: &Update, radius: f64) -> Option<Pose2> {
    let (a, b) = (previous.vector(radius), last.vector(radius));
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (na, nb) = (a.iter().map(|v| v * v).sum::<f64>().sqrt(), b.iter().map(|v| v * v).sum::<f64>().sqrt());
    if na == 0.0 || nb == 0.0 || dot < MIN_COSINE * na * nb || nb >= na {
        return None;
    }
    let ratio = nb / na;
    let factor = (ratio / (1.0 - ratio)).min(MAX_FACTOR);
    Some(last.scaled(factor))
}

/// The cost ICP decreases, made comparable between iterations whose pair sets differ: every used
/// scan point contributes its squared pair distance, or `max_distance^2` when it has no pair.
pub fn truncated_cost(pairs: &[Pair], used_points: usize, max_distance: f64) -> f64 {
    // Four running sums: one would wait on each addition's latency.
    let mut sums = [0.0f64; 4];
    let mut chunks = pairs.chunks_exact(4);
    for c in &mut chunks {
        for k in 0..4 {
            sums[k] += c[k].sq_dist;
        }
    }
    let paired =
        chunks.remainder().iter().map(|p| p.sq_dist).sum::<f64>() + (sums[0] + sums[1]) + (sums[2] + sums[3]);
    paired + (used_points.saturating_sub(pairs.len())) as f64 * max_distance * max_distance
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_update_matches_repeated_motion_about_the_centroid() {
        let step = Pose2::new(0.3, -0.1, 0.02);
        let u = Update::new(&step, [5.0, 2.0]);
        let once = u.scaled(1.0);
        assert!((once.x - step.x).abs() < 1e-12 && (once.y - step.y).abs() < 1e-12);
        let twice = u.scaled(2.0);
        // The centroid moves by twice the shift.
        let c = twice.transform_point([5.0, 2.0]);
        assert!((c[0] - (5.0 + 2.0 * u.shift[0])).abs() < 1e-12);
        assert!((c[1] - (2.0 + 2.0 * u.shift[1])).abs() < 1e-12);
        assert!((twice.yaw - 0.04).abs() < 1e-12);
    }

    #[test]
    fn extrapolates_only_shrinking_aligned_series() {
        let c = [0.0, 0.0];
        let a = Update::new(&Pose2::new(0.02, 0.0, 0.001), c);
        let b = Update::new(&Pose2::new(0.01, 0.0, 0.0005), c);
        let e = extrapolation(&a, &b, 5.0).expect("halving series");
        // r = 1/2: the rest of the series equals the last update: the centroid moves as b moved it.
        let moved = e.transform_point(c);
        let by_b = Pose2::new(0.01, 0.0, 0.0005).transform_point(c);
        assert!((moved[0] - by_b[0]).abs() < 1e-12 && (moved[1] - by_b[1]).abs() < 1e-12, "{e:?}");
        assert!((e.yaw - 0.0005).abs() < 1e-12);
        assert!(extrapolation(&b, &a, 5.0).is_none(), "growing updates must not be extrapolated");
        let turned = Update::new(&Pose2::new(0.0, 0.01, 0.0), c);
        assert!(extrapolation(&a, &turned, 5.0).is_none(), "a change of direction must not be extrapolated");
        let crawl = Update::new(&Pose2::new(0.0199, 0.0, 0.000995), c);
        let e = extrapolation(&a, &crawl, 5.0).unwrap();
        assert!((e.yaw - MAX_FACTOR * 0.000995).abs() < 1e-12, "factor is capped: {e:?}");
    }

    #[test]
    fn cost_counts_unpaired_points_at_the_cap() {
        let pairs =
            [Pair { source: 0, target: 0, sq_dist: 0.01 }, Pair { source: 1, target: 3, sq_dist: 0.04 }];
        assert!((truncated_cost(&pairs, 5, 0.5) - (0.05 + 3.0 * 0.25)).abs() < 1e-12);
    }
}
