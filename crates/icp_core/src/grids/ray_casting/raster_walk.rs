//! A beam's walk through an [`OccupancyRaster`], cell by cell (Amanatides-Woo) with the corner rule
//! and jumps across free cells, to the first occupied cell; and its entry into the raster from a
//! sensor outside it.

use crate::grids::clearance::{BeamAxis, SKIP_MIN_CLEARANCE};
use crate::grids::ray_casting::occupancy_raster::OccupancyRaster;

/// Grid-line crossings closer than this along a beam (in cells) are one crossing of a cell corner.
pub const CORNER_TIE: f64 = 1e-9;

/// Parameter (cells along the beam) where the beam from `g` (cell units, inside the raster, in the
/// free cell `start`) along the unit direction `(dx, dy)` enters its first occupied cell, or `inf`
/// when it leaves the raster or passes `t_max` first.
#[inline]
pub(super) fn walk(
    raster: &OccupancyRaster,
    g: (f64, f64),
    start: (i64, i64),
    (dx, dy): (f64, f64),
    t_max: f64,
) -> f64 {
    let ax = BeamAxis::new(g.0, start.0, dx);
    let ay = BeamAxis::new(g.1, start.1, dy);
    let (cols, rows) = (raster.cols, raster.rows);
    let (mut i, mut j) = (0i64, 0i64);
    let (mut tx, mut ty) = (ax.t(0), ay.t(0));
    let (mut cx, mut cy) = start;
    let mut t_cur = 0.0;
    let mut clearance = raster.clearance[start.1 as usize * cols + start.0 as usize];
    // Every iteration moves the beam into the next cell; it crosses at most cols + rows grid lines
    // inside the raster. A hard bound on the loop, whatever rounding does.
    for _ in 0..cols + rows + 4 {
        if clearance >= SKIP_MIN_CLEARANCE {
            // Every cell within clearance - 1 of this one is free, so the beam cannot enter an
            // occupied cell before t_cur + clearance - 1; jump to one cell short of that, to just
            // after the last crossing before it.
            let t_jump = t_cur + f64::from(clearance - 2);
            if t_jump > t_max {
                return f64::INFINITY;
            }
            i = ax.crossings_before(t_jump).max(i);
            j = ay.crossings_before(t_jump).max(j);
            (tx, ty) = (ax.t(i), ay.t(j));
            (cx, cy) = (start.0 + ax.step * i, start.1 + ay.step * j);
            if cx < 0 || cy < 0 || cx as usize >= cols || cy as usize >= rows {
                return f64::INFINITY;
            }
        }
        // The next crossing; a crossing of the other axis within CORNER_TIE after it is the same
        // corner, so the beam moves diagonally and the two grazed cells are not entered. (A
        // branch-free version of this step measured slower: it puts the int-to-float conversion
        // of both counters on the loop's critical path.)
        let t = if tx <= ty {
            let corner = ty <= tx + CORNER_TIE;
            let t = tx;
            i += 1;
            cx += ax.step;
            tx = ax.t(i);
            if corner {
                j += 1;
                cy += ay.step;
                ty = ay.t(j);
            }
            t
        } else {
            let corner = tx <= ty + CORNER_TIE;
            let t = ty;
            j += 1;
            cy += ay.step;
            ty = ay.t(j);
            if corner {
                i += 1;
                cx += ax.step;
                tx = ax.t(i);
            }
            t
        };
        if t > t_max || cx < 0 || cy < 0 || cx as usize >= cols || cy as usize >= rows {
            return f64::INFINITY;
        }
        clearance = raster.clearance[cy as usize * cols + cx as usize];
        if clearance == 0 {
            return t;
        }
        t_cur = t;
    }
    f64::INFINITY
}

/// [`walk`] for a sensor at `g` (cell units) outside the raster: clips the beam to the raster's box
/// (slab method) and walks on from where it enters; the parameter returned counts from `g`.
pub(super) fn enter_and_walk(
    raster: &OccupancyRaster,
    g: (f64, f64),
    (dx, dy): (f64, f64),
    t_max: f64,
) -> f64 {
    let (mut t_in, mut t_out) = (0.0f64, t_max);
    for (o, d, size) in [(g.0, dx, raster.cols as f64), (g.1, dy, raster.rows as f64)] {
        if d == 0.0 {
            if !(0.0..size).contains(&o) {
                return f64::INFINITY;
            }
        } else {
            let (a, b) = ((0.0 - o) / d, (size - o) / d);
            t_in = t_in.max(a.min(b));
            t_out = t_out.min(a.max(b));
        }
    }
    if t_in > t_out {
        return f64::INFINITY;
    }
    let entry = (g.0 + dx * t_in, g.1 + dy * t_in);
    let cell = (
        (entry.0.floor() as i64).clamp(0, raster.cols as i64 - 1),
        (entry.1.floor() as i64).clamp(0, raster.rows as i64 - 1),
    );
    if raster.is_occupied(cell.1, cell.0) {
        return t_in;
    }
    t_in + walk(raster, entry, cell, (dx, dy), t_max - t_in)
}
