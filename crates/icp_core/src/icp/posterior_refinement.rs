//! The pose of highest posterior: a scan's likelihood in the plan's likelihood field, tempered,
//! times a Gaussian prior on the pose (the odometry prediction).
//!
//! ICP pairs each return with its nearest plan point and keeps the pairs within a shrinking
//! distance: on a map whose walls are bands of noisy cells (a SLAM map) the pairs it keeps decide
//! where it stops, and a long wall with a few far returns lets it slide along the wall to a
//! minimum 0.3-0.6 m off that explains the scan as well as the true pose does, with a
//! covariance of a centimetre or two. A particle filter does not slide there: it weighs poses by
//! the likelihood of the whole scan in a likelihood field and by the motion model. This is that
//! weighing, for one pose:
//!
//! `cost(x) = w sum_i (1 - g(T_x s_i))^2 + (x - x_p)^T P^-1 (x - x_p)`
//!
//! with `g` the [`LikelihoodGrid`] (Cartographer's occupied-space residual `1 - g`), `w` the weight
//! of one return (the returns of one scan are not independent: their errors come from the same
//! wall drawn a little off, the same pose; `w` is the share of them whose evidence counts as
//! independent), and `(x_p, P)` the prior. `cost` is twice the negative log posterior up to a
//! constant; Levenberg-Marquardt minimises it from a start.

use crate::grids::likelihood_grid::LikelihoodGrid;
use crate::pose::{wrap_angle, Pose2};
use nalgebra::{Matrix3, Vector3};

/// A Gaussian prior on the pose over (x, y, yaw).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// Its mean, `T_map_base`.
    pub pose: Pose2,
    /// Its information matrix (the inverse covariance), m^-2 and rad^-2.
    pub information: Matrix3<f64>,
}

impl Prior {
    /// The prior of mean `pose` and covariance `covariance` (rows over x, y, yaw); None when the
    /// covariance is not finite or is singular.
    pub fn from_covariance(pose: Pose2, covariance: [[f64; 3]; 3]) -> Option<Self> {
        let m = Matrix3::from_fn(|r, c| covariance[r][c]);
        if !m.iter().all(|v| v.is_finite()) {
            return None;
        }
        let information = m.try_inverse()?;
        information.iter().all(|v| v.is_finite()).then_some(Self { pose, information })
    }
}

/// Outcome of [`refine`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refinement {
    /// The pose of lowest cost found from the start.
    pub pose: Pose2,
    /// Its cost (see the module).
    pub cost: f64,
    /// The cost at the start.
    pub start_cost: f64,
    /// The Gauss-Newton information `w J^T J + P^-1` at `pose`: the posterior's inverse
    /// covariance in the Laplace approximation.
    pub information: Matrix3<f64>,
    /// Accepted steps.
    pub iterations: usize,
}

impl Refinement {
    /// `information` as rows over x, y, yaw.
    pub fn information_rows(&self) -> [[f64; 3]; 3] {
        let m = &self.information;
        [
            [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
            [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
            [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
        ]
    }
}

/// Smallest Levenberg-Marquardt damping, relative to the diagonal.
const MIN_DAMPING: f64 = 1e-7;
/// Damping at which the search gives up (no step lowers the cost).
const MAX_DAMPING: f64 = 1e6;
/// Steps smaller than this (metres, and radians) end the search.
const TOLERANCE: f64 = 1e-5;

/// The cost, the gradient `J^T r` and the Gauss-Newton matrix at `pose`.
fn evaluate(
    grid: &LikelihoodGrid,
    scan: &[[f64; 2]],
    pose: Pose2,
    prior: &Prior,
    weight: f64,
) -> (f64, Vector3<f64>, Matrix3<f64>) {
    let (c, s) = pose.cos_sin();
    let mut cost = 0.0;
    let mut gradient = Vector3::zeros();
    let mut hessian = Matrix3::zeros();
    for q in scan {
        let rotated = [c * q[0] - s * q[1], s * q[0] + c * q[1]];
        let (g, dg) = grid.value_and_gradient([rotated[0] + pose.x, rotated[1] + pose.y]);
        let residual = 1.0 - g;
        // d residual / d (x, y, yaw) = -dg . d p / d (x, y, yaw).
        let j = Vector3::new(-dg[0], -dg[1], -(dg[0] * -rotated[1] + dg[1] * rotated[0]));
        cost += weight * residual * residual;
        gradient += j * (weight * residual);
        hessian += j * j.transpose() * weight;
    }
    let d = Vector3::new(pose.x - prior.pose.x, pose.y - prior.pose.y, wrap_angle(pose.yaw - prior.pose.yaw));
    let pulled = prior.information * d;
    cost += d.dot(&pulled);
    gradient += pulled;
    hessian += prior.information;
    (cost, gradient, hessian)
}

/// The cost of `pose` (see the module).
pub fn cost(grid: &LikelihoodGrid, scan: &[[f64; 2]], pose: Pose2, prior: &Prior, weight: f64) -> f64 {
    evaluate(grid, scan, pose, prior, weight).0
}

/// Levenberg-Marquardt from `start` on the cost of the module: the pose of lowest cost in the
/// basin of `start`, in at most `max_iterations` accepted steps. `scan` holds the return points in
/// the robot frame, metres; `weight` the weight of one return.
pub fn refine(
    grid: &LikelihoodGrid,
    scan: &[[f64; 2]],
    start: Pose2,
    prior: &Prior,
    weight: f64,
    max_iterations: usize,
) -> Refinement {
    let (mut cost, mut gradient, mut hessian) = evaluate(grid, scan, start, prior, weight);
    let start_cost = cost;
    let mut pose = start;
    let mut damping = 1e-3;
    let mut iterations = 0;
    while iterations < max_iterations && damping <= MAX_DAMPING {
        let mut damped = hessian;
        for k in 0..3 {
            damped[(k, k)] += damping * hessian[(k, k)].max(1e-12);
        }
        let Some(step) = damped.cholesky().map(|f| f.solve(&-gradient)) else {
            damping *= 10.0;
            continue;
        };
        let next = Pose2::new(pose.x + step[0], pose.y + step[1], wrap_angle(pose.yaw + step[2]));
        let (next_cost, next_gradient, next_hessian) = evaluate(grid, scan, next, prior, weight);
        if next_cost < cost {
            (pose, cost, gradient, hessian) = (next, next_cost, next_gradient, next_hessian);
            damping = (damping / 10.0).max(MIN_DAMPING);
            iterations += 1;
            if step[0].abs() + step[1].abs() < TOLERANCE && step[2].abs() < TOLERANCE {
                break;
            }
        } else {
            damping *= 10.0;
        }
    }
    Refinement { pose, cost, start_cost, information: hessian, iterations }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grids::likelihood_grid::FieldProfile;

    /// Two walls of a corner, 4 m long, points every 2 cm; a scan of them from (1, 1).
    fn corner() -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let mut plan = Vec::new();
        for i in 0..200 {
            let t = i as f64 * 0.02;
            plan.push([t, 0.0]);
            plan.push([0.0, t]);
        }
        let scan = plan.iter().map(|p| [p[0] - 1.0, p[1] - 1.0]).collect();
        (plan, scan)
    }

    fn weak_prior(at: Pose2) -> Prior {
        Prior { pose: at, information: Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 10.0)) }
    }

