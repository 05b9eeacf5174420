//! Tests of the ICP loop: poses recovered, budgets and cancellation, outliers, both searches, bad input.

use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Wall points of an L-shaped pair of rooms with 0.2 m thick walls, every 0.05 m on both faces.
fn rooms() -> Vec<[f64; 2]> {
    let mut pts = Vec::new();
    let mut segment = |a: [f64; 2], b: [f64; 2]| {
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let n = (len / 0.05).round() as usize;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    };
    for (a, b) in [
        ([0.0, 0.0], [8.0, 0.0]),
        ([8.0, 0.0], [8.0, 5.0]),
        ([8.0, 5.0], [0.0, 5.0]),
        ([0.0, 5.0], [0.0, 0.0]),
        ([-0.2, -0.2], [8.2, -0.2]),
        ([8.2, -0.2], [8.2, 5.2]),
        ([8.2, 5.2], [-0.2, 5.2]),
        ([-0.2, 5.2], [-0.2, -0.2]),
        ([3.0, 0.0], [3.0, 3.0]),
        ([3.2, 0.0], [3.2, 3.0]),
        ([3.0, 3.0], [3.2, 3.0]),
    ] {
        segment(a, b);
    }
    pts
}

/// A scan seen from `truth` (robot frame): points on the visible wall faces, placed at random
/// along the wall (as beams would hit it, not on the plan's sample points), with uniform
/// noise of `noise` metres.
fn scan_from(map: &PointMap, truth: Pose2, rng: &mut ChaCha8Rng, noise: f64) -> Vec<[f64; 2]> {
    let inv = truth.inverse();
    map.visible_from(truth, 20.0)
        .unwrap()
        .iter()
        .map(|&i| {
            let q = map.points()[i as usize];
            let n = map.normals()[i as usize];
            let along = rng.random_range(-0.02..=0.02);
            let w = [q[0] - n[1] * along, q[1] + n[0] * along];
            let p = inv.transform_point(w);
            [p[0] + rng.random_range(-noise..=noise), p[1] + rng.random_range(-noise..=noise)]
        })
        .collect()
}

