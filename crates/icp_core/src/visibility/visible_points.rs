//! Which wall points a range sensor can see from a position: rays cast cell by cell
//! (Amanatides-Woo traversal) through the plan's [`WallRaster`], each stopping at the first wall
//! cell. The points in the cells where rays stop are the visible wall faces; the far face of a
//! wall, a wall's thickness behind the near one, is hidden, so the ICP cannot lock onto it.

use crate::error::{invalid, Result};
use crate::grids::clearance::{BeamAxis, SKIP_MIN_CLEARANCE};
use crate::grids::wall_raster::WallRaster;
use std::f64::consts::TAU;

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
    visible_cells(raster, position, max_range, RayFan::circle(0.0, BASE_RAYS), &mut hit_cells, None);
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
    let cast = |ray: Ray| Ray { hit: caster.cast(ray.dir), ..ray };
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

/// The range along a ray to the wall it stopped at: the along-ray distance of the wall point in
/// the stop's cell that lies nearest the ray (the cell only says the wall is somewhere within it).
struct SurfaceRanges<'a> {
    raster: &'a WallRaster,
    points: &'a [[f64; 2]],
    position: [f64; 2],
    /// The last cell looked up and its points: neighbouring rays mostly stop in the same cell.
    cached: Option<(usize, &'a [u32])>,
}

impl<'a> SurfaceRanges<'a> {
    /// Metres along `ray` to its wall, `inf` when it stopped at none.
    fn range(&mut self, ray: &Ray) -> f64 {
        let Some(stop) = ray.hit else { return f64::INFINITY };
        let (cols, _) = self.raster.shape();
        let cell = stop.cell.1 as usize * cols + stop.cell.0 as usize;
        let in_cell = match self.cached {
            Some((c, points)) if c == cell => points,
            _ => {
                let points = self.raster.points_in_cell(cell);
                self.cached = Some((cell, points));
                points
            }
        };
        let (dx, dy) = ray.dir;
        let mut best: Option<(f64, f64)> = None;
        for &i in in_cell {
            let Some(p) = self.points.get(i as usize) else { continue };
            let (px, py) = (p[0] - self.position[0], p[1] - self.position[1]);
            let lateral = (px * dy - py * dx).abs();
            if best.is_none_or(|(nearest, _)| lateral < nearest) {
                best = Some((lateral, px * dx + py * dy));
            }
        }
        // No point of the given ones in the cell (points that are not the raster's): the cell's
        // centre, projected on the ray, is the unbiased guess of where the ray meets its wall.
        best.map_or_else(|| self.centre_along(stop.cell, ray.dir), |(_, along)| along)
    }

    /// Metres along the unit direction `(dx, dy)` from the cast's position to the centre of `cell`,
    /// projected on the ray.
    fn centre_along(&self, cell: (i64, i64), (dx, dy): (f64, f64)) -> f64 {
        let (res, origin) = (self.raster.resolution(), self.raster.origin());
        let centre = [origin[0] + (cell.0 as f64 + 0.5) * res, origin[1] + (cell.1 as f64 + 0.5) * res];
        (centre[0] - self.position[0]) * dx + (centre[1] - self.position[1]) * dy
    }
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

/// A raster cell (col, row).
type Cell = (i64, i64);

/// Where a ray stops: the first wall cell it reaches.
#[derive(Clone, Copy, Debug)]
struct Stop {
    /// The wall cell (col, row).
    cell: (i64, i64),
    /// The free cell the ray left to enter it; None when that was the start cell.
    came_from: Option<(i64, i64)>,
}

/// The stop of a ray, `None` when it meets no wall cell within range.
type Hit = Option<Stop>;

/// One ray of a cast: its map angle (radians), unit direction and stop.
#[derive(Clone, Copy, Debug)]
struct Ray {
    angle: f64,
    dir: (f64, f64),
    hit: Hit,
}

impl Ray {
    /// The ray halfway between `a` and `b` (less than half a turn apart), not yet cast: its
    /// direction is the normalised sum of theirs, with no trigonometry.
    fn between(a: &Ray, b: &Ray) -> Ray {
        let (x, y) = (a.dir.0 + b.dir.0, a.dir.1 + b.dir.1);
        // Two unit vectors less than half a turn apart: their sum is neither tiny nor huge, so
        // the plain root (a fraction of `hypot`'s cost) is exact enough.
        let norm = (x * x + y * y).sqrt();
        Ray { angle: 0.5 * (a.angle + b.angle), dir: (x / norm, y / norm), hit: None }
    }
}

/// Two neighbouring rays to refine between, and the refinement depth.
type Bracket = (Ray, Ray, u32);

/// Casts single rays from one position through the raster, in cell units.
struct RayCaster<'a> {
    raster: &'a WallRaster,
    origin: (f64, f64),
    max_t: f64,
    shape: (usize, usize),
}

