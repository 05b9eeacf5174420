//! Tests of the wall view: ranges to the first walls, the visible points, doorways, the scan's arc, and the classification of returns.

use super::*;
use crate::visibility::visible_points::{visible_points, BASE_RAYS};

/// A 4 x 4 m room with 0.2 m walls, points every 5 cm on both faces, and a 1 m doorway in the
/// east wall (x = 4) at y in [1.5, 2.5].
fn room() -> (Vec<[f64; 2]>, WallRaster) {
    let mut pts = Vec::new();
    for i in 0..=80 {
        let t = i as f64 * 0.05;
        pts.extend([[t, 0.0], [t, 4.0], [0.0, t]]);
        if !(1.5..=2.5).contains(&t) {
            pts.push([4.0, t]);
        }
    }
    for i in 0..=88 {
        let t = -0.2 + i as f64 * 0.05;
        pts.extend([[t, -0.2], [t, 4.2], [-0.2, t]]);
        if !(1.3..=2.7).contains(&t) {
            pts.push([4.2, t]);
        }
    }
    let raster = WallRaster::new(&pts, 0.075).unwrap();
    (pts, raster)
}

#[test]
fn ranges_are_the_distances_to_the_first_walls() {
    let (pts, raster) = room();
    // Facing +y from (1, 1.2): direction j looks along base angle -pi + j * 2 pi / 16.
    let view = WallView::cast(&raster, &pts, Pose2::new(1.0, 1.2, PI / 2.0), 10.0, 16, None, true).unwrap();
    assert_eq!(view.ranges.len(), 16);
    let cell = 0.075;
    // Base angle 0 (j = 8) is map +y: the north wall at y = 4, 2.8 m away.
    assert!((view.ranges[8] - 2.8).abs() <= cell, "{}", view.ranges[8]);
    // Base angle -pi/2 (j = 4) is map +x: the east wall at x = 4, 3 m away.
    assert!((view.ranges[4] - 3.0).abs() <= cell, "{}", view.ranges[4]);
    // Base angle pi/2 (j = 12) is map -x: the west wall at x = 0, 1 m away.
    assert!((view.ranges[12] - 1.0).abs() <= cell, "{}", view.ranges[12]);
    // Backwards (j = 0) is map -y: the south wall at y = 0.
    assert!((view.ranges[0] - 1.2).abs() <= cell, "{}", view.ranges[0]);
    assert!(!view.visible.is_empty());
}

/// Points that are not the raster's (none here) leave a ray's stop cell empty: the range is then
/// the stop cell's centre, projected on the ray, still within a cell of the wall.
#[test]
fn without_the_rasters_points_a_range_is_the_stop_cells_centre() {
    let (pts, raster) = room();
    let pose = Pose2::new(1.0, 1.2, PI / 2.0);
    let exact = WallView::cast(&raster, &pts, pose, 10.0, 16, None, true).unwrap();
    let centres = WallView::cast(&raster, &[], pose, 10.0, 16, None, true).unwrap();
    let cell = 0.075;
    let mut differ = 0;
    for (j, (a, b)) in exact.ranges.iter().zip(&centres.ranges).enumerate() {
        if a.is_finite() {
            assert!((a - b).abs() <= cell, "direction {j}: {a} against the centre's {b}");
            differ += usize::from(a != b);
        } else {
            assert_eq!(a, b, "direction {j}");
        }
    }
    // With the points, the ranges are the walls' own (a wall point can lie at a centre's
    // projection, so not every direction differs).
    assert!(differ >= 10, "{differ} of 16 directions differ");
    assert!((centres.ranges[12] - 1.0).abs() <= cell, "{}", centres.ranges[12]);
}

#[test]
fn the_visible_points_are_the_visibility_casts() {
    let (pts, raster) = room();
    // Facing pi, the first direction is map angle 0, as the visibility cast's first ray.
    let pose = Pose2 { x: 2.3, y: 1.7, yaw: PI };
    let view = WallView::cast(&raster, &pts, pose, 8.0, 2 * BASE_RAYS, None, true).unwrap();
    let seen = visible_points(&raster, [2.3, 1.7], 8.0).unwrap();
    assert_eq!(view.visible, seen);
}

