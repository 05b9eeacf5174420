//! From which directions each wall point can be seen: a 16-sector mask per plan point, so that a
//! pairing with a point the robot cannot see (the far face of a wall, a face around a corner or
//! behind a jamb) is refused without ray casting from the robot.
//!
//! For every point and each of [`SECTORS`] directions (sector centres every 22.5 degrees), a
//! march through the plan's [`WallRaster`] leaves the point's own run of wall cells, crosses free
//! cells, and notes whether it meets another wall cell within [`OCCLUSION_REACH`]. A sector whose
//! march meets one is hidden: a sensor in that direction sees the other wall first. The far face
//! of a thick wall is hidden from the whole half-plane across the wall (the near face is within
//! reach), a face in a corner from the directions the other wall covers. A wall point with no wall
//! within reach in any direction (a one-line wall, a pillar) is seen from everywhere.
//!
//! The mask answers for the sector's centre direction, to within 11.25 degrees, and only for
//! occluders within reach: a far face seen at less than about 18 degrees to its plane through a
//! 0.2 m wall, and an occluder farther than [`OCCLUSION_REACH`] from the point, are not caught.

use crate::cancel::{self, Cancel};
use crate::error::Result;
use crate::grids::wall_raster::WallRaster;
use crate::parallel;

/// Points per chunk of work (the chunks run on every core, see [`crate::parallel`]).
const MASK_CHUNK: usize = cancel::POLL_EVERY;

/// Directions per point.
pub const SECTORS: usize = 16;
/// Farthest occluder considered, metres.
pub const OCCLUSION_REACH: f64 = 0.6;
/// Most half-cell steps of one march (a plan sampled at micrometres would march forever).
const MARCH_STEPS: usize = 1024;
/// A mask where every sector is visible.
pub const SEEN_FROM_EVERYWHERE: u16 = u16::MAX;

/// Per point: bit `k` set when the point can be seen from sector `k` (see [`sector`]).
/// `normals` are the points' wall normals (`[0, 0]` where none was fitted): wall cells within a
/// cell and a half of the point's own wall line are the wall itself (a rotated wall's raster
/// staircase), not an occluder.
///
/// The points are marched in chunks on every core ([`crate::parallel`]); `cancel` is polled
/// before each chunk of [`cancel::POLL_EVERY`] points; when it returns true the marches stop
/// with [`crate::error::IcpError::Interrupted`] ([`cancel::NEVER`]: they cannot be stopped, and
/// never fail).
pub fn visibility_masks(
    points: &[[f64; 2]],
    normals: &[[f64; 2]],
    raster: &WallRaster,
    cancel: Cancel<'_>,
) -> Result<Vec<u16>> {
    let directions: Vec<[f64; 2]> = (0..SECTORS)
        .map(|k| {
            let a = (k as f64 + 0.5) * std::f64::consts::TAU / SECTORS as f64;
            [a.cos(), a.sin()]
        })
        .collect();
    // Chunks of points on every core: each point's mask is its own.
    let chunk = MASK_CHUNK;
    let masks = parallel::map_chunks(points.len().div_ceil(chunk), cancel, |c| {
        let range = c * chunk..((c + 1) * chunk).min(points.len());
        Ok(points[range.clone()]
            .iter()
            .zip(&normals[range])
            .map(|(&p, &n)| {
                directions.iter().enumerate().fold(0u16, |mask, (k, &d)| {
                    if occluded(raster, p, n, d) {
                        mask
                    } else {
                        mask | (1 << k)
                    }
                })
            })
            .collect::<Vec<u16>>())
    })?;
    Ok(masks.concat())
}