#[test]
fn recovers_known_transform_from_offset_guess() {
    let map = PointMap::new(rooms(), None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let truth = Pose2::new(5.5, 2.2, 0.4);
    let scan = scan_from(&map, truth, &mut rng, 0.0);
    let guess = Pose2::new(5.7, 2.05, 0.45);
    let res = align(&map, &scan, guess, &IcpConfig::default(), None, cancel::NEVER).unwrap();
    // Point-to-point pairs with 5 cm plan spacing: a few millimetres of discretisation error.
    assert!((res.pose.x - truth.x).abs() < 0.005, "{:?}", res.pose);
    assert!((res.pose.y - truth.y).abs() < 0.005, "{:?}", res.pose);
    assert!((res.pose.yaw - truth.yaw).abs() < 0.002, "{:?}", res.pose);
    assert!(res.converged);
    assert_eq!(res.num_inliers, scan.len());
    assert!(res.rmse < 0.02, "rmse {}", res.rmse);
}

#[test]
fn zero_tolerances_run_every_iteration() {
    let map = PointMap::new(rooms(), None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let truth = Pose2::new(5.0, 2.5, -0.2);
    let scan = scan_from(&map, truth, &mut rng, 0.01);
    let cfg = IcpConfig {
        translation_tolerance: 0.0,
        rotation_tolerance: 0.0,
        max_iterations: 17,
        ..IcpConfig::default()
    };
    let res = align(&map, &scan, Pose2::new(5.1, 2.4, -0.15), &cfg, None, cancel::NEVER).unwrap();
    assert_eq!(res.iterations, 17);
    assert!(res.converged, "a fixed point should be reached within 17 iterations");
    let early =
        align(&map, &scan, Pose2::new(5.1, 2.4, -0.15), &IcpConfig::default(), None, cancel::NEVER).unwrap();
    assert!(
        early.iterations < IcpConfig::default().max_iterations,
        "tolerances should stop early, ran {}",
        early.iterations
    );
    assert!((early.pose.x - res.pose.x).abs() < 1e-3);
}

#[test]
fn a_cancel_hook_stops_an_endless_budget_and_a_silent_one_changes_nothing() {
    let map = PointMap::new(rooms(), None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let scan = scan_from(&map, Pose2::new(5.0, 2.5, -0.2), &mut rng, 0.01);
    let guess = Pose2::new(5.1, 2.4, -0.15);
    for search in [CorrespondenceSearch::WallIndex, CorrespondenceSearch::KdTree] {
        // Zero tolerances: every one of usize::MAX iterations would run (for centuries).
        let endless = IcpConfig {
            translation_tolerance: 0.0,
            rotation_tolerance: 0.0,
            max_iterations: usize::MAX,
            search,
            ..IcpConfig::default()
        };
        let polls = std::cell::Cell::new(0usize);
        let after_200 = || {
            polls.set(polls.get() + 1);
            polls.get() > 200
        };
        let out = align(&map, &scan, guess, &endless, None, &after_200);
        assert_eq!(out, Err(IcpError::Interrupted));
        // It stopped at the first poll that asked: no iteration ran after it.
        assert_eq!(polls.get(), 201);
        let bounded = IcpConfig { max_iterations: 17, ..endless };
        let polls = std::cell::Cell::new(0usize);
        let counting = || {
            polls.set(polls.get() + 1);
            false
        };
        let res = align(&map, &scan, guess, &bounded, None, &counting).unwrap();
        assert_eq!(res, align(&map, &scan, guess, &bounded, None, cancel::NEVER).unwrap());
        // At least once per iteration (the index, built already, polls no more).
        assert!(polls.get() >= 17, "{} polls", polls.get());
    }
}

#[test]
fn an_interrupted_index_build_is_not_kept() {
    let map = PointMap::new(rooms(), None).unwrap();
    let scan = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
    let out = align(&map, &scan, Pose2::new(5.0, 2.5, 0.0), &IcpConfig::default(), None, &|| true);
    assert_eq!(out, Err(IcpError::Interrupted));
    assert!(map.built_wall_index().is_none());
    assert!(map.wall_index(cancel::NEVER).is_ok() && map.built_wall_index().is_some());
}

#[test]
fn budget_exhaustion_is_not_convergence() {
    let map = PointMap::new(rooms(), None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let truth = Pose2::new(5.0, 2.5, 0.0);
    let scan = scan_from(&map, truth, &mut rng, 0.01);
    let cfg = IcpConfig { max_iterations: 1, ..IcpConfig::default() };
    let res = align(&map, &scan, Pose2::new(5.2, 2.4, 0.05), &cfg, None, cancel::NEVER).unwrap();
    assert_eq!(res.iterations, 1);
    assert!(!res.converged);
}

#[test]
fn outliers_beyond_max_distance_are_ignored() {
    let map = PointMap::new(rooms(), None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let truth = Pose2::new(6.0, 1.5, 0.1);
    let mut scan = scan_from(&map, truth, &mut rng, 0.005);
    let clean = scan.len();
    // A cabinet 0.5 m from the wall: not in the plan.
    for i in 0..150 {
        scan.push(truth.inverse().transform_point([4.0 + i as f64 * 0.01, 4.5]));
    }
    let res =
        align(&map, &scan, Pose2::new(6.1, 1.6, 0.12), &IcpConfig::default(), None, cancel::NEVER).unwrap();
    assert!((res.pose.x - truth.x).abs() < 0.01 && (res.pose.y - truth.y).abs() < 0.01, "{:?}", res.pose);
    assert!(res.inlier_mask[clean..].iter().all(|&m| !m), "cabinet points counted as inliers");
    assert!(res.num_inliers >= clean * 95 / 100);
}

#[test]
fn a_huge_correspondence_distance_finishes_and_matches_the_plain_search() {
    // Without outlier rejection (every pair counts) the candidate cache is skipped.
    let map = PointMap::new(rooms(), None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let truth = Pose2::new(5.0, 2.0, 0.1);
    let scan = scan_from(&map, truth, &mut rng, 0.005);
    let cfg = IcpConfig { max_correspondence_distance: 50.0, use_visibility: false, ..IcpConfig::default() };
    let res = align(&map, &scan, Pose2::new(5.05, 2.05, 0.12), &cfg, None, cancel::NEVER).unwrap();
    assert_eq!(res.num_inliers, scan.len());
    assert!((res.pose.x - truth.x).abs() < 0.02 && (res.pose.y - truth.y).abs() < 0.02, "{:?}", res.pose);
}

#[test]
fn the_result_yaw_is_wrapped_even_when_no_iteration_runs() {
    // Found by the core fuzz target `align`: an unwrapped initial yaw (-1e9 rad, set through
    // the public fields) came back as the result's yaw when the scan found no pairs.
    let map = PointMap::new(rooms(), None).unwrap();
    let initial = Pose2 { x: 1e6, y: 1e6, yaw: -1e9 };
    let res = align(
        &map,
        &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        initial,
        &IcpConfig::default(),
        None,
        cancel::NEVER,
    )
    .unwrap();
    assert_eq!(res.iterations, 0);
    assert!(res.pose.yaw > -std::f64::consts::PI && res.pose.yaw <= std::f64::consts::PI, "{:?}", res.pose);
    assert_eq!(res.pose.yaw, crate::pose::wrap_angle(-1e9));
}

#[test]
fn both_correspondence_searches_reach_the_same_pose() {
    let map = PointMap::new(rooms(), None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for (truth, guess) in [
        (Pose2::new(5.5, 2.2, 0.4), Pose2::new(5.7, 2.05, 0.45)),
        (Pose2::new(1.5, 2.5, -2.0), Pose2::new(1.4, 2.6, -2.05)),
        (Pose2::new(6.7, 3.9, 2.9), Pose2::new(6.6, 4.0, 2.95)),
    ] {
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let fast = align(&map, &scan, guess, &IcpConfig::default(), None, cancel::NEVER).unwrap();
        let kd = IcpConfig { search: CorrespondenceSearch::KdTree, ..IcpConfig::default() };
        let exact = align(&map, &scan, guess, &kd, None, cancel::NEVER).unwrap();
        for res in [&fast, &exact] {
            assert!((res.pose.x - truth.x).hypot(res.pose.y - truth.y) < 0.005, "{:?}", res.pose);
        }
        assert!((fast.pose.x - exact.pose.x).hypot(fast.pose.y - exact.pose.y) < 0.002);
        assert!((fast.inlier_ratio - exact.inlier_ratio).abs() < 0.01);
        // The index matches against the whole plan, the KD-tree against the visible subset.
        assert_eq!(fast.num_target_points, map.len());
        assert!(exact.num_target_points < map.len());
    }
}

#[test]
fn a_given_visible_set_is_the_one_matched_against() {
    let map = PointMap::new(rooms(), None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let (truth, guess) = (Pose2::new(5.5, 2.2, 0.4), Pose2::new(5.6, 2.1, 0.42));
    let scan = scan_from(&map, truth, &mut rng, 0.01);
    let kd = IcpConfig { search: CorrespondenceSearch::KdTree, ..IcpConfig::default() };
    // The set the alignment would cast itself: the same result, bit for bit.
    let cast = map.visible_from(guess, visibility_range(&scan, &kd)).unwrap();
    assert_eq!(
        align(&map, &scan, guess, &kd, Some(&cast), cancel::NEVER).unwrap(),
        align(&map, &scan, guess, &kd, None, cancel::NEVER).unwrap()
    );
    // Only the right room's walls (x > 3.1): the scan points on the left room's walls (more
    // than the largest pair distance, 0.25 m, from them) find nothing to pair with.
    let right: Vec<u32> = cast.iter().copied().filter(|&i| map.points()[i as usize][0] > 3.1).collect();
    let seen = align(&map, &scan, guess, &kd, Some(&right), cancel::NEVER).unwrap();
    assert_eq!(seen.num_target_points, right.len());
    let left = scan.iter().filter(|p| truth.transform_point(**p)[0] < 2.8).count();
    assert!(
        left > 20 && seen.num_inliers <= scan.len() - left,
        "{} inliers, {left} on the left",
        seen.num_inliers
    );
    // An index that is not a plan point is refused.
    let bad = [0, map.len() as u32];
    assert!(matches!(
        align(&map, &scan, guess, &kd, Some(&bad), cancel::NEVER),
        Err(IcpError::InvalidParameter { .. })
    ));
}

#[test]
fn rejects_bad_input() {
    let map = PointMap::new(rooms(), None).unwrap();
    let cfg = IcpConfig::default();
    let p = Pose2::new(1.0, 1.0, 0.0);
    assert_eq!(align(&map, &[], p, &cfg, None, cancel::NEVER).unwrap_err(), IcpError::Empty { what: "scan" });
    assert!(matches!(
        align(&map, &[[0.0, 0.0], [1.0, f64::INFINITY]], p, &cfg, None, cancel::NEVER),
        Err(IcpError::NonFinite { row: 1, .. })
    ));
    assert!(matches!(
        align(&map, &[[0.0, 0.0], [1.0, 0.0]], p, &cfg, None, cancel::NEVER),
        Err(IcpError::TooFewPoints { .. })
    ));
    for bad in [
        IcpConfig { max_correspondence_distance: 0.0, ..cfg.clone() },
        IcpConfig { max_correspondence_distance: f64::NAN, ..cfg.clone() },
        IcpConfig { max_iterations: 0, ..cfg.clone() },
        IcpConfig { trim_ratio: 0.0, ..cfg.clone() },
        IcpConfig { trim_ratio: 1.5, ..cfg.clone() },
        IcpConfig { translation_tolerance: -1.0, ..cfg.clone() },
        IcpConfig { subsample: 0, ..cfg.clone() },
        IcpConfig { correspondence_schedule: vec![], ..cfg.clone() },
        IcpConfig { correspondence_schedule: vec![1.0, -0.5], ..cfg.clone() },
        IcpConfig { visibility_range: Some(0.0), ..cfg.clone() },
    ] {
        assert!(
            matches!(
                align(&map, &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], p, &bad, None, cancel::NEVER),
                Err(IcpError::InvalidParameter { .. })
            ),
            "{bad:?}"
        );
    }
}
