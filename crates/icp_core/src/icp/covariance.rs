//! Pose covariance of a finished alignment, over (x, y, yaw) of `T_map_base`.
//!
//! Each inlier is treated as a measurement of its distance to the plan's wall line (point-to-line,
//! normal taken from the plan's local point structure, [`crate::maps::wall_normals`]), so that a
//! direction the walls do not constrain (a long corridor) shows up as a large variance instead of
//! being hidden by the point-to-point pairing. `cov = sigma^2 H^-1` with `H = sum J J^T`,
//! `J = [n_x, n_y, n . perp(p - t)]` and `sigma^2` the residual variance along the normals. `H`
//! itself is returned too: it tells along which direction the walls fix the pose (degeneracy).

use crate::maps::point_map::PointMap;
use crate::pose::Pose2;
use nalgebra::{Matrix3, Vector3};

/// How well an alignment fixes the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseUncertainty {
    /// Covariance over (x, y, yaw) (m^2, m rad, rad^2): `sigma^2 H^-1`; `inf` on the diagonal (0
    /// elsewhere) when fewer than four pairs have a normal or `H` is singular.
    pub covariance: Matrix3<f64>,
    /// `H = sum J J^T` over the inliers with a wall normal (x, y unitless; yaw terms in metres):
    /// along a unit direction `u` of the plane, `u^T H[0..2, 0..2] u` counts how many inliers'
    /// worth of wall normal point along `u`. Zero along a direction no wall faces.
    pub constraint: Matrix3<f64>,
}

/// The [`PoseUncertainty`] of `pose` given inlier pairs `(scan point already in the map frame,
/// plan index)`.
pub fn pose_covariance(
    map: &PointMap,
    normals: &[[f64; 2]],
    pose: &Pose2,
    pairs: &[([f64; 2], u32)],
) -> PoseUncertainty {
    let mut h = Matrix3::<f64>::zeros();
    let mut sum_sq = 0.0;
    let mut m = 0usize;
    for (p, idx) in pairs {
        let n = normals[*idx as usize];
        if n == [0.0, 0.0] {
            continue;
        }
        let q = map.points()[*idx as usize];
        let r = n[0] * (p[0] - q[0]) + n[1] * (p[1] - q[1]);
        let lever = [p[0] - pose.x, p[1] - pose.y];
        let j = Vector3::new(n[0], n[1], n[0] * -lever[1] + n[1] * lever[0]);
        h += j * j.transpose();
        sum_sq += r * r;
        m += 1;
    }
    let unknown =
        PoseUncertainty { covariance: Matrix3::from_diagonal_element(f64::INFINITY), constraint: h };
    if m < 4 {
        return unknown;
    }
    let sigma2 = sum_sq / (m - 3) as f64;
    match inverse_psd(&h) {
        Some(inv) => {
            let c = inv * sigma2;
            let c = (c + c.transpose()) * 0.5;
            if c.iter().all(|v| v.is_finite()) {
                PoseUncertainty { covariance: c, constraint: h }
            } else {
                unknown
            }
        }
        None => unknown,
    }
}

/// Smallest eigenvalue, relative to the largest, of the rescaled constraint that still counts as
/// information; below it the direction is unconstrained.
const MIN_RELATIVE_EIGENVALUE: f64 = 1e-12;

