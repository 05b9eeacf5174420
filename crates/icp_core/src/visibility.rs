//! Which wall points a range sensor can see from a position: rays cast cell by cell
//! (Amanatides-Woo traversal) through the plan's [`WallRaster`], each stopping at the first wall
//! cell. The points in the cells where rays stop are the visible wall faces; the far face of a
//! wall, a wall's thickness behind the near one, is hidden, so the ICP cannot lock onto it.

use crate::error::{invalid, Result};
use crate::wall_raster::WallRaster;
use std::f64::consts::TAU;

/// Rays cast evenly around the position before refinement.
pub const BASE_RAYS: usize = 720;
/// Most halvings of the angle between two neighbouring rays.
pub const MAX_REFINEMENT_DEPTH: u32 = 6;

/// Indices (ascending, unique) of the plan points in the wall cells that rays from `position`
/// (map frame, metres) reach first, within `max_range` metres.
///
/// [`BASE_RAYS`] rays are cast evenly; between two neighbouring rays whose first wall cells do not
/// touch (a depth jump, a doorway, a far wall), a ray is added halfway, recursively, until the
/// cells touch or the angle between the rays is below one cell at `max_range` (at most
/// [`MAX_REFINEMENT_DEPTH`] halvings). The cell holding `position` itself is skipped, so a
/// position that falls inside a wall (a poor guess) still sees the walls around it.
pub fn visible_points(raster: &WallRaster, position: [f64; 2], max_range: f64) -> Result<Vec<u32>> {
    if !(max_range.is_finite() && max_range > 0.0) {
        return Err(invalid(
            "max_range",
            max_range,
            "must be a positive finite number of metres",
        ));
    }
    if !(position[0].is_finite() && position[1].is_finite()) {
        return Err(invalid(
            "position",
            format!("{position:?}"),
            "must be finite",
        ));
    }
    let mut hit_cells = Vec::new();
    visible_cells(raster, position, max_range, &mut hit_cells);
    let mut out: Vec<u32> = hit_cells
        .iter()
        .flat_map(|&cell| raster.points_in_cell(cell).iter().copied())
        .collect();
    out.sort_unstable();
    Ok(out)
}

/// Linear indices (sorted, unique) of the wall cells where the rays from `position` stop.
pub fn visible_cells(
    raster: &WallRaster,
    position: [f64; 2],
    max_range: f64,
    out: &mut Vec<usize>,
) {
    out.clear();
    let res = raster.resolution();
    let origin = raster.origin();
    let (cols, rows) = raster.shape();
    let caster = RayCaster {
        raster,
        origin: (
            (position[0] - origin[0]) / res,
            (position[1] - origin[1]) / res,
        ),
        max_t: max_range / res,
        shape: (cols, rows),
    };
    // Finest angle worth resolving: one cell at the maximum range.
    let min_gap = (res / max_range).min(TAU / BASE_RAYS as f64);
    let step = TAU / BASE_RAYS as f64;
    let first = caster.cast(0.0);
    let mut previous = first;
    let mut stack: Vec<Bracket> = Vec::new();
    for k in 1..=BASE_RAYS {
        let angle = k as f64 * step;
        let hit = if k == BASE_RAYS {
            first
        } else {
            caster.cast(angle)
        };
        stack.push(((k - 1) as f64 * step, previous, angle, hit, 0));
        while let Some((a0, h0, a1, h1, depth)) = stack.pop() {
            if let Some((cx, cy)) = h0 {
                out.push(cy as usize * cols + cx as usize);
            }
            let touching = match (h0, h1) {
                (Some(p), Some(q)) => (p.0 - q.0).abs() <= 1 && (p.1 - q.1).abs() <= 1,
                (None, None) => true,
                _ => false,
            };
            if touching || depth >= MAX_REFINEMENT_DEPTH || a1 - a0 <= min_gap {
                continue;
            }
            let mid = 0.5 * (a0 + a1);
            let hm = caster.cast(mid);
            // Right half first onto the stack so the left half is handled next; the left half
            // records `h0` again, which the final dedup removes.
            stack.push((mid, hm, a1, h1, depth + 1));
            stack.push((a0, h0, mid, hm, depth + 1));
        }
        previous = hit;
    }
    out.sort_unstable();
    out.dedup();
}

