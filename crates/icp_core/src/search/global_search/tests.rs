//! Tests of the global search, and the floors and scans that the relocalization tests share.

use super::*;
use crate::cancel;
use crate::error::IcpError;
use crate::pose::wrap_angle;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Points every 5 cm along the segment `a`-`b`.
pub(crate) fn segment(pts: &mut Vec<[f64; 2]>, a: [f64; 2], b: [f64; 2]) {
    let len = (b[0] - a[0]).hypot(b[1] - a[1]);
    let n = (len / 0.05).round().max(1.0) as usize;
    for i in 0..=n {
        let t = i as f64 / n as f64;
        pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
    }
}

/// An asymmetric floor: a 12 x 8 m hall, an inner wall with a door, a pillar and a diagonal.
pub(crate) fn asymmetric_floor() -> Vec<[f64; 2]> {
    let mut p = Vec::new();
    for (a, b) in [
        ([0.0, 0.0], [12.0, 0.0]),
        ([12.0, 0.0], [12.0, 8.0]),
        ([12.0, 8.0], [0.0, 8.0]),
        ([0.0, 8.0], [0.0, 0.0]),
        ([5.0, 0.0], [5.0, 3.0]),
        ([5.0, 4.2], [5.0, 8.0]),
        ([8.0, 5.0], [8.6, 5.0]),
        ([8.6, 5.0], [8.6, 5.6]),
        ([8.6, 5.6], [8.0, 5.6]),
        ([8.0, 5.6], [8.0, 5.0]),
        ([0.0, 6.0], [2.0, 8.0]),
        ([9.0, 0.0], [9.0, 2.0]),
    ] {
        segment(&mut p, a, b);
    }
    p
}

/// A 360-degree scan of `n` beams from `pose` (robot frame), ray cast against the segments of
/// the plan points' visibility: the visible plan points, resampled to beam directions.
pub(crate) fn scan_from(map: &PointMap, pose: Pose2, rng: &mut ChaCha8Rng, noise: f64) -> Vec<[f64; 2]> {
    let inv = pose.inverse();
    map.visible_from(pose, 30.0)
        .unwrap()
        .iter()
        .map(|&i| {
            let p = inv.transform_point(map.points()[i as usize]);
            [p[0] + rng.random_range(-noise..=noise), p[1] + rng.random_range(-noise..=noise)]
        })
        .collect()
}

fn close(a: &Pose2, b: &Pose2, metres: f64, radians: f64) -> bool {
    (a.x - b.x).hypot(a.y - b.y) < metres && wrap_angle(a.yaw - b.yaw).abs() < radians
}

#[test]
fn a_window_larger_than_the_plan_searches_the_plan() {
    // A 10 km window around a 12 x 8 m plan: clipped to the plan it scores the roots of the
    // whole plan's search, not 10^9 of them (which aborted the process allocating 10 GB).
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let truth = Pose2::new(2.5, 2.0, 0.7);
    let scan = scan_from(&map, truth, &mut rng, 0.01);
    let huge = SearchWindow::new(Pose2::new(6.0, 4.0, 0.0), 1e4, PI);
    let clipped = matcher.search(&scan, Some(&huge), cancel::NEVER).unwrap();
    let whole = matcher.search(&scan, None, cancel::NEVER).unwrap();
    assert_eq!(clipped.nodes, whole.nodes);
    assert!(close(&clipped.candidates[0].pose, &truth, 0.3, 0.1), "{:?}", clipped.candidates[0]);
    // Wholly outside the plan: searched where it is (nothing to find), no error.
    let away = SearchWindow::new(Pose2::new(500.0, 4.0, 0.0), 2.0, 0.1);
    assert!(matcher.search(&scan, Some(&away), cancel::NEVER).is_ok());
}

