//! Fuzz targets over the alignment half of the core: `PointMap::new`/`build`, `nearest`,
//! `visible_from`, `align` with random `IcpConfig`s, the covariance and normals, the
//! correspondence search and its cache, the rigid solver and the extrapolation.
//!
//! Every case feeds hostile inputs (see `fuzz_harness`) and checks that the call neither panics
//! nor hangs, that it refuses exactly the inputs the documentation says it refuses, with a
//! message, and that what it returns is finite and consistent. Case counts: `PLANICP_FUZZ_CASES`.

#[macro_use]
mod fuzz_harness;

use fuzz_harness::{clear_error, in_range, run, Case, Outcome};
use icp_core::cancel;
use icp_core::error::{IcpError, MAX_COORDINATE};
use icp_core::icp::acceleration::{extrapolation, truncated_cost, Update};
use icp_core::icp::candidate_cache::CandidateCache;
use icp_core::icp::correspondence::{find_pairs, trim, TargetSet};
use icp_core::icp::covariance::{pose_covariance, InlierPair};
use icp_core::icp::rigid_solver::{solve_rigid, MIN_PAIRS};
use icp_core::maps::pair::Pair;
use icp_core::maps::wall_normals::estimate_normals;
use icp_core::{align, IcpConfig, PointMap, Pose2};
use nalgebra::{Matrix3, SymmetricEigen};
use std::f64::consts::PI;

/// An explicit raster resolution, or `None`; never one whose raster would hold millions of cells
/// below the limit (memory), but sometimes one far beyond the limit (the refusal is cheap).
fn raster_resolution(c: &mut Case, pts: &[[f64; 2]]) -> Option<f64> {
    if c.coin(0.6) {
        return None;
    }
    let r = if c.coin(0.2) { c.special() } else { c.pick(&[1e-300, 1e-6, 0.01, 0.05, 0.1, 1.0, 1e300]) };
    if !(r.is_finite() && r > 0.0) || pts.is_empty() || !in_range(pts) {
        return Some(r);
    }
    let (lo, hi) = bounds(pts);
    let cells = ((hi[0] - lo[0]) / r + 3.0) * ((hi[1] - lo[1]) / r + 3.0);
    if cells > 4e6 && cells < 1e9 {
        None
    } else {
        Some(r)
    }
}