    #[test]
    fn climbs_to_the_true_pose_from_a_few_centimetres() {
        let (plan, scan) = corner();
        let grid = LikelihoodGrid::new(&plan, 0.02, 0.05, FieldProfile::Nearest).unwrap();
        let truth = Pose2::new(1.0, 1.0, 0.0);
        let start = Pose2::new(1.04, 0.97, 0.02);
        let found = refine(&grid, &scan, start, &weak_prior(start), 0.05, 50);
        assert!((found.pose.x - truth.x).abs() < 0.01, "{:?}", found.pose);
        assert!((found.pose.y - truth.y).abs() < 0.01, "{:?}", found.pose);
        assert!(found.pose.yaw.abs() < 0.005, "{:?}", found.pose);
        assert!(found.cost < found.start_cost);
        assert!(found.iterations > 0);
    }

    #[test]
    fn the_prior_decides_where_the_scan_says_nothing() {
        // A single wall along x: the scan fixes y and yaw, the prior x.
        let plan: Vec<[f64; 2]> = (0..400).map(|i| [i as f64 * 0.02, 0.0]).collect();
        let scan: Vec<[f64; 2]> = (50..350).map(|i| [i as f64 * 0.02 - 4.0, -1.0]).collect();
        let grid = LikelihoodGrid::new(&plan, 0.02, 0.05, FieldProfile::Nearest).unwrap();
        let prior = Prior {
            pose: Pose2::new(4.2, 1.0, 0.0),
            information: Matrix3::from_diagonal(&Vector3::new(100.0, 100.0, 1000.0)),
        };
        let found = refine(&grid, &scan, Pose2::new(4.3, 1.03, 0.0), &prior, 0.05, 50);
        assert!((found.pose.x - 4.2).abs() < 0.01, "{:?}", found.pose);
        assert!((found.pose.y - 1.0).abs() < 0.01, "{:?}", found.pose);
        // Information along the wall is the prior's alone; across it the scan's adds to it.
        assert!((found.information[(0, 0)] - 100.0).abs() < 1.0, "{}", found.information);
        assert!(found.information[(1, 1)] > 200.0, "{}", found.information);
    }

    #[test]
    fn cost_is_the_weighted_residuals_and_the_prior() {
        let (plan, scan) = corner();
        let grid = LikelihoodGrid::new(&plan, 0.02, 0.05, FieldProfile::Nearest).unwrap();
        let at = Pose2::new(1.0, 1.0, 0.0);
        let prior = Prior { pose: Pose2::new(1.1, 1.0, 0.0), information: Matrix3::identity() * 100.0 };
        // On the walls every residual is ~0: the cost is the prior's 100 * 0.1^2.
        assert!((cost(&grid, &scan, at, &prior, 0.05) - 1.0).abs() < 0.01);
        // Far from the plan every residual is 1.
        let far = Pose2::new(50.0, 50.0, 0.0);
        let alone = Prior { pose: far, information: Matrix3::zeros() };
        assert!((cost(&grid, &scan, far, &alone, 0.05) - 0.05 * scan.len() as f64).abs() < 1e-9);
    }
}