/// The first wall cell (col, row) a ray reaches, if any.
type Hit = Option<(i64, i64)>;

/// Two rays to refine between: (angle, hit) of each, and the refinement depth.
type Bracket = (f64, Hit, f64, Hit, u32);

/// Casts single rays from one position through the raster, in cell units.
struct RayCaster<'a> {
    raster: &'a WallRaster,
    origin: (f64, f64),
    max_t: f64,
    shape: (usize, usize),
}

impl RayCaster<'_> {
    /// The first wall cell (col, row) after the start cell along `angle` (radians), if any.
    #[inline]
    fn cast(&self, angle: f64) -> Hit {
        let (dy, dx) = angle.sin_cos();
        let start = (self.origin.0.floor() as i64, self.origin.1.floor() as i64);
        first_wall_cell(
            self.raster,
            self.origin,
            start,
            (dx, dy),
            self.max_t,
            self.shape,
        )
    }
}

/// Walks the cells along one ray (cell units) and returns the first wall cell after the start.
#[inline]
fn first_wall_cell(
    raster: &WallRaster,
    (ox, oy): (f64, f64),
    (mut cx, mut cy): (i64, i64),
    (dx, dy): (f64, f64),
    max_t: f64,
    (cols, rows): (usize, usize),
) -> Option<(i64, i64)> {
    let step_x: i64 = if dx > 0.0 { 1 } else { -1 };
    let step_y: i64 = if dy > 0.0 { 1 } else { -1 };
    let t_delta_x = if dx != 0.0 {
        (1.0 / dx).abs()
    } else {
        f64::INFINITY
    };
    let t_delta_y = if dy != 0.0 {
        (1.0 / dy).abs()
    } else {
        f64::INFINITY
    };
    let mut t_max_x = if dx > 0.0 {
        (cx as f64 + 1.0 - ox) * t_delta_x
    } else if dx < 0.0 {
        (ox - cx as f64) * t_delta_x
    } else {
        f64::INFINITY
    };
    let mut t_max_y = if dy > 0.0 {
        (cy as f64 + 1.0 - oy) * t_delta_y
    } else if dy < 0.0 {
        (oy - cy as f64) * t_delta_y
    } else {
        f64::INFINITY
    };
    loop {
        let t = if t_max_x < t_max_y {
            cx += step_x;
            let t = t_max_x;
            t_max_x += t_delta_x;
            t
        } else {
            cy += step_y;
            let t = t_max_y;
            t_max_y += t_delta_y;
            t
        };
        if t > max_t {
            return None;
        }
        let leaving_x = (cx < 0 && step_x < 0) || (cx >= cols as i64 && step_x > 0);
        let leaving_y = (cy < 0 && step_y < 0) || (cy >= rows as i64 && step_y > 0);
        if leaving_x || leaving_y {
            return None;
        }
        if raster.is_wall(cx, cy) {
            return Some((cx, cy));
        }
    }
}

#[cfg(test)]
mod tests {
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
            for (p, is_inner) in [
                ([t, 0.0], true),
                ([t, 4.0], true),
                ([0.0, t], true),
                ([4.0, t], true),
            ] {
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
        assert!(
            vis.iter().all(|&i| inner[i as usize]),
            "an outer-face point was visible"
        );
        let inner_total = inner.iter().filter(|&&b| b).count();
        // Nearly every inner point is seen (corner cells may hold two points, both seen).
        assert!(
            vis.len() as f64 > 0.95 * inner_total as f64,
            "{} of {}",
            vis.len(),
            inner_total
        );
    }

    #[test]
    fn range_limits_what_is_seen() {
        let (pts, _) = thick_box();
        let raster = WallRaster::new(&pts, RES).unwrap();
        let near = visible_points(&raster, [0.5, 2.0], 1.0).unwrap();
        assert!(near
            .iter()
            .all(|&i| (pts[i as usize][0] - 0.0).abs() < 1e-9));
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
    fn rejects_bad_range() {
        let (pts, _) = thick_box();
        let raster = WallRaster::new(&pts, RES).unwrap();
        assert!(visible_points(&raster, [1.0, 1.0], 0.0).is_err());
        assert!(visible_points(&raster, [1.0, 1.0], f64::INFINITY).is_err());
        assert!(visible_points(&raster, [f64::NAN, 1.0], 5.0).is_err());
    }
}