fn bounds(pts: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// Builds a map from random points; checks the outcome against the documented refusals.
/// `Ok(None)`: refused as documented.
fn random_map(c: &mut Case, max_n: usize) -> std::result::Result<Option<PointMap>, String> {
    let pts = c.points(max_n);
    let res = raster_resolution(c, &pts);
    let normals = if c.coin(0.2) {
        let n = if c.coin(0.8) { pts.len() } else { c.below(pts.len() + 3) };
        Some(
            (0..n)
                .map(|_| if c.coin(0.05) { [c.special(), 0.0] } else { unit(c.uniform(-PI, PI)) })
                .collect(),
        )
    } else {
        None
    };
    c.note(|| format!("plan bounds {:?}, {} points", bounds(&pts), pts.len()));
    c.note(|| format!("plan {pts:?} resolution {res:?} normals {normals:?}"));
    let valid_points = !pts.is_empty() && in_range(&pts);
    let valid_res = res.is_none_or(|r| r.is_finite() && r > 0.0);
    let valid_normals = normals.as_ref().is_none_or(|n: &Vec<[f64; 2]>| n.len() == pts.len() && in_range(n));
    // A plan far denser than useful keeps the first point of each THIN_CELL square, in order.
    let kept: Option<Vec<[f64; 2]>> = valid_points
        .then(|| {
            icp_core::maps::point_map::thinned(&pts).map(|k| k.iter().map(|&i| pts[i as usize]).collect())
        })
        .flatten();
    let n_points = kept.as_ref().map_or(pts.len(), Vec::len);
    let result = PointMap::build(pts, normals.clone(), res, cancel::NEVER);
    match result {
        Ok(map) => {
            ensure!(valid_points && valid_res && valid_normals, "accepted an invalid plan");
            ensure!(map.len() == n_points && map.normals().len() == n_points, "lengths");
            ensure!(kept.as_ref().is_none_or(|k| map.points() == &k[..]), "thinned points");
            ensure!(map.spacing().is_finite() && map.spacing() > 0.0, "spacing {}", map.spacing());
            let r = map.raster().resolution();
            ensure!(r.is_finite() && r > 0.0, "raster resolution {r}");
            if normals.is_none() {
                for n in map.normals() {
                    let len = n[0].hypot(n[1]);
                    ensure!(
                        *n == [0.0, 0.0] || (len - 1.0).abs() < 1e-9,
                        "fitted normal {n:?} is neither unit nor zero"
                    );
                }
            }
            Ok(Some(map))
        }
        Err(e) => {
            clear_error(&e)?;
            let explained = !valid_points
                || !valid_res
                || !valid_normals
                || matches!(e, IcpError::RasterTooLarge { .. } if res.is_some());
            ensure!(explained, "refused a valid plan: {e}");
            Ok(None)
        }
    }
}

fn unit(a: f64) -> [f64; 2] {
    [a.cos(), a.sin()]
}

/// A covariance is the documented "unknown" (inf diagonal, zeros elsewhere) or finite, symmetric
/// and positive semi-definite.
fn check_covariance(cov: &Matrix3<f64>) -> Outcome {
    ensure!(!cov.iter().any(|v| v.is_nan()), "NaN in covariance {cov}");
    if cov.iter().all(|v| v.is_finite()) {
        ensure!((cov - cov.transpose()).abs().max() <= 1e-12 * cov.abs().max(), "asymmetric {cov}");
        let eig = SymmetricEigen::new(*cov).eigenvalues;
        let scale = cov.abs().max();
        ensure!(eig.iter().all(|&l| l >= -1e-9 * scale), "not PSD: eigenvalues {eig} of {cov}");
        ensure!((0..3).all(|i| cov[(i, i)] >= 0.0), "negative variance {cov}");
    } else {
        let unknown = Matrix3::from_diagonal_element(f64::INFINITY);
        ensure!(*cov == unknown, "partly infinite covariance {cov}");
    }
    Ok(())
}

fn check_pose(p: &Pose2) -> Outcome {
    ensure!(p.is_finite(), "non-finite pose {p:?}");
    ensure!(p.yaw > -PI - 1e-12 && p.yaw <= PI + 1e-12, "yaw {} outside (-pi, pi]", p.yaw);
    Ok(())
}

/// A random configuration: mostly valid and near the defaults, sometimes extreme or invalid.
fn random_config(c: &mut Case) -> IcpConfig {
    let mut cfg = IcpConfig::default();
    let p = 0.08;
    if c.coin(0.5) {
        cfg.max_correspondence_distance = c.pick(&[0.05, 0.25, 0.5, 1.0, 3.0]);
    }
    if c.coin(p) {
        cfg.max_correspondence_distance = c.special();
    }
    if c.coin(0.3) {
        cfg.max_iterations = c.pick(&[0, 1, 2, 3, 5, 50, 120]);
    }
    if c.coin(0.3) {
        cfg.trim_ratio = c.pick(&[1e-300, 0.1, 0.5, 0.9, 1.0]);
    }
    if c.coin(p) {
        cfg.trim_ratio = c.special();
    }
    if c.coin(0.3) {
        cfg.auto_trim = true;
    }
    if c.coin(0.2) {
        cfg.translation_tolerance = 0.0;
        cfg.rotation_tolerance = 0.0;
    }
    if c.coin(p) {
        cfg.translation_tolerance = c.special();
    }
    if c.coin(p) {
        cfg.rotation_tolerance = c.special();
    }
    if c.coin(0.2) {
        cfg.subsample = c.pick(&[0, 1, 2, 3, 7, 1000, usize::MAX]);
    }
    if c.coin(0.3) {
        let n = c.below(5);
        cfg.correspondence_schedule = (0..n)
            .map(|_| if c.coin(0.1) { c.special() } else { c.pick(&[0.1, 0.25, 0.5, 1.0, 2.0, 4.0]) })
            .collect();
    }
    cfg.use_visibility = c.coin(0.7);
    cfg.accelerate = c.coin(0.7);
    if c.coin(0.2) {
        cfg.visibility_range = Some(if c.coin(0.3) { c.special() } else { c.pick(&[0.5, 5.0, 30.0, 1e6]) });
    }
    cfg
}

/// Whether `align` must accept this config and scan (the map is valid).
fn align_input_valid(cfg: &IcpConfig, scan: &[[f64; 2]], initial: &Pose2) -> bool {
    cfg.validate().is_ok()
        && !scan.is_empty()
        && in_range(scan)
        && initial.is_finite()
        && initial.x.abs() <= MAX_COORDINATE
        && initial.y.abs() <= MAX_COORDINATE
        && scan.len().div_ceil(cfg.subsample) >= MIN_PAIRS
}

#[test]
fn fuzz_point_map() {
    run("point_map", 3, |c| {
        let Some(map) = random_map(c, 3000)? else { return Ok(()) };
        for _ in 0..4 {
            let q = if c.coin(0.2) {
                [c.special(), c.special()]
            } else {
                let p = map.points()[c.below(map.len())];
                [p[0] + c.uniform(-1.0, 1.0), p[1] + c.uniform(-1.0, 1.0)]
            };
            if !(q[0].is_finite() && q[1].is_finite()) {
                continue; // a documented-free precondition of a KD-tree query; the core never asks.
            }
            let (i, d2) = map.nearest(q);
            ensure!((i as usize) < map.len(), "nearest index {i} of {}", map.len());
            if map.len() <= 400 {
                let best = map
                    .points()
                    .iter()
                    .map(|p| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2))
                    .fold(f64::INFINITY, f64::min);
                ensure!(d2 == best || (d2 - best).abs() <= 1e-9 * best, "nearest {d2} vs {best}");
            }
        }
        Ok(())
    });
}

