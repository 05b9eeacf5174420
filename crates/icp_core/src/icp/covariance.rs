//! Pose covariance of a finished alignment, over (x, y, yaw) of `T_map_base`.
//!
//! Each inlier is treated as a measurement of its distance to the plan's wall line (point-to-line,
//! normal taken from the plan's local point structure, [`crate::maps::wall_normals`]), so that a
//! direction the walls do not constrain (a long corridor) shows up as a large variance instead of
//! being hidden by the point-to-point pairing. With `J = [n_x, n_y, n . perp(p - t)]` the
//! residual's gradient, `r` the residual along the normal and `H = sum J J^T`:
//!
//! - `sigma^2 H^-1` (`sigma^2` the residual variance) holds when every residual is independent:
//!   the noise of the beams. On a real building it is not: neighbouring beams see the same stretch
//!   of wall, drawn or mapped a little off, and their residuals share that error, so that 180
//!   returns are worth far fewer independent ones (docs/design.md, "Covariance that means
//!   something").
//! - The covariance returned is therefore the sandwich `H^-1 S H^-1`, `S` the Newey-West
//!   (heteroscedasticity and autocorrelation consistent) estimate of the covariance of the summed
//!   scores `J r`: their products over pairs up to `L` beams apart, weighted by Bartlett's
//!   `1 - lag / (L + 1)`, the cross terms' negative part dropped. The bandwidth `L` is chosen from
//!   the scan's own residuals by Newey and West's automatic rule ("Automatic lag selection in
//!   covariance matrix estimation", 1994): independent residuals give a short lag and
//!   `S ~ sigma^2 H`, residuals that share a wall's error a lag as long as that wall.

use crate::maps::point_map::PointMap;
use crate::pose::Pose2;
use nalgebra::{Matrix3, Vector3};

/// How well an alignment fixes the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseUncertainty {
    /// Covariance over (x, y, yaw) (m^2, m rad, rad^2): `H^-1 S H^-1` (see the module); `inf` on
    /// the diagonal (0 elsewhere) when fewer than four pairs have a normal or `H` is singular.
    pub covariance: Matrix3<f64>,
    /// `H = sum J J^T` over the inliers with a wall normal (x, y unitless; yaw terms in metres):
    /// along a unit direction `u` of the plane, `u^T H[0..2, 0..2] u` counts how many inliers'
    /// worth of wall normal point along `u`. Zero along a direction no wall faces.
    pub constraint: Matrix3<f64>,
    /// The Newey-West bandwidth `L` the scan's residuals chose, in beams (0: residuals
    /// uncorrelated from one beam to the next).
    pub bandwidth: usize,
}

/// One inlier of a finished alignment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InlierPair {
    /// Index of the return in its scan: returns are in beam order, so neighbouring indices are
    /// neighbouring beams.
    pub beam: u32,
    /// The return, already in the map frame (m).
    pub point: [f64; 2],
    /// Index of the plan point it is paired with.
    pub target: u32,
}

/// The [`PoseUncertainty`] of `pose` given its inlier pairs.
pub fn pose_covariance(
    map: &PointMap,
    normals: &[[f64; 2]],
    pose: &Pose2,
    pairs: &[InlierPair],
) -> PoseUncertainty {
    let mut h = Matrix3::<f64>::zeros();
    let mut scores: Vec<(u32, Vector3<f64>)> = Vec::with_capacity(pairs.len());
    for pair in pairs {
        let n = normals[pair.target as usize];
        if n == [0.0, 0.0] {
            continue;
        }
        let (p, q) = (pair.point, map.points()[pair.target as usize]);
        let r = n[0] * (p[0] - q[0]) + n[1] * (p[1] - q[1]);
        let lever = [p[0] - pose.x, p[1] - pose.y];
        let j = Vector3::new(n[0], n[1], n[0] * -lever[1] + n[1] * lever[0]);
        h += j * j.transpose();
        scores.push((pair.beam, j * r));
    }
    let m = scores.len();
    let unknown = PoseUncertainty {
        covariance: Matrix3::from_diagonal_element(f64::INFINITY),
        constraint: h,
        bandwidth: 0,
    };
    if m < 4 {
        return unknown;
    }
    scores.sort_by_key(|(beam, _)| *beam);
    let scale =
        Vector3::new(h[(0, 0)], h[(1, 1)], h[(2, 2)]).map(|v| if v > 0.0 { 1.0 / v.sqrt() } else { 0.0 });
    let bandwidth = automatic_bandwidth(&scores, &scale);
    let s = long_run_covariance(&scores, bandwidth);
    match inverse_psd(&h) {
        Some(inv) => {
            // m / (m - 3): the residuals were fitted with three parameters.
            let c = inv * s * inv * (m as f64 / (m - 3) as f64);
            let c = (c + c.transpose()) * 0.5;
            if c.iter().all(|v| v.is_finite()) {
                PoseUncertainty { covariance: c, constraint: h, bandwidth }
            } else {
                unknown
            }
        }
        None => unknown,
    }
}