/// Whether a march from `p` along the unit direction `d` meets a wall cell past the free cells
/// that follow `p`'s own run of wall cells, within [`OCCLUSION_REACH`].
fn occluded(raster: &WallRaster, p: [f64; 2], n: [f64; 2], d: [f64; 2]) -> bool {
    let res = raster.resolution();
    let origin = raster.origin();
    let step = 0.5 * res;
    let limit = OCCLUSION_REACH.min(MARCH_STEPS as f64 * step);
    let mut left_own_run = false;
    // Distance from p's own wall line within which a wall cell is that wall.
    let own_band = 1.5 * res;
    let across = (d[0] * n[0] + d[1] * n[1]).abs();
    let (cols, rows) = raster.shape();
    // Counted steps: at a denormal resolution `step` rounds to zero and `t += step` would never
    // reach the limit (a hang the fuzz target found).
    let mut i = 1;
    while i <= MARCH_STEPS {
        let t = i as f64 * step;
        if t > limit {
            break;
        }
        let x = ((p[0] + t * d[0] - origin[0]) / res).floor() as i64;
        let y = ((p[1] + t * d[1] - origin[1]) / res).floor() as i64;
        if x < 0 || y < 0 || x as usize >= cols || y as usize >= rows {
            // Out of the raster, a rectangle with a free border: a straight march never comes back
            // to a wall cell.
            return false;
        }
        let clearance = raster.clearance(x as usize, y as usize);
        let own_line = n != [0.0, 0.0] && t * across < own_band;
        let wall = clearance == 0 && !(left_own_run && own_line);
        if !left_own_run {
            left_own_run = !wall;
        } else if wall {
            return true;
        }
        // Every cell within `clearance - 1` of this free one is free: the next 2 (clearance - 2)
        // half-cell steps (one cell short, against rounding) land on free cells and change
        // nothing, so the march jumps over them, as the visibility casts do (crate::grids::clearance).
        // Marches from a wall of a dense plan cross its open space in a few jumps.
        i += 1 + 2 * usize::from(clearance.saturating_sub(2));
    }
    false
}

/// The sector (0..16, counter-clockwise from +x, 22.5 degrees each) of the direction `(dx, dy)`,
/// from comparisons only (no trigonometry in the look-up loop).
#[inline]
pub fn sector(dx: f64, dy: f64) -> usize {
    const TAN_22_5: f64 = 0.414_213_562_373_095_1;
    // Sector by quadrant (x < 0, y < 0), steepness (|y| > |x|) and which half of that octant:
    // a table instead of branches, since the direction to the sensor changes from point to point.
    const TABLE: [u8; 16] = {
        let mut t = [0u8; 16];
        let mut i = 0;
        while i < 16 {
            let (neg_x, neg_y, steep, half) = (i & 1 != 0, i & 2 != 0, i & 4 != 0, i & 8 != 0);
            let q = if steep { 3 - half as u8 } else { half as u8 };
            t[i] = match (neg_x, neg_y) {
                (false, false) => q,
                (true, false) => 7 - q,
                (true, true) => 8 + q,
                (false, true) => 15 - q,
            };
            i += 1;
        }
        t
    };
    let (ax, ay) = (dx.abs(), dy.abs());
    let steep = ay > ax;
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let half = lo > TAN_22_5 * hi;
    let i =
        usize::from(dx < 0.0) | usize::from(dy < 0.0) << 1 | usize::from(steep) << 2 | usize::from(half) << 3;
    TABLE[i] as usize
}