#[test]
fn fuzz_visible_from() {
    run("visible_from", 3, |c| {
        let Some(map) = random_map(c, 2000)? else { return Ok(()) };
        for _ in 0..2 {
            let (x, y) = if c.coin(0.7) {
                let p = map.points()[c.below(map.len())];
                (p[0] + c.uniform(-3.0, 3.0), p[1] + c.uniform(-3.0, 3.0))
            } else {
                (c.special(), c.special())
            };
            let yaw = c.f64_or_special(-PI, PI, 0.1);
            let range = if c.coin(0.2) { c.special() } else { c.pick(&[1e-3, 0.5, 5.0, 30.0, 1e4]) };
            c.note(|| format!("pose ({x}, {y}, {yaw}) range {range}"));
            let valid = x.is_finite() && y.is_finite() && range.is_finite() && range > 0.0;
            match map.visible_from(Pose2 { x, y, yaw }, range) {
                Ok(v) => {
                    ensure!(valid, "accepted pose ({x}, {y}) range {range}");
                    ensure!(v.windows(2).all(|w| w[0] < w[1]), "indices not ascending and unique");
                    ensure!(v.iter().all(|&i| (i as usize) < map.len()), "index out of range");
                }
                Err(e) => {
                    clear_error(&e)?;
                    ensure!(!valid, "refused pose ({x}, {y}) range {range}: {e}");
                }
            }
        }
        Ok(())
    });
}