/// `S = sum_ij w(|b_i - b_j|) g_i g_j^T` over scores `(beam b, score g)` sorted by beam, with
/// Bartlett's weight `w(lag) = 1 - lag / (bandwidth + 1)` (0 beyond `bandwidth`): a missing beam
/// (no inlier) is a zero score, so `S` stays positive semi-definite. Only the positive part of the
/// cross terms (`i != j`) is kept: correlation between neighbouring returns may widen the
/// covariance, never narrow it below the independent returns' `sum g_i g_i^T`. Walls do not give
/// neighbouring beams opposite errors; where residuals alternate in sign (two interleaved lasers
/// slightly out of calibration, a zigzag of the plan's lattice), that is no evidence that the
/// returns together fix the pose better than each alone says.
fn long_run_covariance(scores: &[(u32, Vector3<f64>)], bandwidth: usize) -> Matrix3<f64> {
    let mut own = Matrix3::<f64>::zeros();
    let mut cross = Matrix3::<f64>::zeros();
    let span = bandwidth as u64;
    for (i, (bi, gi)) in scores.iter().enumerate() {
        own += gi * gi.transpose();
        for (bj, gj) in &scores[i + 1..] {
            let lag = u64::from(*bj - *bi);
            if lag > span {
                break;
            }
            let w = 1.0 - lag as f64 / (span + 1) as f64;
            let c = gi * gj.transpose();
            cross += (c + c.transpose()) * w;
        }
    }
    own + positive_part(&cross)
}

/// The symmetric `m` with its negative eigenvalues set to 0.
fn positive_part(m: &Matrix3<f64>) -> Matrix3<f64> {
    let eigen = nalgebra::SymmetricEigen::new((m + m.transpose()) * 0.5);
    let kept = Matrix3::from_diagonal(&eigen.eigenvalues.map(|l| l.max(0.0)));
    eigen.eigenvectors * kept * eigen.eigenvectors.transpose()
}

