//! Tests of the simulated LIDAR: exact ranges in boxes and doorways, discs, sensors outside the raster, jumps across free space, validation, noise and dropouts.

use super::*;
use crate::error::IcpError;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

const RES: f64 = 0.05;

/// A box room: free inside [0, 4] x [0, 3] m, walls 0.25 m thick around it, a 1 m raster margin
/// outside. Returns the raster and the (row, col) of the cell at (x, y).
fn box_room(door: bool) -> OccupancyRaster {
    let origin = [-1.25, -1.25];
    let (cols, rows) = (((4.0 + 2.5) / RES) as usize, ((3.0 + 2.5) / RES) as usize);
    let mut cells = vec![false; rows * cols];
    for r in 0..rows {
        for c in 0..cols {
            let x = origin[0] + (c as f64 + 0.5) * RES;
            let y = origin[1] + (r as f64 + 0.5) * RES;
            let in_outer = (-0.25..4.25).contains(&x) && (-0.25..3.25).contains(&y);
            let in_inner = (0.0..4.0).contains(&x) && (0.0..3.0).contains(&y);
            // A doorway in the right wall at y in [1, 2].
            let in_door = door && x > 3.9 && (1.0..2.0).contains(&y);
            cells[r * cols + c] = in_outer && !in_inner && !in_door;
        }
    }
    OccupancyRaster::new(cells, rows, cols, RES, origin).unwrap()
}

fn model(angle_min: f64, angle_increment: f64, beams: usize) -> LidarModel {
    LidarModel { angle_min, angle_increment, beams, range_min: 0.05, range_max: 30.0 }
}

fn cast(raster: &OccupancyRaster, pose: Pose2, m: &LidarModel, discs: &[Disc]) -> Vec<f64> {
    let mut out = Vec::new();
    cast_ranges(raster, pose, m, discs, &mut out).unwrap();
    out
}

fn single(raster: &OccupancyRaster, x: f64, y: f64, angle: f64) -> f64 {
    cast(raster, Pose2 { x, y, yaw: angle }, &model(0.0, 0.0, 1), &[])[0]
}

#[test]
fn axis_aligned_beams_in_a_box() {
    let room = box_room(false);
    let (x, y) = (1.3, 1.1);
    assert!((single(&room, x, y, 0.0) - (4.0 - x)).abs() < 1e-9);
    assert!((single(&room, x, y, PI) - x).abs() < 1e-9);
    assert!((single(&room, x, y, FRAC_PI_2) - (3.0 - y)).abs() < 1e-9);
    assert!((single(&room, x, y, -FRAC_PI_2) - y).abs() < 1e-9);
    // Exactly along a grid line (y = 1.0 is a cell border): still the right wall.
    assert!((single(&room, 0.7, 1.0, 0.0) - 3.3).abs() < 1e-9);
}

#[test]
fn diagonal_and_oblique_beams_in_a_box() {
    let room = box_room(false);
    // From (1, 1) at 45 deg: hits the top wall y = 3 at x = 3, distance 2 sqrt 2.
    assert!((single(&room, 1.0, 1.0, FRAC_PI_4) - 2.0 * 2f64.sqrt()).abs() < 1e-9);
    // Exactly through the inner corner (4, 3) from (1, 0.75) is a grid-corner beam.
    let a = (2.25f64).atan2(3.0);
    let d = single(&room, 1.0, 0.75, a);
    assert!((d - 3.75).abs() < 1e-9, "{d}");
    // An oblique beam: from (0.5, 2.5) at -20 deg hits y = 0 or x = 4, whichever comes first.
    let (x, y, a) = (0.5, 2.5, -20f64.to_radians());
    let expected = ((4.0 - x) / a.cos()).min(y / -a.sin());
    assert!((single(&room, x, y, a) - expected).abs() < 1e-9);
}

#[test]
fn every_beam_of_a_scan_is_exact() {
    let room = box_room(false);
    let m = model(-PI, 2.0 * PI / 3600.0, 3600);
    let (x, y, yaw) = (1.37, 2.21, 0.4);
    let out = cast(&room, Pose2 { x, y, yaw }, &m, &[]);
    for (k, r) in out.iter().enumerate() {
        let a = yaw + m.angle_min + m.angle_increment * k as f64;
        let (s, c) = a.sin_cos();
        let tx = if c > 0.0 { (4.0 - x) / c } else { -x / c };
        let ty = if s > 0.0 { (3.0 - y) / s } else { -y / s };
        assert!((r - tx.min(ty)).abs() < 1e-9, "beam {k}: {r} vs {}", tx.min(ty));
    }
}