/// The inverse of a symmetric positive semi-definite `h`, or None when a direction has (next to)
/// no information. `h` mixes units (unitless x, y; metres and square metres for yaw terms, which
/// reach 1e18 far from the origin), so it is first rescaled to a unit diagonal and inverted through
/// its eigendecomposition: a plain inverse of a badly conditioned `h` came back finite but not
/// positive semi-definite.
fn inverse_psd(h: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let d = Vector3::new(h[(0, 0)], h[(1, 1)], h[(2, 2)]);
    if !d.iter().all(|v| v.is_finite() && *v > 0.0) {
        return None;
    }
    let scale = d.map(|v| 1.0 / v.sqrt());
    let s = Matrix3::from_diagonal(&scale);
    let rescaled = s * h * s;
    let eigen = nalgebra::SymmetricEigen::new((rescaled + rescaled.transpose()) * 0.5);
    let largest = eigen.eigenvalues.max();
    if !(largest.is_finite() && largest > 0.0)
        || eigen.eigenvalues.iter().any(|&l| !l.is_finite() || l <= largest * MIN_RELATIVE_EIGENVALUE)
    {
        return None;
    }
    let inverse_values = Matrix3::from_diagonal(&eigen.eigenvalues.map(|l| 1.0 / l));
    let inv = s * (eigen.eigenvectors * inverse_values * eigen.eigenvectors.transpose()) * s;
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cancel;
    use crate::maps::wall_normals::estimate_normals;

    #[test]
    fn corridor_is_unconstrained_along_its_axis() {
        // Two long parallel walls: x is free, y and yaw are fixed.
        let mut pts = Vec::new();
        for i in 0..400 {
            let x = i as f64 * 0.05;
            pts.push([x, 1.0]);
            pts.push([x, -1.0]);
        }
        let map = PointMap::new(pts.clone(), None).unwrap();
        let normals = estimate_normals(map.points(), map.tree(), cancel::NEVER).unwrap();
        let pose = Pose2::new(10.0, 0.0, 0.0);
        let pairs: Vec<([f64; 2], u32)> = (0..pts.len())
            .step_by(3)
            .map(|i| {
                let jitter = if i % 2 == 0 { 0.004 } else { -0.003 };
                ([pts[i][0], pts[i][1] + jitter], i as u32)
            })
            .collect();
        let PoseUncertainty { covariance: cov, constraint } = pose_covariance(&map, &normals, &pose, &pairs);
        assert!(cov[(0, 0)].is_infinite() || cov[(0, 0)] > 1e3 * cov[(1, 1)], "{cov}");
        // No wall normal points along x; every pair constrains y.
        assert!(constraint[(0, 0)] < 1e-9, "{constraint}");
        assert!((constraint[(1, 1)] - pairs.len() as f64).abs() < 1e-6, "{constraint}");
    }

    #[test]
    fn far_from_the_origin_the_covariance_stays_positive_semi_definite() {
        // Lever arms of 1e8 m make the yaw terms of H about 1e16 times the others: a plain inverse
        // came back finite with a negative eigenvalue (found by the fuzz target).
        let mut pts = Vec::new();
        for i in 0..=100 {
            let t = i as f64 * 0.05;
            pts.extend([[1e8 + t, 0.0], [1e8 + t, 5.0], [1e8, t], [1e8 + 5.0, t]]);
        }
        let map = PointMap::new(pts.clone(), None).unwrap();
        let normals = estimate_normals(map.points(), map.tree(), cancel::NEVER).unwrap();
        let pose = Pose2::new(0.0, 2.5, 0.0);
        let pairs: Vec<([f64; 2], u32)> = pts
            .iter()
            .enumerate()
            .map(|(i, p)| ([p[0] + if i % 2 == 0 { 0.01 } else { -0.01 }, p[1]], i as u32))
            .collect();
        let cov = pose_covariance(&map, &normals, &pose, &pairs).covariance;
        if cov.iter().all(|v| v.is_finite()) {
            let eig = nalgebra::SymmetricEigen::new(cov).eigenvalues;
            assert!(eig.iter().all(|&l| l >= -1e-9 * cov.abs().max()), "{eig}");
        } else {
            assert_eq!(cov, Matrix3::from_diagonal_element(f64::INFINITY));
        }
    }

    #[test]
    fn room_covariance_is_small_and_scales_with_noise() {
        let mut pts = Vec::new();
        for i in 0..=100 {
            let t = i as f64 * 0.05;
            pts.extend([[t, 0.0], [t, 5.0], [0.0, t], [5.0, t]]);
        }
        let map = PointMap::new(pts.clone(), None).unwrap();
        let normals = estimate_normals(map.points(), map.tree(), cancel::NEVER).unwrap();
        let pose = Pose2::new(2.5, 2.5, 0.0);
        let covariance_for = |noise: f64| {
            let pairs: Vec<([f64; 2], u32)> = pts
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let s = if i % 2 == 0 { noise } else { -noise };
                    ([p[0] + s, p[1] + s], i as u32)
                })
                .collect();
            pose_covariance(&map, &normals, &pose, &pairs).covariance
        };
        let c1 = covariance_for(0.01);
        let c2 = covariance_for(0.02);
        assert!(c1[(0, 0)].is_finite() && c1[(0, 0)] > 0.0 && c1[(0, 0)] < 1e-5, "{c1}");
        assert!((c2[(0, 0)] / c1[(0, 0)] - 4.0).abs() < 0.2, "{} {}", c1[(0, 0)], c2[(0, 0)]);
        assert!(c1[(2, 2)] > 0.0 && c1[(2, 2)] < 1e-5);
    }
}