#[test]
fn fuzz_align() {
    run("align", 1, |c| {
        let Some(map) = random_map(c, 2500)? else { return Ok(()) };
        // A scan: plan points seen from a pose near the plan, with noise and clutter, or garbage.
        let anchor = map.points()[c.below(map.len())];
        let truth = Pose2::new(
            anchor[0] + c.uniform(-2.0, 2.0),
            anchor[1] + c.uniform(-2.0, 2.0),
            c.uniform(-PI, PI),
        );
        let mut scan: Vec<[f64; 2]> = if c.coin(0.7) {
            let inv = truth.inverse();
            let step = 1 + c.below(4);
            let noise = c.pick(&[0.0, 0.001, 0.01, 0.1]);
            map.points()
                .iter()
                .step_by(step)
                .take(1500)
                .map(|p| {
                    let q = inv.transform_point(*p);
                    [q[0] + c.uniform(-noise, noise), q[1] + c.uniform(-noise, noise)]
                })
                .collect()
        } else {
            c.points(1500)
        };
        if c.coin(0.2) {
            scan.extend(c.points(300));
        }
        let initial = if c.coin(0.85) {
            Pose2::new(
                truth.x + c.uniform(-0.3, 0.3),
                truth.y + c.uniform(-0.3, 0.3),
                truth.yaw + c.uniform(-0.2, 0.2),
            )
        } else {
            Pose2 { x: c.special(), y: c.f64_or_special(-5.0, 5.0, 0.5), yaw: c.f64_or_special(-PI, PI, 0.5) }
        };
        let cfg = random_config(c);
        c.note(|| format!("scan {scan:?}\n  initial {initial:?}\n  config {cfg:?}"));
        let valid = align_input_valid(&cfg, &scan, &initial);
        match align(&map, &scan, initial, &cfg, None, cancel::NEVER) {
            Ok(res) => {
                ensure!(valid, "accepted invalid input");
                check_pose(&res.pose)?;
                ensure!(res.iterations <= cfg.max_iterations, "{} iterations", res.iterations);
                ensure!(res.inlier_mask.len() == scan.len(), "mask length");
                let count = res.inlier_mask.iter().filter(|&&m| m).count();
                ensure!(count == res.num_inliers, "mask {count} vs num_inliers {}", res.num_inliers);
                let ratio = res.num_inliers as f64 / scan.len() as f64;
                ensure!(res.inlier_ratio == ratio, "inlier_ratio {}", res.inlier_ratio);
                if res.num_inliers == 0 {
                    ensure!(res.rmse.is_nan(), "rmse {} without inliers", res.rmse);
                } else {
                    ensure!(
                        res.rmse.is_finite()
                            && res.rmse >= 0.0
                            && res.rmse <= cfg.max_correspondence_distance,
                        "rmse {} (max distance {})",
                        res.rmse,
                        cfg.max_correspondence_distance
                    );
                }
                ensure!(
                    res.num_target_points >= 1 && res.num_target_points <= map.len(),
                    "num_target_points {}",
                    res.num_target_points
                );
                check_covariance(&res.covariance)?;
            }
            Err(e) => {
                clear_error(&e)?;
                ensure!(!valid, "refused valid input: {e}");
            }
        }
        Ok(())
    });
}

#[test]
fn fuzz_covariance_and_normals() {
    run("covariance", 3, |c| {
        let Some(map) = random_map(c, 1500)? else { return Ok(()) };
        let normals = estimate_normals(map.points(), map.tree(), cancel::NEVER).unwrap();
        ensure!(normals.len() == map.len(), "normals length");
        let pose =
            Pose2 { x: c.f64_or_special(-5.0, 5.0, 0.1), y: c.uniform(-5.0, 5.0), yaw: c.uniform(-PI, PI) };
        let n = c.below(300);
        let noise = c.pick(&[0.0, 1e-300, 1e-3, 0.1, 1e6]);
        // Beams in any order, some repeated: the covariance sorts them.
        let pairs: Vec<InlierPair> = (0..n)
            .map(|_| {
                let i = c.below(map.len());
                let p = map.points()[i];
                let point = [p[0] + c.uniform(-noise, noise), p[1] + c.uniform(-noise, noise)];
                InlierPair { beam: c.below(2 * n + 1) as u32, point, target: i as u32 }
            })
            .collect();
        c.note(|| format!("pose {pose:?} pairs {pairs:?}"));
        let uncertainty = pose_covariance(&map, map.normals(), &pose, &pairs);
        if pose.is_finite() {
            check_covariance(&uncertainty.covariance)?;
            let h = uncertainty.constraint;
            ensure!(!h.iter().any(|v| v.is_nan()), "NaN in constraint {h}");
        }
        Ok(())
    });
}