/// Whether a point with visibility `mask` at `p` can be seen from a sensor at `sensor`.
#[inline]
pub fn seen_from(mask: u16, p: [f64; 2], sensor: [f64; 2]) -> bool {
    mask >> sector(sensor[0] - p[0], sensor[1] - p[1]) & 1 == 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_denormal_raster_resolution_does_not_hang_the_march() {
        // Found by the fuzz target: half of 5e-324 rounds to 0, and the march never advanced.
        // (The target gave a map 54 copies of one point, which the map thins to one; the raster
        // of the copies is the same, and so is the march.)
        let points = vec![[0.3, -0.2]; 54];
        let raster = WallRaster::new(&points, 5e-324).unwrap();
        let masks = visibility_masks(&points, &vec![[0.0, 0.0]; 54], &raster, cancel::NEVER).unwrap();
        assert_eq!(masks.len(), 54);
    }

    fn sample(pts: &mut Vec<[f64; 2]>, a: [f64; 2], b: [f64; 2]) {
        let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / 0.05).round() as usize;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }

    #[test]
    fn sectors_follow_the_angle() {
        for k in 0..64 {
            let a = (k as f64 + 0.5) * std::f64::consts::TAU / 64.0;
            let expected = (a / (std::f64::consts::TAU / 16.0)) as usize;
            assert_eq!(sector(a.cos(), a.sin()), expected, "angle {a}");
            assert_eq!(sector(3.0 * a.cos(), 3.0 * a.sin()), expected);
        }
    }

    #[test]
    fn a_thick_walls_far_face_is_hidden_and_a_thin_wall_is_seen_from_both_sides() {
        let mut pts = Vec::new();
        // A 0.2 m thick wall along x between rooms (faces at y = 0 and y = 0.2)...
        sample(&mut pts, [0.0, 0.0], [6.0, 0.0]);
        sample(&mut pts, [0.0, 0.2], [6.0, 0.2]);
        let thick = pts.len();
        // ...and a one-line wall far from everything.
        sample(&mut pts, [10.0, -3.0], [10.0, 3.0]);
        let raster = WallRaster::new(&pts, 0.075).unwrap();
        let tree = crate::maps::kd_tree::Tree2::new_from_slice(&pts);
        let normals = crate::maps::wall_normals::estimate_normals(&pts, &tree, cancel::NEVER).unwrap();
        let masks = visibility_masks(&pts, &normals, &raster, cancel::NEVER).unwrap();
        for (i, p) in pts.iter().enumerate() {
            if p[0] < 1.0 || (p[0] > 5.0 && p[0] < 9.0) || p[1].abs() > 2.5 {
                continue;
            }
            let m = masks[i];
            if i < thick {
                // The face at y = 0 looks down (-y), the one at y = 0.2 up.
                let outward = if p[1] < 0.1 { -1.0 } else { 1.0 };
                assert!(seen_from(m, *p, [p[0] + 1.0, p[1] + 3.0 * outward]), "{p:?}: {m:016b}");
                assert!(seen_from(m, *p, [p[0] - 2.0, p[1] + 3.0 * outward]), "{p:?}: {m:016b}");
                assert!(!seen_from(m, *p, [p[0] + 1.0, p[1] - 3.0 * outward]), "{p:?}: {m:016b}");
                assert!(!seen_from(m, *p, [p[0], p[1] - 3.0 * outward]), "{p:?}: {m:016b}");
            } else {
                assert_eq!(m, SEEN_FROM_EVERYWHERE, "{p:?}");
            }
        }
    }

    #[test]
    fn marches_that_jump_across_free_cells_give_the_masks_of_marches_cell_by_cell() {
        // Rooms with thick walls, a corner, a pillar and a slanted wall, at two resolutions.
        let mut pts = Vec::new();
        for (a, b) in [
            ([0.0, 0.0], [8.0, 0.0]),
            ([8.0, 0.0], [8.0, 5.0]),
            ([8.0, 5.0], [0.0, 5.0]),
            ([0.0, 5.0], [0.0, 0.0]),
            ([-0.2, -0.2], [8.2, -0.2]),
            ([8.2, -0.2], [8.2, 5.2]),
            ([3.0, 0.0], [3.0, 3.0]),
            ([3.2, 0.0], [3.2, 3.0]),
            ([5.0, 1.0], [7.0, 4.1]),
            ([1.5, 3.5], [1.6, 3.5]),
        ] {
            sample(&mut pts, a, b);
        }
        let tree = crate::maps::kd_tree::Tree2::new_from_slice(&pts);
        let normals = crate::maps::wall_normals::estimate_normals(&pts, &tree, cancel::NEVER).unwrap();
        for resolution in [0.075, 0.031] {
            let raster = WallRaster::new(&pts, resolution).unwrap();
            let jumping = visibility_masks(&pts, &normals, &raster, cancel::NEVER).unwrap();
            let stepping = visibility_masks(&pts, &normals, &raster.without_jumps(), cancel::NEVER).unwrap();
            assert_eq!(jumping, stepping, "at {resolution} m");
            assert!(jumping.iter().any(|&m| m != SEEN_FROM_EVERYWHERE));
        }
    }

    #[test]
    fn a_face_in_a_corner_is_hidden_behind_the_other_wall() {
        // An inner corner: walls along y = 0 and x = 0, both one line.
        let mut pts = Vec::new();
        sample(&mut pts, [0.0, 0.0], [4.0, 0.0]);
        sample(&mut pts, [0.0, 0.05], [0.0, 4.0]);
        let raster = WallRaster::new(&pts, 0.075).unwrap();
        let tree = crate::maps::kd_tree::Tree2::new_from_slice(&pts);
        let normals = crate::maps::wall_normals::estimate_normals(&pts, &tree, cancel::NEVER).unwrap();
        let masks = visibility_masks(&pts, &normals, &raster, cancel::NEVER).unwrap();
        let i = pts.iter().position(|p| (p[0] - 0.3).abs() < 1e-9 && p[1] == 0.0).unwrap();
        // Seen from the room (up and to the right), hidden from behind the x = 0 wall.
        assert!(seen_from(masks[i], pts[i], [2.0, 2.0]));
        assert!(!seen_from(masks[i], pts[i], [-3.0, 2.0]));
    }
}