#[test]
fn a_beam_through_a_doorway_reads_inf() {
    let room = box_room(true);
    assert_eq!(single(&room, 1.0, 1.5, 0.0), f64::INFINITY);
    // Outside the door the raster ends after a metre of free margin: nothing to hit.
    assert!((single(&room, 1.0, 0.5, 0.0) - 3.0).abs() < 1e-9);
}

#[test]
fn range_limits() {
    let room = box_room(false);
    let mut m = model(0.0, 0.0, 1);
    m.range_max = 2.0;
    assert_eq!(cast(&room, Pose2 { x: 1.0, y: 1.0, yaw: 0.0 }, &m, &[])[0], f64::INFINITY);
    m.range_max = 3.0; // exactly the distance: still a return
    assert!((cast(&room, Pose2 { x: 1.0, y: 1.0, yaw: 0.0 }, &m, &[])[0] - 3.0).abs() < 1e-12);
    m.range_min = 0.5;
    assert_eq!(cast(&room, Pose2 { x: 3.7, y: 1.0, yaw: 0.0 }, &m, &[])[0], f64::NEG_INFINITY);
    // Inside a wall: 0, below any positive range_min.
    assert_eq!(cast(&room, Pose2 { x: -0.1, y: 1.0, yaw: 0.0 }, &m, &[])[0], f64::NEG_INFINITY);
    m.range_min = 0.0;
    assert_eq!(cast(&room, Pose2 { x: -0.1, y: 1.0, yaw: 0.0 }, &m, &[])[0], 0.0);
}

#[test]
fn discs_occlude() {
    let room = box_room(false);
    let disc = Disc { x: 2.5, y: 1.0, radius: 0.3 };
    let m = model(0.0, 0.0, 1);
    let pose = Pose2 { x: 1.0, y: 1.0, yaw: 0.0 };
    assert!((cast(&room, pose, &m, &[disc])[0] - 1.2).abs() < 1e-12);
    // Tangent-ish beam above the disc misses it.
    let above = Pose2 { x: 1.0, y: 1.31, yaw: 0.0 };
    assert!((cast(&room, above, &m, &[disc])[0] - 3.0).abs() < 1e-9);
    // A disc behind the sensor is not seen; a sensor inside a disc reads 0.
    let behind = Disc { x: 0.5, y: 1.0, radius: 0.2 };
    assert!((cast(&room, pose, &m, &[behind])[0] - 3.0).abs() < 1e-9);
    let around = Disc { x: 1.0, y: 1.0, radius: 0.2 };
    let mut m0 = m;
    m0.range_min = 0.0;
    assert_eq!(cast(&room, pose, &m0, &[around])[0], 0.0);
    // The nearest of several; a disc beyond the wall changes nothing.
    let far = Disc { x: 5.0, y: 1.0, radius: 0.5 };
    let near = Disc { x: 2.0, y: 1.0, radius: 0.1 };
    assert!((cast(&room, pose, &m, &[far, disc, near])[0] - 0.9).abs() < 1e-12);
}

#[test]
fn a_sensor_outside_the_raster_sees_the_outer_faces() {
    let room = box_room(false);
    // 2 m right of the outer face x = 4.25, looking back (-x): hits it 2 m away.
    let d = single(&room, 6.25, 1.5, PI);
    assert!((d - 2.0).abs() < 1e-9, "{d}");
    // Below the raster, looking up through the margin: the outer face y = -0.25.
    let d = single(&room, 2.0, -5.0, FRAC_PI_2);
    assert!((d - 4.75).abs() < 1e-9, "{d}");
    // Looking away, or past the raster, or with a short range: nothing.
    assert_eq!(single(&room, 6.25, 1.5, 0.0), f64::INFINITY);
    assert_eq!(single(&room, 6.25, 10.0, PI), f64::INFINITY);
    let m = LidarModel { range_max: 1.5, ..model(0.0, 0.0, 1) };
    assert_eq!(cast(&room, Pose2 { x: 6.25, y: 1.5, yaw: PI }, &m, &[])[0], f64::INFINITY);
    // Far away with a long range: terminates and hits.
    let m = LidarModel { range_max: 1e9, ..model(0.0, 0.0, 1) };
    let d = cast(&room, Pose2 { x: 1e8, y: 1.5, yaw: PI }, &m, &[])[0];
    assert!((d - (1e8 - 4.25)).abs() < 1e-5, "{d}");
}

