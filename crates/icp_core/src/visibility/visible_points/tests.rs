//! Tests of the visibility cast: the faces seen and hidden, range limits, positions outside the building, jumps across open space.

use super::*;

/// Raster cell: 1.5 times the point spacing, so consecutive wall points share or touch cells.
const RES: f64 = 0.075;

/// A square room [0, 4] x [0, 4] with walls 0.2 m thick: inner faces at 0 and 4, outer faces at
/// -0.2 and 4.2, points every 0.05 m.
fn thick_box() -> (Vec<[f64; 2]>, Vec<bool>) {
    let mut pts = Vec::new();
    let mut inner = Vec::new();
    let n = 80;
    for i in 0..=n {
        let t = i as f64 * 0.05;
        for (p, is_inner) in [([t, 0.0], true), ([t, 4.0], true), ([0.0, t], true), ([4.0, t], true)] {
            pts.push(p);
            inner.push(is_inner);
        }
    }
    for i in 0..=88 {
        let t = -0.2 + i as f64 * 0.05;
        for p in [[t, -0.2], [t, 4.2], [-0.2, t], [4.2, t]] {
            pts.push(p);
            inner.push(false);
        }
    }
    (pts, inner)
}

#[test]
fn sees_inner_faces_only() {
    let (pts, inner) = thick_box();
    let raster = WallRaster::new(&pts, RES).unwrap();
    let vis = visible_points(&raster, [1.3, 2.1], 10.0).unwrap();
    assert!(!vis.is_empty());
    assert!(vis.iter().all(|&i| inner[i as usize]), "an outer-face point was visible");
    let inner_total = inner.iter().filter(|&&b| b).count();
    // Nearly every inner point is seen (corner cells may hold two points, both seen).
    assert!(vis.len() as f64 > 0.95 * inner_total as f64, "{} of {}", vis.len(), inner_total);
}

/// An occupancy grid's wall two 5 cm cells thick, seen from a robot 1.5 m in front of it: its
/// two rows of cell centres (y = 2.06 and 2.11, every 5 cm in x) fall into neighbouring raster
/// cells of 7.5 cm (the raster starts one cell below the floor row at y = 0), and a solid block
/// lies behind them beyond a free cell.
#[test]
fn the_first_layer_of_a_grid_wall_is_seen_whole_and_what_lies_deeper_is_not() {
    let mut pts = Vec::new();
    for i in 0..=60 {
        let x = i as f64 * 0.05;
        pts.extend([[x, 2.06], [x, 2.11]]);
    }
    let two_rows = pts.len();
    for i in 0..=60 {
        for y in [2.3, 2.35, 2.4, 0.0] {
            pts.push([i as f64 * 0.05, y]);
        }
    }
    let raster = WallRaster::new(&pts, RES).unwrap();
    let row = |y: f64| ((y - raster.origin()[1]) / RES).floor();
    assert_eq!(row(2.11), row(2.06) + 1.0);
    let seen = visible_points(&raster, [1.5, 0.5], 10.0).unwrap();
    let count = |y: f64| seen.iter().filter(|&&i| pts[i as usize][1] == y).count();
    assert!(
        count(2.06) > 55 && count(2.11) > 55,
        "near row {}, far row {} of 61 each",
        count(2.06),
        count(2.11)
    );
    assert!(
        seen.iter().all(|&i| (i as usize) < two_rows || pts[i as usize][1] == 0.0),
        "the block behind was seen"
    );
}

#[test]
fn range_limits_what_is_seen() {
    let (pts, _) = thick_box();
    let raster = WallRaster::new(&pts, RES).unwrap();
    let near = visible_points(&raster, [0.5, 2.0], 1.0).unwrap();
    assert!(near.iter().all(|&i| (pts[i as usize][0] - 0.0).abs() < 1e-9));
    assert!(!near.is_empty());
}

#[test]
fn outside_the_building_sees_outer_faces() {
    let (pts, inner) = thick_box();
    let raster = WallRaster::new(&pts, RES).unwrap();
    let vis = visible_points(&raster, [6.0, 2.0], 20.0).unwrap();
    assert!(!vis.is_empty());
    assert!(vis.iter().all(|&i| !inner[i as usize]));
}

#[test]
fn far_outside_positions_finish_and_see_the_outer_faces() {
    let (pts, inner) = thick_box();
    let raster = WallRaster::new(&pts, RES).unwrap();
    // Far away, with an absurd range: the walk through the raster is bounded, so this returns
    // (the building may be too small to be hit by any ray), and sees only outer faces.
    for position in [[1e8, 0.0], [-3e8, 5e8], [2.0, -1e9]] {
        let vis = visible_points(&raster, position, 1e10).unwrap();
        assert!(vis.iter().all(|&i| !inner[i as usize]), "{position:?}");
    }
    let vis = visible_points(&raster, [60.0, 2.0], 1e10).unwrap();
    assert!(vis.len() > 20 && vis.iter().all(|&i| !inner[i as usize]));
    assert!(visible_points(&raster, [1e8, 0.0], 100.0).unwrap().is_empty());
}

#[test]
fn a_shorter_range_sees_no_fewer_near_points() {
    let (pts, _) = thick_box();
    let raster = WallRaster::new(&pts, RES).unwrap();
    // Close to a corner, the far walls are seen at grazing angles.
    let position = [3.7, 3.8];
    let far = visible_points(&raster, position, 30.0).unwrap();
    let near = visible_points(&raster, position, 6.0).unwrap();
    let within = |i: &u32| {
        let p = pts[*i as usize];
        (p[0] - position[0]).hypot(p[1] - position[1]) < 5.5
    };
    let far_near: Vec<u32> = far.iter().copied().filter(within).collect();
    let near_near: Vec<u32> = near.iter().copied().filter(within).collect();
    assert_eq!(far_near, near_near);
}

#[test]
fn jumps_across_open_space_do_not_change_what_is_seen() {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    // Random walls, sampled every 5 cm, across a 30 x 20 m floor: wide open space to jump
    // across, and walls at every angle to land next to.
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut pts = Vec::new();
    for _ in 0..40 {
        let a = [rng.random_range(0.0..30.0), rng.random_range(0.0..20.0)];
        let (len, angle) = (rng.random_range(0.5..8.0), rng.random_range(0.0..TAU));
        let n = (len / 0.05f64).ceil() as usize;
        for k in 0..=n {
            let t = len * k as f64 / n as f64;
            pts.push([a[0] + t * angle.cos(), a[1] + t * angle.sin()]);
        }
    }
    let raster = WallRaster::new(&pts, RES).unwrap();
    let plain = raster.without_jumps();
    let mut positions: Vec<[f64; 2]> =
        (0..30).map(|_| [rng.random_range(-5.0..35.0), rng.random_range(-5.0..25.0)]).collect();
    positions.push(pts[17]); // inside a wall cell
    for position in positions {
        for range in [3.0, 12.0, 40.0] {
            let jumping = visible_points(&raster, position, range).unwrap();
            assert_eq!(jumping, visible_points(&plain, position, range).unwrap(), "{position:?} {range}");
        }
    }
}

#[test]
fn rejects_bad_range() {
    let (pts, _) = thick_box();
    let raster = WallRaster::new(&pts, RES).unwrap();
    assert!(visible_points(&raster, [1.0, 1.0], 0.0).is_err());
    assert!(visible_points(&raster, [1.0, 1.0], f64::INFINITY).is_err());
    assert!(visible_points(&raster, [f64::NAN, 1.0], 5.0).is_err());
}