#[test]
fn a_doorway_reads_inf_within_range_and_returns_are_classified() {
    let (pts, raster) = room();
    // At (2, 2) facing +x: base angle 0 (direction 360 of 720) looks through the doorway.
    let view = WallView::cast(&raster, &pts, Pose2::new(2.0, 2.0, 0.0), 3.0, 720, None, true).unwrap();
    assert_eq!(view.ranges[360], f64::INFINITY);
    let ahead_left = view.ranges[540]; // base angle pi/2: the north wall, 2 m
    assert!((ahead_left - 2.0).abs() <= 0.075, "{ahead_left}");
    let margin = 0.2;
    let classes = view.classify(
        &[
            [0.0, 2.0],  // on the north wall
            [0.0, 1.0],  // a person 1 m short of it
            [0.0, 2.5],  // 0.5 m beyond it: through the wall
            [1.0, 0.0],  // through the doorway, where the plan shows nothing in range
            [-2.0, 0.0], // on the west wall
        ],
        margin,
    );
    assert_eq!(classes.in_front, vec![false, true, false, true, false]);
    assert_eq!(classes.beyond, vec![false, false, true, false, false]);
}

#[test]
fn halfway_ranges_match_casting_every_direction() {
    let (pts, raster) = room();
    for (x, y, yaw) in [(1.0, 1.2, 0.3), (2.0, 2.0, 0.0), (3.7, 0.4, -2.0), (6.0, 2.0, 1.0)] {
        let pose = Pose2::new(x, y, yaw);
        // 1441 directions: every one a base ray. 1440: every other one, the rest halfway.
        let exact = WallView::cast(&raster, &pts, pose, 12.0, 1441, None, true).unwrap();
        let halved = WallView::cast(&raster, &pts, pose, 12.0, 1440, None, true).unwrap();
        assert_eq!((exact.ranges.len(), halved.ranges.len()), (1441, 1440));
        let reference = WallView::cast(&raster, &pts, pose, 12.0, 2881, None, true).unwrap();
        // Direction j of 1440 is direction 2j of 2880; the 2881-direction cast is within
        // 1/2881 of a turn of it, compare with the nearer of its neighbours.
        for (j, r) in halved.ranges.iter().enumerate() {
            let near = [reference.ranges[(2 * j) % 2881], reference.ranges[(2 * j + 1) % 2881]];
            let off =
                near.iter().map(|e| if e.is_infinite() && r.is_infinite() { 0.0 } else { (e - r).abs() });
            assert!(off.fold(f64::INFINITY, f64::min) <= 0.11, "{pose:?} direction {j}: {r} vs {near:?}");
        }
    }
}

#[test]
fn bearings_agree_with_atan2() {
    let mut worst = 0.0f64;
    for i in 0..200_000 {
        let angle = -PI + TAU * i as f64 / 200_000.0;
        for r in [1e-3, 1.0, 37.0] {
            let (y, x) = (r * angle.sin(), r * angle.cos());
            worst = worst.max((bearing(y, x) - y.atan2(x)).abs());
        }
    }
    assert!(worst < 1e-7, "{worst}");
    for (y, x) in [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (2.0, 2.0), (-3.0, -3.0)] {
        assert!((bearing(y, x) - f64::atan2(y, x)).abs() < 1e-7, "({y}, {x})");
    }
    assert_eq!(bearing(0.0, 0.0), 0.0);
    assert!(bearing(f64::NAN, 1.0).is_nan());
}

#[test]
fn the_arc_is_the_scan_span_widened_by_the_margin() {
    let n = 1440;
    let at = |deg: f64| [deg.to_radians().cos(), deg.to_radians().sin()];
    // A 270-degree scan: directions 180 (-135 deg) to 1260 (+135 deg).
    let scan: Vec<[f64; 2]> = (0..1081).map(|i| at(-135.0 + 0.25 * i as f64)).collect();
    assert_eq!(spanned_arc(&scan, n, 40), Some((140, 1081 + 80)));
    // Across +-pi: returns between 170 and 190 degrees (directions 1400 to 1440 = 0 to 40).
    let back: Vec<[f64; 2]> = (0..=80).map(|i| at(170.0 + 0.25 * i as f64)).collect();
    assert_eq!(spanned_arc(&back, n, 10), Some((1390, 81 + 20)));
    // Nearly all round, an empty scan: the full circle.
    let round: Vec<[f64; 2]> = (0..1400).map(|i| at(-180.0 + 0.25 * i as f64)).collect();
    assert_eq!(spanned_arc(&round, n, 40), None);
    assert_eq!(spanned_arc(&[], n, 40), None);
    assert_eq!(spanned_arc(&[[1.0, 0.0]], n, 3), Some((717, 7)));
}

