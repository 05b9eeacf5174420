//! The rigid transform that best maps paired points onto each other, in closed form.
//!
//! Minimises `sum_i |R(theta) s_i + t - d_i|^2` over `theta` and `t` (the 2D case of
//! Umeyama/Kabsch, without reflection): `theta = atan2(sum s'_i x d'_i, sum s'_i . d'_i)` over the
//! centred points, `t = mean(d) - R mean(s)`.

use crate::maps::pair::Pair;
use crate::pose::Pose2;

/// Fewest pairs the solver accepts: two distinct points fix a 2D rigid transform; a third guards
/// against a lucky coincidence.
pub const MIN_PAIRS: usize = 3;

/// Running sums for the closed-form solution (add pairs one by one, then [`solve`](Self::solve)).
#[derive(Clone, Copy, Debug, Default)]
pub struct RigidAccumulator {
    n: f64,
    // Points are accumulated relative to the first pair, so that large map coordinates do not
    // cancel in the centred moments.
    ref_s: [f64; 2],
    ref_d: [f64; 2],
    /// Sums over the pairs of [`moments`]: s.x, s.y, d.x, d.y and the raw second moments
    /// s.x d.x, s.x d.y, s.y d.x, s.y d.y.
    sums: Moments,
}

/// What one pair adds to the sums (see [`RigidAccumulator`]).
type Moments = [f64; 8];

/// The sums' terms of the pair `s -> d`, both relative to the reference pair `(ref_s, ref_d)`.
#[inline]
fn moments(s: [f64; 2], d: [f64; 2], ref_s: [f64; 2], ref_d: [f64; 2]) -> Moments {
    let s = [s[0] - ref_s[0], s[1] - ref_s[1]];
    let d = [d[0] - ref_d[0], d[1] - ref_d[1]];
    [s[0], s[1], d[0], d[1], s[0] * d[0], s[0] * d[1], s[1] * d[0], s[1] * d[1]]
}

/// `into += from`, term by term.
#[inline]
fn absorb(into: &mut Moments, from: Moments) {
    for (a, b) in into.iter_mut().zip(from) {
        *a += b;
    }
}

impl RigidAccumulator {
    /// Adds the pair `source -> destination`.
    #[inline]
    pub fn add(&mut self, s: [f64; 2], d: [f64; 2]) {
        if self.n == 0.0 {
            self.ref_s = s;
            self.ref_d = d;
        }
        self.n += 1.0;
        absorb(&mut self.sums, moments(s, d, self.ref_s, self.ref_d));
    }

    /// The sums of every pair `sources[p.source] -> destinations[p.target]` of `pairs`, added
    /// as [`add`](Self::add) would, in two interleaved halves: one chain of additions per sum
    /// waits on each addition's latency, two overlap. (The order of the additions differs from
    /// `add`'s, so the sums may differ in the last bits.)
    ///
    /// Panics when a pair indexes beyond `sources` or `destinations`.
    pub fn of_pairs(pairs: &[Pair], sources: &[[f64; 2]], destinations: &[[f64; 2]]) -> Self {
        let Some(first) = pairs.first() else {
            return Self::default();
        };
        let (ref_s, ref_d) = (sources[first.source as usize], destinations[first.target as usize]);
        let mut halves: [Moments; 2] = [[0.0; 8]; 2];
        let term =
            |p: &Pair| moments(sources[p.source as usize], destinations[p.target as usize], ref_s, ref_d);
        let mut twos = pairs.chunks_exact(2);
        for two in &mut twos {
            absorb(&mut halves[0], term(&two[0]));
            absorb(&mut halves[1], term(&two[1]));
        }
        for p in twos.remainder() {
            absorb(&mut halves[0], term(p));
        }
        let [mut sums, other] = halves;
        absorb(&mut sums, other);
        Self { n: pairs.len() as f64, ref_s, ref_d, sums }
    }

    /// Mean of the sources added (`None`: none).
    pub fn source_mean(&self) -> Option<[f64; 2]> {
        (self.n > 0.0).then(|| [self.ref_s[0] + self.sums[0] / self.n, self.ref_s[1] + self.sums[1] / self.n])
    }

    /// Number of pairs added.
    pub fn len(&self) -> usize {
        self.n as usize
    }

    /// True when no pair was added.
    pub fn is_empty(&self) -> bool {
        self.n == 0.0
    }

    /// The transform mapping sources onto destinations, or `None` with fewer than [`MIN_PAIRS`].
    pub fn solve(&self) -> Option<Pose2> {
        if self.len() < MIN_PAIRS {
            return None;
        }
        let n = self.n;
        let [sx, sy, dx, dy, sxx, sxy, syx, syy] = self.sums;
        let ms = [sx / n, sy / n];
        let md = [dx / n, dy / n];
        // Centred cross-covariance H = sum (s - ms)(d - md)^T.
        let hxx = sxx - n * ms[0] * md[0];
        let hxy = sxy - n * ms[0] * md[1];
        let hyx = syx - n * ms[1] * md[0];
        let hyy = syy - n * ms[1] * md[1];
        let theta = (hxy - hyx).atan2(hxx + hyy);
        let (s, c) = theta.sin_cos();
        // Undo the reference shift: R (s + ref_s) + t = d + ref_d.
        let ms = [ms[0] + self.ref_s[0], ms[1] + self.ref_s[1]];
        let md = [md[0] + self.ref_d[0], md[1] + self.ref_d[1]];
        let t = [md[0] - (c * ms[0] - s * ms[1]), md[1] - (s * ms[0] + c * ms[1])];
        let pose = Pose2::new(t[0], t[1], theta);
        pose.is_finite().then_some(pose)
    }
}

