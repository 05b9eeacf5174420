//! Which wall points a range sensor can see from a position: rays cast cell by cell
//! (Amanatides-Woo traversal) through the plan's [`WallRaster`], each stopping at the first wall
//! cell. The points in the cells where rays stop are the visible wall faces; the far face of a
//! wall, a wall's thickness behind the near one, is hidden, so the ICP cannot lock onto it.
//!
//! This file holds the cast's fan of rays and its refinement at depth jumps; one ray's walk to its
//! first wall cell is in `wall_rays`, and the range to the wall where it stopped in
//! `surface_ranges`.

use crate::error::{invalid, Result};
use crate::grids::wall_raster::WallRaster;
use crate::visibility::visible_points::surface_ranges::SurfaceRanges;
use crate::visibility::visible_points::wall_rays::{Cell, Hit, Ray, RayCaster, Stop};
use std::f64::consts::TAU;

mod surface_ranges;
mod wall_rays;

/// Rays cast evenly around the position before refinement.
pub const BASE_RAYS: usize = 720;
/// Most halvings of the angle between two neighbouring rays.
pub const MAX_REFINEMENT_DEPTH: u32 = 6;

/// Indices (ascending, unique) of the plan points in the wall cells that rays from `position`
/// (map frame, metres) reach first, within `max_range` metres.
///
/// [`BASE_RAYS`] rays are cast evenly; between two neighbouring rays whose first wall cells are not
/// adjacent (a depth jump, a doorway, a far wall; see `adjacent`), a ray is added halfway, recursively, until
/// the cells touch or the angle between the rays is below one cell at `max_range` (at most
/// [`MAX_REFINEMENT_DEPTH`] halvings). The cell holding `position` itself is skipped, so a
/// position that falls inside a wall (a poor guess) still sees the walls around it.
pub fn visible_points(raster: &WallRaster, position: [f64; 2], max_range: f64) -> Result<Vec<u32>> {
    check_cast(position, max_range)?;
    let mut hit_cells = Vec::new();
    visible_cells(raster, position, max_range, RayFan::circle(0.0, BASE_RAYS), &mut hit_cells, None, None);
    Ok(raster.points_in_cells(&hit_cells))
}

/// Refuses a position that is not finite and a range that is not a positive finite number.
pub(crate) fn check_cast(position: [f64; 2], max_range: f64) -> Result<()> {
    if !(max_range.is_finite() && max_range > 0.0) {
        return Err(invalid("max_range", max_range, "must be a positive finite number of metres"));
    }
    if !(position[0].is_finite() && position[1].is_finite()) {
        return Err(invalid("position", format!("{position:?}"), "must be finite"));
    }
    Ok(())
}

/// The base rays of a visibility cast: `rays` directions evenly over the full circle, ray `k` at
/// map angle `first_angle + k * TAU / rays` (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayFan {
    /// Map angle of ray 0, radians.
    pub first_angle: f64,
    /// Number of base rays over the full circle (at least 2).
    pub rays: usize,
    /// How many of the gaps between base rays, from ray 0 on, are cast: `rays` for the full
    /// circle, fewer for an arc (rays 0 to `span`).
    pub span: usize,
}

/// How far rays are cast in each direction (metres), by map angle: `reach[j]` for the angles in
/// `[first_angle + j w, first_angle + (j + 1) w)`, `w = TAU / reach.len()`, all within the cast's
/// own range.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionalReach {
    /// Map angle where bin 0 starts, radians.
    pub first_angle: f64,
    /// Metres per bin.
    pub reach: Vec<f64>,
}

impl DirectionalReach {
    /// The reach at map angle `angle`, metres.
    #[inline]
    pub fn at(&self, angle: f64) -> f64 {
        let n = self.reach.len();
        let turns = (angle - self.first_angle) / TAU;
        let j = ((turns - turns.floor()) * n as f64) as usize;
        self.reach[j.min(n - 1)]
    }
}

impl RayFan {
    /// The full circle of `rays` base rays from `first_angle`.
    pub fn circle(first_angle: f64, rays: usize) -> Self {
        Self { first_angle, rays, span: rays }
    }
}