#[test]
fn a_view_over_the_scan_arc_classifies_as_the_full_circle() {
    let (pts, raster) = room();
    let pose = Pose2::new(1.3, 2.2, 0.7);
    let full = WallView::cast(&raster, &pts, pose, 10.0, 1440, None, true).unwrap();
    // A 180-degree scan ahead: returns at 0.5-5 m.
    let scan: Vec<[f64; 2]> = (0..721)
        .map(|i| {
            let a = (-90.0 + 0.25 * i as f64).to_radians();
            let r = 0.5 + 4.5 * ((i * 37) % 100) as f64 / 100.0;
            [r * a.cos(), r * a.sin()]
        })
        .collect();
    let arc = WallView::cast(
        &raster,
        &pts,
        pose,
        10.0,
        1440,
        Some(ViewScan { returns: &scan, pair_distance: None }),
        true,
    )
    .unwrap();
    assert_eq!(arc.ranges.len(), 1440);
    let cast = arc.ranges.iter().filter(|r| !r.is_nan()).count();
    assert!(cast < 1440 * 6 / 10, "{cast} directions cast for a half circle");
    for (a, f) in arc.ranges.iter().zip(&full.ranges) {
        assert!(a.is_nan() || a == f || (a - f).abs() < 1e-9, "{a} vs {f}");
    }
    assert_eq!(arc.classify(&scan, 0.2), full.classify(&scan, 0.2));
    // The points seen over the arc are points seen over the full circle, most of them.
    let in_full = arc.visible.iter().filter(|i| full.visible.binary_search(i).is_ok()).count();
    assert!(in_full as f64 >= 0.98 * arc.visible.len() as f64 && arc.visible.len() < full.visible.len());
}

#[test]
fn the_exact_classification_refuses_bad_directions() {
    let raster = OccupancyRaster::new(vec![false; 100], 10, 10, 0.1, [0.0, 0.0]).unwrap();
    let pose = Pose2::new(0.5, 0.5, 0.0);
    assert!(classify_exact(&raster, pose, &[[1.0, 0.0]], 0.2, 7).is_err());
    assert!(classify_exact(&raster, pose, &[[1.0, 0.0]], 0.2, MAX_DIRECTIONS + 1).is_err());
    // Nothing but free cells: every return is in front of "no wall" (inf), none beyond.
    let classes = classify_exact(&raster, pose, &[[1.0, 0.0], [0.0, -0.3]], 0.2, 720).unwrap();
    assert_eq!(classes, ReturnClasses { in_front: vec![true, true], beyond: vec![false, false] });
}

#[test]
fn bad_casts_are_refused() {
    let (pts, raster) = room();
    let ok = Pose2::new(1.0, 1.0, 0.0);
    assert!(WallView::cast(&raster, &pts, ok, 0.0, 16, None, true).is_err());
    assert!(WallView::cast(&raster, &pts, ok, f64::NAN, 16, None, true).is_err());
    assert!(WallView::cast(&raster, &pts, ok, 5.0, 7, None, true).is_err());
    assert!(WallView::cast(&raster, &pts, ok, 5.0, MAX_DIRECTIONS + 1, None, true).is_err());
    assert!(
        WallView::cast(&raster, &pts, Pose2 { x: f64::NAN, y: 1.0, yaw: 0.0 }, 5.0, 16, None, true).is_err()
    );
    assert!(WallView::cast(&raster, &pts, Pose2 { x: 1.0, y: 1.0, yaw: f64::INFINITY }, 5.0, 16, None, true)
        .is_err());
}

/// The room with a wall 8 m beyond its doorway (x = 12, y in [-2, 6]), seen through it.
fn room_and_far_wall() -> (Vec<[f64; 2]>, WallRaster) {
    let (mut pts, _) = room();
    pts.extend((0..=160).map(|i| [12.0, -2.0 + 0.05 * i as f64]));
    let raster = WallRaster::new(&pts, 0.075).unwrap();
    (pts, raster)
}

