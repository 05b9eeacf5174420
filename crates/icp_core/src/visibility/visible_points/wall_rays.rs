//! One ray of a visibility cast: from a position through the [`WallRaster`], cell by cell
//! (Amanatides-Woo, 4-connected, jumping across open space), to the first wall cell.

use crate::grids::clearance::{BeamAxis, SKIP_MIN_CLEARANCE};
use crate::grids::wall_raster::WallRaster;

/// A raster cell (col, row).
pub(super) type Cell = (i64, i64);

/// Where a ray stops: the first wall cell it reaches.
#[derive(Clone, Copy, Debug)]
pub(super) struct Stop {
    /// The wall cell (col, row).
    pub(super) cell: (i64, i64),
    /// The free cell the ray left to enter it; None when that was the start cell.
    pub(super) came_from: Option<(i64, i64)>,
}

/// The stop of a ray, `None` when it meets no wall cell within range.
pub(super) type Hit = Option<Stop>;

/// One ray of a cast: its map angle (radians), unit direction and stop.
#[derive(Clone, Copy, Debug)]
pub(super) struct Ray {
    pub(super) angle: f64,
    pub(super) dir: (f64, f64),
    pub(super) hit: Hit,
}

impl Ray {
    /// The ray halfway between `a` and `b` (less than half a turn apart), not yet cast: its
    /// direction is the normalised sum of theirs, with no trigonometry.
    pub(super) fn between(a: &Ray, b: &Ray) -> Ray {
        let (x, y) = (a.dir.0 + b.dir.0, a.dir.1 + b.dir.1);
        // Two unit vectors less than half a turn apart: their sum is neither tiny nor huge, so
        // the plain root (a fraction of `hypot`'s cost) is exact enough.
        let norm = (x * x + y * y).sqrt();
        Ray { angle: 0.5 * (a.angle + b.angle), dir: (x / norm, y / norm), hit: None }
    }
}
/// Casts single rays from one position through the raster, in cell units.
pub(super) struct RayCaster<'a> {
    pub(super) raster: &'a WallRaster,
    pub(super) origin: (f64, f64),
    pub(super) max_t: f64,
    pub(super) shape: (usize, usize),
}

impl RayCaster<'_> {
    /// The first wall cell (col, row) along the unit direction `(dx, dy)`, if any: after the
    /// start cell when the position is inside the raster, from the cell where the ray enters it
    /// otherwise.
    #[inline]
    pub(super) fn cast(&self, dir: (f64, f64)) -> Hit {
        self.cast_within(dir, self.max_t)
    }

    /// As [`Self::cast`], within `max_t` cells (at most the caster's own).
    #[inline]
    pub(super) fn cast_within(&self, (dx, dy): (f64, f64), max_t: f64) -> Hit {
        let max_t = max_t.min(self.max_t);
        let (cols, rows) = (self.shape.0 as f64, self.shape.1 as f64);
        let (ox, oy) = self.origin;
        if (0.0..cols).contains(&ox) && (0.0..rows).contains(&oy) {
            let start = (ox.floor() as i64, oy.floor() as i64);
            return first_wall_cell(self.raster, self.origin, start, (dx, dy), max_t, self.shape);
        }
        // Outside: clip the ray to the raster's box (slab method) and start where it enters.
        let (mut t_in, mut t_out) = (0.0f64, max_t);
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
        first_wall_cell(self.raster, entry, cell, (dx, dy), max_t - t_in, self.shape)
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
