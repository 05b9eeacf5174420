//! The office floor every bench uses: 40 x 25 m, 0.2 m thick walls, eight rooms along a corridor,
//! as wall-surface points every 5 cm ([`office`]) and as an occupancy raster at 5 cm
//! ([`office_raster`]).

// Each bench compiles this module on its own and uses only part of it.
#![allow(dead_code)]

use icp_core::grids::ray_casting::{LidarModel, OccupancyRaster};
use icp_core::{PointMap, Pose2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Raster resolution, metres per cell.
pub const RES: f64 = 0.05;

/// Walls of the office as (a, b) centre lines, 0.2 m thick.
fn office_walls() -> Vec<([f64; 2], [f64; 2])> {
    let mut walls = vec![
        ([0.0, 0.0], [40.0, 0.0]),
        ([0.0, 25.0], [40.0, 25.0]),
        ([0.0, 0.0], [0.0, 25.0]),
        ([40.0, 0.0], [40.0, 25.0]),
    ];
    for (y, far) in [(11.0, 0.0), (13.5, 25.0)] {
        let mut x = 0.0;
        for k in 0..4 {
            let x1 = 10.0 * (k + 1) as f64;
            walls.push(([x, y], [x + 4.0, y]));
            walls.push(([x + 5.0, y], [x1, y]));
            if k < 3 {
                walls.push(([x1, y], [x1, far]));
            }
            x = x1;
        }
    }
    walls
}

/// The office at 5 cm with a 1 m free margin: a cell is occupied when its centre lies within 0.1 m
/// of a wall's centre line (axis-aligned walls, so a box test).
pub fn office_raster() -> OccupancyRaster {
    let origin = [-1.0, -1.0];
    let (cols, rows) = ((42.0 / RES) as usize, (27.0 / RES) as usize);
    let walls = office_walls();
    let mut cells = vec![false; rows * cols];
    for r in 0..rows {
        for c in 0..cols {
            let (x, y) = (origin[0] + (c as f64 + 0.5) * RES, origin[1] + (r as f64 + 0.5) * RES);
            cells[r * cols + c] = walls.iter().any(|(a, b)| {
                let (x0, x1) = (a[0].min(b[0]) - 0.1, a[0].max(b[0]) + 0.1);
                let (y0, y1) = (a[1].min(b[1]) - 0.1, a[1].max(b[1]) + 0.1);
                (x0..x1).contains(&x) && (y0..y1).contains(&y)
            });
        }
    }
    OccupancyRaster::new(cells, rows, cols, RES, origin).unwrap()
}

/// Both faces of an axis-aligned wall from `a` to `b` (thickness 0.2 m), points every 5 cm.
fn wall(points: &mut Vec<[f64; 2]>, a: [f64; 2], b: [f64; 2]) {
    let horizontal = (a[1] - b[1]).abs() < 1e-9;
    let len = if horizontal { (b[0] - a[0]).abs() } else { (b[1] - a[1]).abs() };
    let n = (len / 0.05).round() as usize;
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let p = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
        if horizontal {
            points.push([p[0], p[1] - 0.1]);
            points.push([p[0], p[1] + 0.1]);
        } else {
            points.push([p[0] - 0.1, p[1]]);
            points.push([p[0] + 0.1, p[1]]);
        }
    }
}

/// The office as wall-surface points: both faces of every wall, every 5 cm.
pub fn office() -> Vec<[f64; 2]> {
    let mut pts = Vec::new();
    for (a, b) in office_walls() {
        wall(&mut pts, a, b);
    }
    pts
}

/// A noisy scan of `points` returns from `pose` (robot frame): plan points visible from the pose,
/// jittered by up to 2.5 cm along the wall and 1.5 cm across it.
pub fn noisy_scan(map: &PointMap, pose: Pose2, points: usize, rng: &mut ChaCha8Rng) -> Vec<[f64; 2]> {
    let vis = map.visible_from(pose, 30.0).unwrap();
    let inv = pose.inverse();
    (0..points)
        .map(|_| {
            let i = vis[rng.random_range(0..vis.len())] as usize;
            let q = map.points()[i];
            let n = map.normals()[i];
            let along = rng.random_range(-0.025..0.025);
            let across = rng.random_range(-0.015..0.015);
            inv.transform_point([q[0] - n[1] * along + n[0] * across, q[1] + n[0] * along + n[1] * across])
        })
        .collect()
}

/// A 270-degree, 1081-beam, 30 m LIDAR (a Hokuyo UTM-30LX), as the simulation uses.
pub fn hokuyo() -> LidarModel {
    let fov = 270f64.to_radians();
    LidarModel {
        angle_min: -0.5 * fov,
        angle_increment: fov / 1080.0,
        beams: 1081,
        range_min: 0.05,
        range_max: 30.0,
    }
}

/// A square floor of `size` metres: a grid of `room[0]` x `room[1]` m rooms, 0.2 m thick walls
/// with a 1 m door in every wall between two crossings, both faces sampled every `spacing` metres
/// (a plan drawn at `spacing` metres per pixel gives its wall surface points that far apart).
pub fn grid_floor(size: f64, room: [f64; 2], spacing: f64) -> Vec<[f64; 2]> {
    let mut pts = Vec::new();
    let mut face = |a: [f64; 2], b: [f64; 2]| {
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (len / spacing).round().max(1.0) as usize;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    };
    for axis in 0..2 {
        let step = room[axis];
        let lines = (size / step).round() as usize;
        let segments = (size / room[1 - axis]).round() as usize;
        for k in 0..=lines {
            let c = k as f64 * step;
            for s in 0..segments {
                let (s0, s1) = (s as f64 * room[1 - axis], (s + 1) as f64 * room[1 - axis]);
                let mid = 0.5 * (s0 + s1);
                let outer = k == 0 || k == lines;
                let spans = if outer { vec![(s0, s1)] } else { vec![(s0, mid - 0.5), (mid + 0.5, s1)] };
                for (u0, u1) in spans {
                    for side in [-0.1, 0.1] {
                        let (a, b) = if axis == 0 {
                            ([c + side, u0], [c + side, u1])
                        } else {
                            ([u0, c + side], [u1, c + side])
                        };
                        face(a, b);
                    }
                }
            }
        }
    }
    pts
}