#[test]
fn a_beam_into_the_raster_edge_and_a_wall_at_the_edge() {
    // A single occupied column at the raster's right edge, sensor outside at the left.
    let (rows, cols) = (4, 10);
    let mut cells = vec![false; rows * cols];
    for r in 0..rows {
        cells[r * cols + cols - 1] = true;
    }
    let raster = OccupancyRaster::new(cells, rows, cols, 1.0, [0.0, 0.0]).unwrap();
    assert!((single(&raster, -3.0, 1.5, 0.0) - 12.0).abs() < 1e-12);
    assert!((single(&raster, 0.5, 1.5, 0.0) - 8.5).abs() < 1e-12);
    assert!((single(&raster, 20.0, 1.5, PI) - 10.0).abs() < 1e-12);
    assert_eq!(raster.occupied_cells(), 4);
    assert!(raster.is_occupied(0, 9) && !raster.is_occupied(0, 8) && !raster.is_occupied(-1, 9));
}

#[test]
fn jumps_do_not_change_ranges() {
    // A large empty raster with scattered single occupied cells: compare against a walk
    // without jumps (clearance capped to 1).
    let (rows, cols) = (300, 400);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let cells: Vec<bool> = (0..rows * cols).map(|_| rng.random_bool(0.0005)).collect();
    let raster = OccupancyRaster::new(cells, rows, cols, 0.05, [-3.0, 2.0]).unwrap();
    let mut plain = raster.clone();
    for c in plain.clearance.iter_mut() {
        *c = (*c).min(1);
    }
    let m = LidarModel { range_max: 40.0, ..model(-PI, 2.0 * PI / 2000.0, 2000) };
    for _ in 0..20 {
        let pose = Pose2 {
            x: rng.random_range(-3.0..17.0),
            y: rng.random_range(2.0..17.0),
            yaw: rng.random_range(-PI..PI),
        };
        assert_eq!(cast(&raster, pose, &m, &[]), cast(&plain, pose, &m, &[]));
    }
}

#[test]
fn validation_errors() {
    let bad = |r: Result<OccupancyRaster>| assert!(matches!(r, Err(IcpError::InvalidParameter { .. })));
    bad(OccupancyRaster::new(vec![], 0, 3, 0.05, [0.0, 0.0]));
    bad(OccupancyRaster::new(vec![false; 5], 2, 3, 0.05, [0.0, 0.0]));
    bad(OccupancyRaster::new(vec![false; 6], 2, 3, 0.0, [0.0, 0.0]));
    bad(OccupancyRaster::new(vec![false; 6], 2, 3, -0.05, [0.0, 0.0]));
    bad(OccupancyRaster::new(vec![false; 6], 2, 3, f64::NAN, [0.0, 0.0]));
    bad(OccupancyRaster::new(vec![false; 6], 2, 3, 0.05, [f64::INFINITY, 0.0]));
    bad(OccupancyRaster::new(vec![false; 6], 2, 3, 1e9, [0.0, 0.0]));
    bad(OccupancyRaster::new(vec![], usize::MAX, 2, 0.05, [0.0, 0.0]));

    let room = box_room(false);
    let ok = model(0.0, 0.01, 10);
    let pose = Pose2 { x: 1.0, y: 1.0, yaw: 0.0 };
    let mut out = Vec::new();
    let mut expect_err = |m: LidarModel, pose: Pose2, discs: &[Disc], name: &str| {
        let err = cast_ranges(&room, pose, &m, discs, &mut out).unwrap_err();
        assert!(err.to_string().contains(name), "{err}");
    };
    expect_err(LidarModel { beams: 0, ..ok }, pose, &[], "beams");
    expect_err(LidarModel { beams: MAX_BEAMS + 1, ..ok }, pose, &[], "beams");
    expect_err(LidarModel { angle_min: f64::NAN, ..ok }, pose, &[], "angle_min");
    expect_err(LidarModel { angle_increment: f64::INFINITY, ..ok }, pose, &[], "angle_increment");
    expect_err(LidarModel { range_min: -0.1, ..ok }, pose, &[], "range_min");
    expect_err(LidarModel { range_max: 0.05, ..ok }, pose, &[], "range_max");
    expect_err(LidarModel { range_max: f64::INFINITY, ..ok }, pose, &[], "range_max");
    expect_err(ok, Pose2 { yaw: f64::NAN, ..pose }, &[], "sensor pose");
    expect_err(ok, Pose2 { x: 2e9, ..pose }, &[], "sensor pose");
    expect_err(ok, pose, &[Disc { x: 1.0, y: 1.0, radius: 0.0 }], "disc");
    expect_err(ok, pose, &[Disc { x: f64::NAN, y: 1.0, radius: 1.0 }], "disc");

    let mut rng = noise_rng(Some(1));
    let mut r = [1.0, 2.0];
    assert!(add_noise(&mut r, &ok, -0.1, 0.0, &mut rng).is_err());
    assert!(add_noise(&mut r, &ok, f64::NAN, 0.0, &mut rng).is_err());
    assert!(add_noise(&mut r, &ok, 0.0, 1.5, &mut rng).is_err());
    assert!(add_noise(&mut r, &ok, 0.0, f64::NAN, &mut rng).is_err());
    assert_eq!(r, [1.0, 2.0]);
}