#[test]
fn a_window_across_the_plans_edge_keeps_its_own_lattice() {
    // A window around a pose 0.33 m inside the wall at x = 0 reaches 0.67 m past the plan: it is
    // searched on the lattice centred on its centre, as the same window well inside the plan
    // would be, not clipped to the plan and re-centred (which shifted its lattice by half a
    // cell and changed what a recovery near the edge found).
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let res = GlobalSearchConfig::default().resolution;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let truth = Pose2::new(0.33 + 0.37 * res, 3.0 + 0.21 * res, 0.4);
    let scan = scan_from(&map, truth, &mut rng, 0.01);
    let centre = Pose2::new(0.33, 3.0, 0.4);
    let window = SearchWindow::new(centre, 1.0, 0.2);
    let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
    assert!(out.complete && !out.candidates.is_empty());
    for c in &out.candidates {
        for (v, c0) in [(c.pose.x, centre.x), (c.pose.y, centre.y)] {
            let k = (v - c0) / res;
            assert!((k - k.round()).abs() < 1e-6, "{c:?} is off the window's lattice ({k} cells)");
        }
    }
    assert!(close(&out.candidates[0].pose, &truth, res, 0.05), "{:?}", out.candidates[0]);
}

#[test]
fn a_window_with_a_lever_searches_the_ring_its_heading_error_turns_it_to() {
    // A robot lost at (2, 2) heading 0 drove 4 m ahead by its odometry, but its heading was 1.2
    // rad off: it is at (2, 2) + R(1.2) (4, 0). The window with that lever finds it there, at
    // heading 1.2, with squares of 0.5 m: every candidate lies within its heading's square.
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let (turn, lever) = (1.2f64, [4.0, 0.0]);
    let truth = Pose2::new(2.0 + 4.0 * turn.cos(), 2.0 + 4.0 * turn.sin(), turn);
    let scan = scan_from(&map, truth, &mut rng, 0.01);
    let window = SearchWindow { center: Pose2::new(2.0, 2.0, 0.0), half_width: 0.5, half_angle: PI, lever };
    let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
    assert!(out.complete && !out.candidates.is_empty());
    assert!(close(&out.candidates[0].pose, &truth, 0.15, 0.05), "{:?}", out.candidates[0]);
    let res = GlobalSearchConfig::default().resolution;
    for c in &out.candidates {
        let [cx, cy] = window.center_at(c.pose.yaw);
        assert!(
            (c.pose.x - cx).abs() <= 0.5 + res && (c.pose.y - cy).abs() <= 0.5 + res,
            "{c:?} off its square"
        );
    }
    // Without the lever the same squares are searched around (2, 2): the robot is not there.
    let no_lever = SearchWindow::new(Pose2::new(2.0, 2.0, 0.0), 0.5, PI);
    let out = matcher.search(&scan, Some(&no_lever), cancel::NEVER).unwrap();
    assert!(out.candidates.iter().all(|c| !close(&c.pose, &truth, 0.5, 0.2)), "{:?}", out.candidates);
    // A lever that is not finite is refused with its name.
    let bad = SearchWindow { lever: [f64::NAN, 0.0], ..window };
    let err = matcher.search(&scan, Some(&bad), cancel::NEVER).unwrap_err();
    assert!(err.to_string().contains("lever"), "{err}");
}

#[test]
fn a_search_with_more_roots_than_max_nodes_ends_at_max_nodes() {
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let config = GlobalSearchConfig { max_nodes: 100, ..GlobalSearchConfig::default() };
    let matcher = GlobalMatcher::new(&map, config).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let scan = scan_from(&map, Pose2::new(2.5, 2.0, 0.7), &mut rng, 0.01);
    let out = matcher.search(&scan, None, cancel::NEVER).unwrap();
    assert!(!out.complete && out.nodes == 100, "{out:?}");
}

#[test]
fn finds_the_pose_from_no_guess() {
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for truth in [Pose2::new(2.5, 2.0, 0.7), Pose2::new(9.5, 6.5, -2.4), Pose2::new(7.0, 3.0, 3.0)] {
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let out = matcher.search(&scan, None, cancel::NEVER).unwrap();
        assert!(out.complete);
        let best = out.candidates[0];
        assert!(close(&best.pose, &truth, 0.15, 0.04), "{truth:?}: best {best:?}");
        assert!(best.score > 0.8, "{best:?}");
        assert!(out.candidates.windows(2).all(|w| w[0].score >= w[1].score));
    }
}