/// Newey and West's (1994) automatic bandwidth for Bartlett's kernel: from the autocovariances
/// `c_j` (j = 0..=n_pre beams apart) of the scores rescaled to unit information (`scale`) and
/// summed over their three components, `s0 = c_0 + 2 sum c_j`, `s1 = 2 sum j c_j`, and
/// `L = floor(1.1447 ((s1 / s0)^2 n)^(1/3))`, `n` the beams spanned; the preliminary estimate's
/// lag is `n_pre = floor(4 (n / 100)^(2/9))`. Capped at `n - 1`; 0 when the scores show no
/// positive long-run variance.
fn automatic_bandwidth(scores: &[(u32, Vector3<f64>)], scale: &Vector3<f64>) -> usize {
    let (Some(first), Some(last)) = (scores.first(), scores.last()) else {
        return 0;
    };
    let n = (last.0 - first.0) as usize + 1;
    let pre = (4.0 * (n as f64 / 100.0).powf(2.0 / 9.0)).floor() as usize;
    let mut c = vec![0.0; pre + 1];
    let u: Vec<(u32, f64)> = scores.iter().map(|(b, g)| (*b, g.component_mul(scale).sum())).collect();
    for (i, (bi, ui)) in u.iter().enumerate() {
        for (bj, uj) in &u[i..] {
            let lag = (*bj - *bi) as usize;
            if lag > pre {
                break;
            }
            c[lag] += ui * uj;
        }
    }
    let s0 = c[0] + 2.0 * c[1..].iter().sum::<f64>();
    let s1 = 2.0 * c.iter().enumerate().map(|(j, cj)| j as f64 * cj).sum::<f64>();
    if s0.is_nan() || s0 <= 0.0 || !s1.is_finite() {
        return 0;
    }
    let l = 1.1447 * ((s1 / s0).powi(2) * n as f64).cbrt();
    if l.is_finite() {
        (l.floor() as usize).min(n - 1)
    } else {
        0
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

    /// Plan point `i` observed at `point` by beam `i`.
    fn pair(i: usize, point: [f64; 2]) -> InlierPair {
        InlierPair { beam: i as u32, point, target: i as u32 }
    }

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
        let pairs: Vec<InlierPair> = (0..pts.len())
            .step_by(3)
            .map(|i| {
                let jitter = if i % 2 == 0 { 0.004 } else { -0.003 };
                pair(i, [pts[i][0], pts[i][1] + jitter])
            })
            .collect();
        let PoseUncertainty { covariance: cov, constraint, .. } =
            pose_covariance(&map, &normals, &pose, &pairs);
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
        let pairs: Vec<InlierPair> = pts
            .iter()
            .enumerate()
            .map(|(i, p)| pair(i, [p[0] + if i % 2 == 0 { 0.01 } else { -0.01 }, p[1]]))
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
            let pairs: Vec<InlierPair> = pts
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let s = if i % 2 == 0 { noise } else { -noise };
                    pair(i, [p[0] + s, p[1] + s])
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

    /// A 5 x 5 m room's walls, sampled every 5 cm in the order a scanning beam sweeps them, and
    /// the plan point indices in that order.
    fn swept_room() -> (PointMap, Vec<[f64; 2]>) {
        let mut pts = Vec::new();
        for i in 0..100 {
            let t = i as f64 * 0.05;
            pts.push([t, 0.0]);
        }
        for i in 0..100 {
            pts.push([5.0, i as f64 * 0.05]);
        }
        for i in 0..100 {
            pts.push([5.0 - i as f64 * 0.05, 5.0]);
        }
        for i in 0..100 {
            pts.push([0.0, 5.0 - i as f64 * 0.05]);
        }
        (PointMap::new(pts.clone(), None).unwrap(), pts)
    }

    /// Uniform noise in [-amplitude, amplitude] from a fixed linear congruential sequence.
    fn white_noise(count: usize, amplitude: f64) -> Vec<f64> {
        let mut state: u64 = 0x2545_f491_4f6c_dd1d;
        (0..count)
            .map(|_| {
                state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
                amplitude * (2.0 * ((state >> 11) as f64 / (1u64 << 53) as f64) - 1.0)
            })
            .collect()
    }

    /// The covariance `sigma^2 H^-1` that independent residuals would give.
    fn independent(map: &PointMap, normals: &[[f64; 2]], pose: &Pose2, pairs: &[InlierPair]) -> Matrix3<f64> {
        let u = pose_covariance(map, normals, pose, pairs);
        let mut sum_sq = 0.0;
        for p in pairs {
            let n = normals[p.target as usize];
            let q = map.points()[p.target as usize];
            let r = n[0] * (p.point[0] - q[0]) + n[1] * (p.point[1] - q[1]);
            sum_sq += r * r;
        }
        inverse_psd(&u.constraint).unwrap() * (sum_sq / (pairs.len() - 3) as f64)
    }

    /// Each plan point observed by one beam, displaced along its wall's inward normal by
    /// `offset(i)` (the room is convex, so every wall's normal points to its centre).
    fn observed(pts: &[[f64; 2]], offset: impl Fn(usize) -> f64) -> Vec<InlierPair> {
        pts.iter()
            .enumerate()
            .map(|(i, p)| {
                let d = offset(i);
                let point = match i / 100 {
                    0 => [p[0], p[1] + d],
                    1 => [p[0] - d, p[1]],
                    2 => [p[0], p[1] - d],
                    _ => [p[0] + d, p[1]],
                };
                pair(i, point)
            })
            .collect()
    }

    /// The swept room seen from its centre with each return displaced by `offset(beam)`: the
    /// covariance and the `sigma^2 H^-1` independent residuals would give.
    fn room_covariances(offset: impl Fn(usize) -> f64) -> (PoseUncertainty, Matrix3<f64>) {
        let (map, pts) = swept_room();
        let normals = estimate_normals(map.points(), map.tree(), cancel::NEVER).unwrap();
        let pose = Pose2::new(2.5, 2.5, 0.0);
        let pairs = observed(&pts, offset);
        (pose_covariance(&map, &normals, &pose, &pairs), independent(&map, &normals, &pose, &pairs))
    }

    #[test]
    fn independent_residuals_choose_a_short_lag_and_keep_sigma_squared_h_inverse() {
        let noise = white_noise(400, 0.01);
        let (u, plain) = room_covariances(|i| noise[i]);
        assert!(u.bandwidth <= 4, "white noise chose a lag of {} beams", u.bandwidth);
        for k in 0..3 {
            let ratio = u.covariance[(k, k)] / plain[(k, k)];
            assert!((0.6..1.6).contains(&ratio), "axis {k}: {ratio} times sigma^2 H^-1");
        }
    }

    #[test]
    fn residuals_that_share_a_walls_error_widen_the_covariance() {
        // The wall at y = 0 drawn 2 cm off along its first half, the rest of the room right: the
        // 50 returns on that stretch share one error, which sigma^2 H^-1 counts as 50
        // independent measurements.
        let noise = white_noise(400, 0.002);
        let (u, plain) = room_covariances(|i| noise[i] + if i < 50 { 0.02 } else { 0.0 });
        assert!(u.bandwidth >= 10, "a 50-beam stretch chose a lag of {} beams", u.bandwidth);
        let ratio = u.covariance[(1, 1)] / plain[(1, 1)];
        assert!(ratio > 10.0, "y variance only {ratio} times sigma^2 H^-1");
    }

    #[test]
    fn residuals_alternating_in_sign_do_not_narrow_the_covariance() {
        // Two beams 1 cm in front of the wall, the next two 1 cm behind, and so on: the scores of
        // beams two apart cancel, which a plain Newey-West sum would read as the returns fixing
        // the pose better together than alone.
        let (u, plain) = room_covariances(|i| if i % 4 < 2 { 0.01 } else { -0.01 });
        for k in 0..3 {
            let ratio = u.covariance[(k, k)] / plain[(k, k)];
            assert!(ratio > 0.95, "axis {k}: {ratio} times sigma^2 H^-1");
        }
    }
}
