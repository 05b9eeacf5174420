//! When an ICP stage stops: after its share of the iteration budget, when the pose update falls
//! under both tolerances, or at a fixed point (the pairs did not change, so another iteration
//! would reproduce the same pose).

use crate::maps::pair::Pair;
use crate::pose::Pose2;

/// Step tolerances. Both zero disables early stopping: every stage runs its whole budget.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    /// Largest translation step (metres) that counts as converged.
    pub translation: f64,
    /// Largest rotation step (radians) that counts as converged.
    pub rotation: f64,
}

impl Tolerances {
    /// True when both tolerances are zero: run every iteration.
    pub fn disabled(&self) -> bool {
        self.translation == 0.0 && self.rotation == 0.0
    }

    /// True when `step` is within both tolerances (never when disabled).
    pub fn is_small(&self, step: &Pose2) -> bool {
        !self.disabled() && step.translation_norm() <= self.translation && step.yaw.abs() <= self.rotation
    }
}

/// The iteration count at which stage `stage` (of `stages`) must end, out of `max_iterations`:
/// stages share the budget evenly and cumulatively (a stage that stops early leaves its iterations
/// to the next ones); the last stage may use everything that is left.
pub fn stage_end(stage: usize, stages: usize, max_iterations: usize) -> usize {
    if stage + 1 >= stages {
        max_iterations
    } else {
        // In u128: (stage + 1) * max_iterations overflows usize for budgets near usize::MAX.
        ((stage as u128 + 1) * max_iterations as u128 / stages as u128) as usize
    }
}

/// An order-independent fingerprint of a set of pairs, to detect a fixed point cheaply.
pub fn pair_fingerprint(pairs: &[Pair]) -> u64 {
    pairs.iter().fold(0u64, |acc, p| {
        // One multiply-xorshift round of the (source, target) pair, summed: independent of order.
        // A collision only ends a stage as if at a fixed point, so a full mixer is not needed.
        let z = ((p.source as u64) << 32 | p.target as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        acc.wrapping_add(z ^ (z >> 29))
    }) ^ pairs.len() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_budgets_do_not_overflow() {
        // Found by the fuzz target `pose_and_budget`: (stage + 1) * max_iterations overflowed.
        assert_eq!(stage_end(1, 3, usize::MAX), (2 * (usize::MAX as u128) / 3) as usize);
        assert_eq!(stage_end(0, 3, usize::MAX), usize::MAX / 3);
        assert_eq!(stage_end(2, 3, usize::MAX), usize::MAX);
        assert_eq!(stage_end(usize::MAX - 2, usize::MAX, usize::MAX), usize::MAX - 1);
    }

    #[test]
    fn zero_tolerances_never_stop_early() {
        let tol = Tolerances { translation: 0.0, rotation: 0.0 };
        assert!(tol.disabled());
        assert!(!tol.is_small(&Pose2::identity()));
    }

    #[test]
    fn small_step_needs_both_components_small() {
        let tol = Tolerances { translation: 1e-3, rotation: 1e-3 };
        assert!(tol.is_small(&Pose2::new(5e-4, 5e-4, 5e-4)));
        assert!(!tol.is_small(&Pose2::new(2e-3, 0.0, 0.0)));
        assert!(!tol.is_small(&Pose2::new(0.0, 0.0, -2e-3)));
        // A translation-only tolerance still lets the rotation decide.
        let t_only = Tolerances { translation: 1e-3, rotation: 0.0 };
        assert!(!t_only.is_small(&Pose2::new(0.0, 0.0, 1e-9)));
        assert!(t_only.is_small(&Pose2::new(1e-4, 0.0, 0.0)));
    }

    #[test]
    fn stages_share_the_budget() {
        assert_eq!((0..3).map(|s| stage_end(s, 3, 30)).collect::<Vec<_>>(), vec![10, 20, 30]);
        assert_eq!((0..3).map(|s| stage_end(s, 3, 31)).collect::<Vec<_>>(), vec![10, 20, 31]);
        assert_eq!(stage_end(0, 1, 7), 7);
        assert_eq!((0..3).map(|s| stage_end(s, 3, 2)).collect::<Vec<_>>(), vec![0, 1, 2]);
    }

    #[test]
    fn fingerprint_ignores_order_but_not_content() {
        let a = Pair { source: 1, target: 7, sq_dist: 0.1 };
        let b = Pair { source: 2, target: 9, sq_dist: 0.2 };
        let c = Pair { source: 2, target: 8, sq_dist: 0.2 };
        assert_eq!(pair_fingerprint(&[a, b]), pair_fingerprint(&[b, a]));
        assert_ne!(pair_fingerprint(&[a, b]), pair_fingerprint(&[a, c]));
        assert_ne!(pair_fingerprint(&[a]), pair_fingerprint(&[a, b]));
    }
}