#[test]
fn branch_and_bound_equals_exhaustive_search() {
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let cfg = GlobalSearchConfig { max_candidates: 1, ..GlobalSearchConfig::default() };
    let matcher = GlobalMatcher::new(&map, cfg).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let truth = Pose2::new(3.0, 5.0, 0.2);
    let scan = scan_from(&map, truth, &mut rng, 0.01);
    let window = SearchWindow::new(Pose2::new(3.3, 4.8, 0.25), 0.6, 0.1);
    let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
    let best = out.candidates[0];
    // Exhaustive: every lattice translation at every swept rotation.
    let points = matcher.thin_scan(&scan).unwrap();
    let (m, step) = ((0.1 / out.angular_step).ceil() as i64, 0.1 / (0.1 / out.angular_step).ceil());
    let mut top = 0.0f64;
    for k in -m..=m {
        for ix in -6..=6 {
            for iy in -6..=6 {
                let pose = Pose2::new(3.3 + ix as f64 * 0.1, 4.8 + iy as f64 * 0.1, 0.25 + k as f64 * step);
                let s: u32 = points
                    .iter()
                    .map(|p| {
                        let q = Pose2::new(3.3, 4.8, pose.yaw).transform_point(*p);
                        let c = matcher.pyramid.cell_of(q);
                        matcher.pyramid.get(0, c[0] + ix, c[1] + iy) as u32
                    })
                    .sum();
                top = top.max((s as f32 / (255.0 * points.len() as f32)) as f64);
            }
        }
    }
    assert!((best.score - top).abs() < 1e-5, "bnb {} vs exhaustive {top}", best.score);
}