/// Convenience: the transform mapping `sources[i]` onto `destinations[i]`.
pub fn solve_rigid(sources: &[[f64; 2]], destinations: &[[f64; 2]]) -> Option<Pose2> {
    let mut acc = RigidAccumulator::default();
    for (s, d) in sources.iter().zip(destinations) {
        acc.add(*s, *d);
    }
    acc.solve()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn exact_on_noiseless_pairs() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for _ in 0..200 {
            let truth = Pose2::new(
                rng.random_range(-50.0..50.0),
                rng.random_range(-50.0..50.0),
                rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
            );
            let src: Vec<[f64; 2]> = (0..rng.random_range(3..60))
                .map(|_| [rng.random_range(-20.0..20.0), rng.random_range(-20.0..20.0)])
                .collect();
            let dst: Vec<[f64; 2]> = src.iter().map(|p| truth.transform_point(*p)).collect();
            let est = solve_rigid(&src, &dst).unwrap();
            assert!((est.x - truth.x).abs() < 1e-9, "{est:?} vs {truth:?}");
            assert!((est.y - truth.y).abs() < 1e-9);
            assert!(crate::pose::wrap_angle(est.yaw - truth.yaw).abs() < 1e-11);
        }
    }

    #[test]
    fn sums_of_pairs_match_adding_them_one_by_one() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let src: Vec<[f64; 2]> =
            (0..101).map(|_| [rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0)]).collect();
        let dst: Vec<[f64; 2]> =
            (0..77).map(|_| [rng.random_range(100.0..110.0), rng.random_range(-3.0..3.0)]).collect();
        for n in [0, 1, 2, 3, 4, 57] {
            let pairs: Vec<Pair> = (0..n)
                .map(|k| Pair {
                    source: rng.random_range(0..src.len() as u32),
                    target: rng.random_range(0..dst.len() as u32),
                    sq_dist: k as f64,
                })
                .collect();
            let mut one_by_one = RigidAccumulator::default();
            for p in &pairs {
                one_by_one.add(src[p.source as usize], dst[p.target as usize]);
            }
            let batch = RigidAccumulator::of_pairs(&pairs, &src, &dst);
            assert_eq!(batch.len(), n);
            match (batch.solve(), one_by_one.solve()) {
                (Some(a), Some(b)) => {
                    assert!((a.x - b.x).abs() < 1e-9 && (a.y - b.y).abs() < 1e-9, "{a:?} vs {b:?}");
                    assert!((a.yaw - b.yaw).abs() < 1e-12);
                }
                (a, b) => assert!(a.is_none() && b.is_none() && n < MIN_PAIRS, "{n}: {a:?} vs {b:?}"),
            }
            let mean = |v: Vec<[f64; 2]>| {
                let k = v.len() as f64;
                [v.iter().map(|p| p[0]).sum::<f64>() / k, v.iter().map(|p| p[1]).sum::<f64>() / k]
            };
            match batch.source_mean() {
                Some(m) => {
                    let e = mean(pairs.iter().map(|p| src[p.source as usize]).collect());
                    assert!((m[0] - e[0]).abs() < 1e-12 && (m[1] - e[1]).abs() < 1e-12);
                }
                None => assert_eq!(n, 0),
            }
        }
    }

    #[test]
    fn needs_three_pairs() {
        assert!(solve_rigid(&[[0.0, 0.0], [1.0, 0.0]], &[[0.0, 0.0], [1.0, 0.0]]).is_none());
        assert!(solve_rigid(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &[[1.0, 0.0], [2.0, 0.0], [1.0, 1.0]])
            .is_some());
    }

    #[test]
    fn least_squares_with_noise_is_unbiased_on_average() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let truth = Pose2::new(0.3, -0.2, 0.05);
        let src: Vec<[f64; 2]> =
            (0..5000).map(|_| [rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0)]).collect();
        let dst: Vec<[f64; 2]> = src
            .iter()
            .map(|p| {
                let q = truth.transform_point(*p);
                [q[0] + rng.random_range(-0.01..0.01), q[1] + rng.random_range(-0.01..0.01)]
            })
            .collect();
        let est = solve_rigid(&src, &dst).unwrap();
        assert!((est.x - truth.x).abs() < 1e-3 && (est.y - truth.y).abs() < 1e-3);
        assert!((est.yaw - truth.yaw).abs() < 1e-4);
    }
}