/// Linear indices (sorted, unique) of the wall cells where the rays from `position` stop (see
/// [`visible_points`]). With `ranges`, also the metres from `position` to the wall in the first
/// wall cell (see `SurfaceRanges`) in `2 * fan.span` directions (one more for an arc, whose last
/// base ray has no gap after it): each base ray of `fan`, then the direction halfway to the next
/// one, `inf` where no wall cell lies within `max_range`. A halfway direction takes the range of
/// the refinement's ray there when one was cast (the two base rays stopped in cells that are not
/// adjacent), else the mean of the two base rays' ranges: they stopped in the same or adjacent
/// cells, so the ray between them stops there too, and its range lies within about a cell of
/// that mean.
pub fn visible_cells(
    raster: &WallRaster,
    position: [f64; 2],
    max_range: f64,
    fan: RayFan,
    out: &mut Vec<usize>,
    ranges: Option<RangeOutput<'_>>,
    reach: Option<&DirectionalReach>,
) {
    out.clear();
    let res = raster.resolution();
    let origin = raster.origin();
    let (cols, rows) = raster.shape();
    let caster = RayCaster {
        raster,
        origin: ((position[0] - origin[0]) / res, (position[1] - origin[1]) / res),
        max_t: max_range / res,
        shape: (cols, rows),
    };
    let rays = fan.rays.max(2);
    let span = fan.span.clamp(1, rays);
    let mut ranges = ranges.map(|output| {
        output.ranges.clear();
        output.ranges.reserve(2 * span + 1);
        (output.ranges, SurfaceRanges { raster, points: output.points, position, cached: None })
    });
    // Finest angle worth resolving: an eighth of a cell at the maximum range (walls seen at a
    // grazing angle need more than one ray per cell width).
    let min_gap = res / max_range / 8.0;
    let step = TAU / rays as f64;
    // Base ray k's direction turns ray k - 1's by `step` (a rotation, no trigonometry), and is
    // taken from sin_cos afresh every RESEED rays so that rounding cannot accumulate.
    const RESEED: usize = 32;
    let (turn_sin, turn_cos) = step.sin_cos();
    let base = |k: usize, before: &Ray| {
        let angle = fan.first_angle + k as f64 * step;
        let dir = if k % RESEED == 0 {
            let (dy, dx) = angle.sin_cos();
            (dx, dy)
        } else {
            let (x, y) = before.dir;
            (turn_cos * x - turn_sin * y, turn_sin * x + turn_cos * y)
        };
        Ray { angle, dir, hit: None }
    };
    let cast = |ray: Ray| {
        let hit = match reach {
            None => caster.cast(ray.dir),
            Some(reach) => caster.cast_within(ray.dir, reach.at(ray.angle) / res),
        };
        Ray { hit, ..ray }
    };
    let first = cast(base(0, &Ray { angle: 0.0, dir: (1.0, 0.0), hit: None }));
    let mut previous = first;
    let mut previous_range = ranges.as_mut().map_or(f64::NAN, |(_, surface)| surface.range(&first));
    let mut stack: Vec<Bracket> = Vec::new();
    // Neighbouring rays mostly stop in the same cell from the same free cell: its cells are
    // recorded once (the sort below then has far fewer duplicates to remove).
    let mut last_recorded: Option<(Cell, Option<Cell>)> = None;
    // An arc ends with a bracket from its last base ray to itself, which records that ray's stop.
    let brackets = if span < rays { span + 1 } else { span };
    for k in 1..=brackets {
        // On the full circle the last bracket closes it: its end is ray 0, one turn on.
        let next = if k == rays {
            Ray { angle: first.angle + TAU, ..first }
        } else if k > span {
            previous
        } else {
            cast(base(k, &previous))
        };
        let mut halfway: Option<Ray> = None;
        stack.push((previous, next, 0));
        while let Some((r0, r1, depth)) = stack.pop() {
            if let Some(Stop { cell: (cx, cy), came_from, .. }) =
                r0.hit.filter(|s| last_recorded != Some((s.cell, s.came_from)))
            {
                last_recorded = Some(((cx, cy), came_from));
                out.push(cy as usize * cols + cx as usize);
                // Wall cells bordering the last free cell are seen too: an inner corner's cell
                // can only be entered through its two wall neighbours, so no ray stops in it.
                if let Some((fx, fy)) = came_from {
                    // The beam ends within the wall's first layer, not at its first cell's edge:
                    // the cell behind the stop along the step that entered it is seen too when it
                    // is a wall. An occupancy grid marks every cell where beams ended, so a wall
                    // two grid cells thick has two rows of points, and the far one can lie in the
                    // next raster cell; hiding it moved fits on real logs 3-4 cm towards the
                    // sensor. The far face of a thick wall lies beyond free cells and stays hidden.
                    let (bx, by) = (2 * cx - fx, 2 * cy - fy);
                    if raster.is_wall(bx, by) {
                        out.push(by as usize * cols + bx as usize);
                    }
                    for (nx, ny) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                        let (x, y) = (fx + nx, fy + ny);
                        if (x, y) != (cx, cy) && raster.is_wall(x, y) {
                            out.push(y as usize * cols + x as usize);
                        }
                    }
                }
            }
            if touching(raster, r0.hit, r1.hit)
                || depth >= MAX_REFINEMENT_DEPTH
                || r1.angle - r0.angle <= min_gap
            {
                continue;
            }
            let mid = cast(Ray::between(&r0, &r1));
            if depth == 0 {
                halfway = Some(mid);
            }
            // Right half first onto the stack so the left half is handled next; the left half
            // records `r0` again, which the final dedup removes.
            stack.push((mid, r1, depth + 1));
            stack.push((r0, mid, depth + 1));
        }
        if k > span {
            break;
        }
        if let Some((out_ranges, surface)) = ranges.as_mut() {
            let next_range = surface.range(&next);
            out_ranges.push(previous_range);
            out_ranges.push(match (halfway, previous.hit, next.hit) {
                (Some(mid), _, _) => surface.range(&mid),
                (None, Some(p), Some(q)) if adjacent(raster, p.cell, q.cell) => {
                    0.5 * (previous_range + next_range)
                }
                (None, None, None) => f64::INFINITY,
                // Not refined for want of angle (a range of kilometres): cast it for its range.
                _ => surface.range(&cast(Ray::between(&previous, &next))),
            });
            previous_range = next_range;
        }
        previous = next;
    }
    if span < rays {
        // An arc's last base ray has no gap after it.
        if let Some((out_ranges, _)) = ranges.as_mut() {
            out_ranges.push(previous_range);
        }
    }
    out.sort_unstable();
    out.dedup();
}