#[test]
fn fuzz_correspondences_and_cache() {
    run("correspondences", 1, |c| {
        let Some(map) = random_map(c, 2000)? else { return Ok(()) };
        let target = if c.coin(0.5) {
            let idx: Vec<u32> = (0..map.len() as u32).filter(|_| c.coin(0.5)).collect();
            TargetSet::subset(&map, idx).unwrap_or(TargetSet::Full(&map))
        } else {
            TargetSet::Full(&map)
        };
        let distance = c.pick(&[1e-300, 0.01, 0.1, 0.25, 1.0]);
        let mut cache = CandidateCache::new(2.0 * distance);
        let mut positions: Vec<[f64; 2]> = (0..c.below(400))
            .map(|_| {
                let p = map.points()[c.below(map.len())];
                [p[0] + c.uniform(-0.3, 0.3), p[1] + c.uniform(-0.3, 0.3)]
            })
            .collect();
        let (mut direct, mut cached) = (Vec::new(), Vec::new());
        for _ in 0..6 {
            // Move the scan a little (as ICP does), sometimes a lot.
            let jump = if c.coin(0.2) { 1.0 } else { 0.1 * distance };
            let (dx, dy) = (c.uniform(-jump, jump), c.uniform(-jump, jump));
            positions.iter_mut().for_each(|p| *p = [p[0] + dx, p[1] + dy]);
            find_pairs(&target, &positions, distance, &mut direct);
            cache.find_pairs(&target, &positions, distance, &mut cached);
            let key = |p: &Pair| (p.source, p.sq_dist.to_bits());
            let (mut a, mut b): (Vec<_>, Vec<_>) =
                (direct.iter().map(key).collect(), cached.iter().map(key).collect());
            a.sort_unstable();
            b.sort_unstable();
            ensure!(a == b, "cache pairs differ from the direct search");
            let before = direct.len();
            let ratio = c.pick(&[1e-300, 0.3, 0.9, 1.0]);
            trim(&mut direct, ratio, MIN_PAIRS);
            ensure!(direct.len() <= before, "trim grew the pairs");
            ensure!(direct.len() >= before.min(MIN_PAIRS), "trim kept {} of {before}", direct.len());
            let cost = truncated_cost(&direct, positions.len(), distance);
            ensure!(cost.is_finite() && cost >= 0.0, "truncated cost {cost}");
        }
        Ok(())
    });
}

#[test]
fn fuzz_rigid_solver_and_extrapolation() {
    run("rigid_solver", 30, |c| {
        let src = c.points(200);
        let truth =
            Pose2::new(c.f64_or_special(-10.0, 10.0, 0.05), c.uniform(-10.0, 10.0), c.uniform(-PI, PI));
        let noise = c.pick(&[0.0, 0.0, 1e-6, 0.01]);
        let dst: Vec<[f64; 2]> = src
            .iter()
            .map(|p| {
                let q = truth.transform_point(*p);
                [q[0] + c.uniform(-noise, noise), q[1] + c.uniform(-noise, noise)]
            })
            .collect();
        c.note(|| format!("src {src:?} truth {truth:?}"));
        let solved = solve_rigid(&src, &dst);
        if let Some(p) = solved {
            check_pose(&p)?;
            ensure!(src.len() >= MIN_PAIRS, "solved from {} pairs", src.len());
        }
        // Exact recovery on well-spread, moderate points without noise.
        let (lo, hi) = bounds(&src);
        let spread = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        if noise == 0.0
            && src.len() >= MIN_PAIRS
            && in_range(&src)
            && spread > 0.5
            && spread < 1e3
            && truth.is_finite()
        {
            let (lo2, hi2) = bounds(&src);
            let _ = (lo2, hi2);
            let max_abs = src.iter().flat_map(|p| p.iter()).fold(0.0f64, |m, v| m.max(v.abs()));
            // Collinear points still fix the transform; only coincident ones do not.
            if max_abs < 1e3 && truth.x.abs() < 1e3 {
                let Some(p) = solved else { return Err("no solution for a spread point set".into()) };
                let err = (p.x - truth.x).abs().max((p.y - truth.y).abs());
                let yaw_err = icp_core::pose::wrap_angle(p.yaw - truth.yaw).abs();
                ensure!(err < 1e-6 && yaw_err < 1e-8, "recovered {p:?}, truth {truth:?}");
            }
        }
        // Extrapolation of two random updates: finite in, finite out.
        let u1 = Update::new(
            &Pose2::new(c.uniform(-0.1, 0.1), c.uniform(-0.1, 0.1), c.uniform(-0.05, 0.05)),
            [c.uniform(-10.0, 10.0), c.uniform(-10.0, 10.0)],
        );
        let step = Pose2::new(c.uniform(-0.1, 0.1), c.uniform(-0.1, 0.1), c.uniform(-0.05, 0.05));
        let u2 = Update::new(&step, [c.uniform(-10.0, 10.0), c.uniform(-10.0, 10.0)]);
        let radius = c.f64_or_special(0.0, 30.0, 0.1);
        if let Some(j) = extrapolation(&u1, &u2, radius) {
            if radius.is_finite() {
                check_pose(&j)?;
            }
        }
        Ok(())
    });
}