#[test]
fn a_symmetric_room_gives_several_candidates() {
    let mut pts = Vec::new();
    for (a, b) in [([0.0, 0.0], [10.0, 0.0]), ([10.0, 0.0], [10.0, 6.0]), ([10.0, 6.0], [0.0, 6.0])] {
        segment(&mut pts, a, b);
    }
    segment(&mut pts, [0.0, 6.0], [0.0, 0.0]);
    let map = PointMap::new(pts, None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let truth = Pose2::new(3.0, 2.0, 0.4);
    let scan = scan_from(&map, truth, &mut rng, 0.005);
    let out = matcher.search(&scan, None, cancel::NEVER).unwrap();
    assert!(out.candidates.len() >= 2, "{:?}", out.candidates);
    let mirrored = Pose2::new(7.0, 4.0, 0.4 + PI);
    let (a, b) = (out.candidates[0], out.candidates[1]);
    assert!(
        (close(&a.pose, &truth, 0.15, 0.04) && close(&b.pose, &mirrored, 0.15, 0.04))
            || (close(&b.pose, &truth, 0.15, 0.04) && close(&a.pose, &mirrored, 0.15, 0.04)),
        "{a:?} {b:?}"
    );
    assert!((a.score - b.score).abs() < 0.05, "{a:?} {b:?}");
}

#[test]
fn a_window_restricts_the_search() {
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let truth = Pose2::new(10.0, 3.5, 1.0);
    let scan = scan_from(&map, truth, &mut rng, 0.01);
    let window = SearchWindow::new(Pose2::new(10.4, 3.2, 1.2), 1.0, 0.4);
    let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
    let full = matcher.search(&scan, None, cancel::NEVER).unwrap();
    assert!(out.nodes < full.nodes / 5, "window {} vs whole plan {} nodes", out.nodes, full.nodes);
    assert!(close(&out.candidates[0].pose, &truth, 0.15, 0.04), "{:?}", out.candidates[0]);
    for c in &out.candidates {
        assert!((c.pose.x - 10.4).abs() <= 1.05 && (c.pose.y - 3.2).abs() <= 1.05, "{c:?}");
        assert!(wrap_angle(c.pose.yaw - 1.2).abs() <= 0.4 + 1e-9, "{c:?}");
    }
    // A window that excludes the truth finds nothing as good.
    let away = SearchWindow::new(Pose2::new(2.0, 2.0, -2.0), 0.5, 0.1);
    let out = matcher.search(&scan, Some(&away), cancel::NEVER).unwrap();
    assert!(out.candidates.iter().all(|c| c.score < full.candidates[0].score - 0.2));
}

#[test]
fn a_run_advanced_in_small_budgets_finds_what_one_search_finds() {
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let scan = scan_from(&map, Pose2::new(3.2, 5.4, 0.7), &mut rng, 0.01);
    let whole = matcher.search(&scan, None, cancel::NEVER).unwrap();
    let mut run = matcher.start(&scan, None).unwrap();
    let mut calls = 0;
    let mut before = 0;
    while !run.advance(&matcher, 500, cancel::NEVER).unwrap() {
        calls += 1;
        // An expansion scores up to four children: a call ends at most three past its budget.
        assert!((500..=503).contains(&(run.nodes() - before)), "{} nodes in one call", run.nodes() - before);
        before = run.nodes();
    }
    assert!(
        run.finished() && calls as u64 >= whole.nodes / 500 - 1,
        "{calls} calls for {} nodes",
        whole.nodes
    );
    assert_eq!(run.outcome(), whole);
    // A finished run stays finished and scores nothing more.
    assert!(run.advance(&matcher, 500, cancel::NEVER).unwrap());
    assert_eq!(run.nodes(), whole.nodes);
}

/// A matcher of the asymmetric floor, a scan of it and the outcome of its whole search, which
/// scores more than four polls' worth of nodes (so that a run can be stopped and resumed).
fn a_search_of_several_polls() -> (GlobalMatcher, Vec<[f64; 2]>, SearchOutcome) {
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let scan = scan_from(&map, Pose2::new(3.2, 5.4, 0.7), &mut rng, 0.01);
    let whole = matcher.search(&scan, None, cancel::NEVER).unwrap();
    assert!(whole.nodes > 4 * NODES_PER_POLL, "{} nodes: too few to stop a run", whole.nodes);
    (matcher, scan, whole)
}

#[test]
fn an_interrupted_run_stops_between_nodes_and_resumes_to_the_same_result() {
    let (matcher, scan, whole) = a_search_of_several_polls();
    // Stop at the third poll: after 3 * NODES_PER_POLL nodes (up to three more), not later.
    let polls = std::cell::Cell::new(0u32);
    let third = || {
        polls.set(polls.get() + 1);
        polls.get() >= 3
    };
    let mut run = matcher.start(&scan, None).unwrap();
    assert_eq!(run.advance(&matcher, u64::MAX, &third), Err(IcpError::Interrupted));
    assert_eq!(polls.get(), 3);
    assert!(!run.finished() && (3 * NODES_PER_POLL..3 * NODES_PER_POLL + 4).contains(&run.nodes()));
    assert!(run.advance(&matcher, u64::MAX, cancel::NEVER).unwrap());
    assert_eq!(run.outcome(), whole);
    assert_eq!(matcher.search(&scan, None, &|| true).unwrap_err(), IcpError::Interrupted);
}

#[test]
fn the_node_budget_makes_the_search_incomplete() {
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    // 19 headings of one coarsest cell each: room for the roots, not for expanding them.
    let cfg = GlobalSearchConfig { max_nodes: 25, ..GlobalSearchConfig::default() };
    let matcher = GlobalMatcher::new(&map, cfg).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(15);
    let scan = scan_from(&map, Pose2::new(2.5, 2.0, 0.7), &mut rng, 0.01);
    let window = SearchWindow::new(Pose2::new(2.5, 2.0, 0.7), 1.0, 0.3);
    let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
    assert!(!out.complete && out.nodes <= 25 + 3, "{out:?}");
}

#[test]
fn rejects_bad_input() {
    let map = PointMap::new(asymmetric_floor(), None).unwrap();
    let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
    let good: Vec<[f64; 2]> =
        (0..50).map(|i| [(i as f64 * 0.3).cos() * 3.0, (i as f64 * 0.3).sin()]).collect();
    assert_eq!(matcher.search(&[], None, cancel::NEVER).unwrap_err(), IcpError::Empty { what: "scan" });
    let mut nan = good.clone();
    nan[7][1] = f64::NAN;
    assert_eq!(
        matcher.search(&nan, None, cancel::NEVER).unwrap_err(),
        IcpError::NonFinite { what: "scan", row: 7 }
    );
    assert!(matches!(
        matcher.search(&[[1.0, 0.0], [1.0, 0.01], [0.0, 2.0]], None, cancel::NEVER),
        Err(IcpError::TooFewPoints { need: MIN_SEARCH_POINTS, .. })
    ));
    for w in [
        SearchWindow::new(Pose2::new(f64::NAN, 0.0, 0.0), 1.0, 0.1),
        SearchWindow::new(Pose2::new(1.0, 1.0, 0.0), -1.0, 0.1),
        SearchWindow::new(Pose2::new(1.0, 1.0, 0.0), 1.0, f64::INFINITY),
    ] {
        assert!(
            matches!(matcher.search(&good, Some(&w), cancel::NEVER), Err(IcpError::InvalidParameter { .. })),
            "{w:?}"
        );
    }
    let cfg = GlobalSearchConfig::default();
    for bad in [
        GlobalSearchConfig { resolution: 0.0, ..cfg.clone() },
        GlobalSearchConfig { sigma: f64::NAN, ..cfg.clone() },
        GlobalSearchConfig { levels: 0, ..cfg.clone() },
        GlobalSearchConfig { levels: 13, ..cfg.clone() },
        GlobalSearchConfig { angular_step: Some(-0.1), ..cfg.clone() },
        GlobalSearchConfig { max_candidates: 0, ..cfg.clone() },
        GlobalSearchConfig { min_score: 1.0, ..cfg.clone() },
        GlobalSearchConfig { relative_score: 1.5, ..cfg.clone() },
        GlobalSearchConfig { nms_distance: 0.0, ..cfg.clone() },
        GlobalSearchConfig { max_scan_points: 3, ..cfg.clone() },
        GlobalSearchConfig { max_nodes: 0, ..cfg.clone() },
    ] {
        assert!(
            matches!(GlobalMatcher::new(&map, bad.clone()), Err(IcpError::InvalidParameter { .. })),
            "{bad:?}"
        );
    }
    let tiny = GlobalSearchConfig { angular_step: Some(1e-6), ..cfg };
    let m = GlobalMatcher::new(&map, tiny).unwrap();
    assert!(matches!(
        m.search(&good, None, cancel::NEVER),
        Err(IcpError::InvalidParameter { name: "angular_step", .. })
    ));
}

#[test]
fn a_run_out_of_time_stops_at_a_poll_and_resumes_to_the_same_result() {
    let (matcher, scan, whole) = a_search_of_several_polls();
    // A time already past: each call scores up to its first poll (NODES_PER_POLL nodes, up to
    // three more) and stops there, unfinished, however large its node budget.
    let mut run = matcher.start(&scan, None).unwrap();
    let mut calls = 0u64;
    let mut before = 0;
    while !run.advance_until(&matcher, u64::MAX, Some(std::time::Instant::now()), cancel::NEVER).unwrap() {
        calls += 1;
        assert!(
            (NODES_PER_POLL..NODES_PER_POLL + 4).contains(&(run.nodes() - before)),
            "{}",
            run.nodes() - before
        );
        before = run.nodes();
    }
    assert!(calls >= whole.nodes / (NODES_PER_POLL + 3), "{calls} calls for {} nodes", whole.nodes);
    assert_eq!(run.outcome(), whole);
    // Time to spare: the node budget stops it, as `advance` does.
    let mut run = matcher.start(&scan, None).unwrap();
    let later = std::time::Instant::now() + std::time::Duration::from_secs(3600);
    assert!(!run.advance_until(&matcher, 500, Some(later), cancel::NEVER).unwrap());
    assert!((500..=503).contains(&run.nodes()));
}