/// Where [`visible_cells`] writes the range of each direction, and the plan points (those the
/// raster was built from) the ranges are measured to.
pub struct RangeOutput<'a> {
    /// Cleared, then one range per direction, metres.
    pub ranges: &'a mut Vec<f64>,
    /// The plan's wall points, map frame, metres.
    pub points: &'a [[f64; 2]],
}
/// Whether no wall cell can lie between the stops of two neighbouring rays: both stopped in the
/// same or [`adjacent`] cells, or neither stopped.
fn touching(raster: &WallRaster, h0: Hit, h1: Hit) -> bool {
    match (h0, h1) {
        (Some(p), Some(q)) => adjacent(raster, p.cell, q.cell),
        (None, None) => true,
        _ => false,
    }
}

/// Whether rays between two that stopped in cells `p` and `q` can only stop in `p` or `q`: the
/// cells are the same, share an edge, or touch at a corner with both cells beside that corner free
/// (a diagonal wall); otherwise a wall cell may lie between them.
fn adjacent(raster: &WallRaster, p: (i64, i64), q: (i64, i64)) -> bool {
    let (dx, dy) = ((p.0 - q.0).abs(), (p.1 - q.1).abs());
    match (dx, dy) {
        (0, 0) | (0, 1) | (1, 0) => true,
        (1, 1) => !raster.is_wall(p.0, q.1) && !raster.is_wall(q.0, p.1),
        _ => false,
    }
}
/// Two neighbouring rays to refine between, and the refinement depth.
type Bracket = (Ray, Ray, u32);

#[cfg(test)]
mod tests;