impl RayCaster<'_> {
    /// The first wall cell (col, row) along the unit direction `(dx, dy)`, if any: after the
    /// start cell when the position is inside the raster, from the cell where the ray enters it
    /// otherwise.
    #[inline]
    fn cast(&self, (dx, dy): (f64, f64)) -> Hit {
        let (cols, rows) = (self.shape.0 as f64, self.shape.1 as f64);
        let (ox, oy) = self.origin;
        if (0.0..cols).contains(&ox) && (0.0..rows).contains(&oy) {
            let start = (ox.floor() as i64, oy.floor() as i64);
            return first_wall_cell(self.raster, self.origin, start, (dx, dy), self.max_t, self.shape);
        }
        // Outside: clip the ray to the raster's box (slab method) and start where it enters.
        let (mut t_in, mut t_out) = (0.0f64, self.max_t);
        for (o, d, size) in [(ox, dx, cols), (oy, dy, rows)] {
            if d == 0.0 {
                if !(0.0..size).contains(&o) {
                    return None;
                }
            } else {
                let (a, b) = ((0.0 - o) / d, (size - o) / d);
                t_in = t_in.max(a.min(b));
                t_out = t_out.min(a.max(b));
            }
        }
        if t_in > t_out {
            return None;
        }
        let entry = (ox + dx * t_in, oy + dy * t_in);
        let cell = (
            (entry.0.floor() as i64).clamp(0, self.shape.0 as i64 - 1),
            (entry.1.floor() as i64).clamp(0, self.shape.1 as i64 - 1),
        );
        if self.raster.is_wall(cell.0, cell.1) {
            return Some(Stop { cell, came_from: None });
        }
        first_wall_cell(self.raster, entry, cell, (dx, dy), self.max_t - t_in, self.shape)
    }
}

/// Walks the cells along one ray (cell units) and returns the first wall cell after the start, with
/// the free cell the ray left to enter it (None when that was the start cell, which may be a wall)
/// and the parameter from `(ox, oy)` where it entered.
/// The walk is 4-connected (a ray exactly through a cell corner steps along y first), so it cannot
/// slip between the 8-connected cells of a diagonal wall. It crosses open space in jumps (see
/// [`crate::grids::clearance`]), landing in the cells the step-by-step walk reaches.
#[inline]
fn first_wall_cell(
    raster: &WallRaster,
    (ox, oy): (f64, f64),
    start: (i64, i64),
    (dx, dy): (f64, f64),
    max_t: f64,
    (cols, rows): (usize, usize),
) -> Hit {
    let ax = BeamAxis::new(ox, start.0, dx);
    let ay = BeamAxis::new(oy, start.1, dy);
    let (mut i, mut j) = (0i64, 0i64);
    let (mut tx, mut ty) = (ax.t(0), ay.t(0));
    let (mut cx, mut cy) = start;
    let outside = |cx: i64, cy: i64| cx < 0 || cy < 0 || cx as usize >= cols || cy as usize >= rows;
    let mut t_cur = 0.0;
    let mut clearance = raster.clearance(start.0 as usize, start.1 as usize);
    // A ray crosses at most cols + rows cell borders inside the raster: a hard bound on the walk,
    // whatever rounding does to the crossing times.
    for _ in 0..cols + rows + 2 {
        if clearance >= SKIP_MIN_CLEARANCE {
            let t_jump = t_cur + f64::from(clearance - 2);
            if t_jump > max_t {
                return None;
            }
            i = ax.crossings_before(t_jump).max(i);
            j = ay.crossings_before(t_jump).max(j);
            (tx, ty) = (ax.t(i), ay.t(j));
            (cx, cy) = (start.0 + ax.step * i, start.1 + ay.step * j);
            if outside(cx, cy) {
                return None;
            }
        }
        let before = (cx, cy);
        let t = if tx < ty {
            let t = tx;
            i += 1;
            cx += ax.step;
            tx = ax.t(i);
            t
        } else {
            let t = ty;
            j += 1;
            cy += ay.step;
            ty = ay.t(j);
            t
        };
        if t > max_t || outside(cx, cy) {
            return None;
        }
        clearance = raster.clearance(cx as usize, cy as usize);
        if clearance == 0 {
            let came_from = (before != start || !raster.is_wall(start.0, start.1)).then_some(before);
            return Some(Stop { cell: (cx, cy), came_from });
        }
        t_cur = t;
    }
    None
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
}