#[test]
fn a_view_for_a_scan_reaches_only_as_far_as_its_returns_can_pair() {
    let (pts, raster) = room_and_far_wall();
    let pose = Pose2::new(1.0, 2.0, 0.0);
    let pair = 0.5;
    // Returns on the room's walls ahead and to the sides (base frame = map frame shifted by the
    // pose), none through the doorway.
    let mut scan: Vec<[f64; 2]> = Vec::new();
    for i in 0..=40 {
        let y = 0.1 * i as f64;
        if !(1.4..=2.6).contains(&y) {
            scan.push([3.0, y - 2.0]);
        }
    }
    scan.extend((0..=30).map(|i| [0.1 * i as f64, -2.0]));
    scan.extend((0..=30).map(|i| [0.1 * i as f64, 2.0]));
    let cast = |scan: &[[f64; 2]], pair_distance| {
        WallView::cast(
            &raster,
            &pts,
            pose,
            15.0,
            1440,
            Some(ViewScan { returns: scan, pair_distance }),
            false,
        )
        .unwrap()
    };
    let far = |view: &WallView| view.visible.iter().filter(|&&i| pts[i as usize][0] > 11.0).count();
    let full = cast(&scan, None);
    let reached = cast(&scan, Some(pair));
    assert!(far(&full) > 10, "the far wall is seen through the doorway");
    assert_eq!(far(&reached), 0, "no return can pair with the far wall");
    // Every point the full cast sees within the pair distance of a return (at the pose) is seen.
    let near_a_return =
        |p: [f64; 2]| scan.iter().any(|q| (q[0] + pose.x - p[0]).hypot(q[1] + pose.y - p[1]) <= pair);
    for &i in &full.visible {
        if near_a_return(pts[i as usize]) {
            assert!(reached.visible.binary_search(&i).is_ok(), "point {:?} lost", pts[i as usize]);
        }
    }
    // A return on the far wall, through the doorway: the wall near it is seen, not all of it.
    scan.push([11.0, 0.0]);
    let through = cast(&scan, Some(pair));
    let seen: Vec<[f64; 2]> =
        through.visible.iter().map(|&i| pts[i as usize]).filter(|p| p[0] > 11.0).collect();
    assert!(!seen.is_empty() && seen.iter().all(|p| (p[1] - 2.0).abs() < 2.5), "{seen:?}");
    assert!(seen.len() <= far(&full));
}

#[test]
fn a_pair_distance_is_refused_for_a_cast_with_ranges_or_without_a_positive_value() {
    let (pts, raster) = room();
    let pose = Pose2::new(1.0, 2.0, 0.0);
    let scan = [[1.0, 0.0]];
    for (pair_distance, with_ranges) in [(0.5, true), (0.0, false), (f64::NAN, false), (-1.0, false)] {
        let view = ViewScan { returns: &scan, pair_distance: Some(pair_distance) };
        let err = WallView::cast(&raster, &pts, pose, 10.0, 1440, Some(view), with_ranges).unwrap_err();
        assert!(err.to_string().contains("pair_distance"), "{err}");
    }
}

#[test]
fn the_reach_per_direction_is_the_farthest_window_over_it() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for case in 0..20 {
        let pair = 0.25 + 0.5 * (case % 3) as f64;
        let scan: Vec<[f64; 2]> = (0..(1 + case * 15))
            .map(|_| {
                let (a, r) = (rng.random_range(-PI..PI), rng.random_range(0.1..40.0));
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        let pose = Pose2::new(1.0, -2.0, rng.random_range(-PI..PI));
        let got = directional_reach(&scan, pose, 30.0, pair);
        let n = REACH_BINS;
        let bin = TAU / n as f64;
        let mut want = vec![0.0f64; n];
        for p in &scan {
            let rho = p[0].hypot(p[1]);
            let far = (rho + pair).min(30.0);
            let half = if rho <= pair { PI } else { (pair / rho).asin() } + ARC_MARGIN;
            let centre = (bearing(p[1], p[0]) + PI) / bin;
            // Every bin of the window, going round: the plain loop the build replaces.
            let (lo, hi) = if half >= PI {
                (0, n as i64 - 1)
            } else {
                ((centre - half / bin).floor() as i64, (centre + half / bin).floor() as i64)
            };
            for j in lo..=hi {
                let k = j.rem_euclid(n as i64) as usize;
                want[k] = want[k].max(far);
            }
        }
        assert_eq!(got.reach, want, "case {case}");
        assert!((got.first_angle - (pose.yaw - PI)).abs() < 1e-12);
    }
}