#[test]
fn noise_statistics() {
    let n = 100_000;
    let m = LidarModel { range_min: 0.0, range_max: 100.0, ..model(0.0, 0.0, n) };
    let mut r = vec![10.0; n];
    r[0] = f64::INFINITY;
    r[1] = f64::NEG_INFINITY;
    let sigma = 0.03;
    add_noise(&mut r, &m, sigma, 0.0, &mut noise_rng(Some(5))).unwrap();
    assert_eq!((r[0], r[1]), (f64::INFINITY, f64::NEG_INFINITY));
    let e: Vec<f64> = r[2..].iter().map(|v| v - 10.0).collect();
    let mean = e.iter().sum::<f64>() / e.len() as f64;
    let std = (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (e.len() - 1) as f64).sqrt();
    assert!(mean.abs() < 0.01 * sigma * 3.0, "mean {mean}");
    assert!((std / sigma - 1.0).abs() < 0.02, "std {std}");

    // Noise crossing the limits: beyond range_max -> +inf, below range_min -> -inf.
    let m = LidarModel { range_min: 9.99, range_max: 10.01, ..m };
    let mut r = vec![10.0; n];
    add_noise(&mut r, &m, sigma, 0.0, &mut noise_rng(Some(6))).unwrap();
    let above = r.iter().filter(|v| **v == f64::INFINITY).count() as f64 / n as f64;
    let below = r.iter().filter(|v| **v == f64::NEG_INFINITY).count() as f64 / n as f64;
    // P(|z| > 1/3) / 2 = 0.3694 each side.
    assert!((above - 0.3694).abs() < 0.01 && (below - 0.3694).abs() < 0.01, "{above} {below}");
    assert!(r.iter().all(|v| v.is_infinite() || (9.99..=10.01).contains(v)));
}

#[test]
fn dropout_rate_and_determinism() {
    let n = 100_000;
    let m = model(0.0, 0.0, n);
    for p in [0.0, 0.1, 0.5, 1.0] {
        let mut r = vec![5.0; n];
        add_noise(&mut r, &m, 0.0, p, &mut noise_rng(Some(9))).unwrap();
        let rate = r.iter().filter(|v| **v == f64::INFINITY).count() as f64 / n as f64;
        assert!((rate - p).abs() < 0.005, "{p}: {rate}");
        assert!(r.iter().all(|v| *v == 5.0 || *v == f64::INFINITY));
    }
    let run = |seed| {
        let mut r = vec![5.0; 1000];
        add_noise(&mut r, &m, 0.02, 0.1, &mut noise_rng(Some(seed))).unwrap();
        r
    };
    assert_eq!(run(42), run(42));
    assert_ne!(run(42), run(43));
    // Unseeded generators differ (with overwhelming probability).
    let mut a = vec![5.0; 100];
    let mut b = a.clone();
    add_noise(&mut a, &m, 0.02, 0.0, &mut noise_rng(None)).unwrap();
    add_noise(&mut b, &m, 0.02, 0.0, &mut noise_rng(None)).unwrap();
    assert_ne!(a, b);
}
