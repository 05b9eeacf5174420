//! A log-odds occupancy grid updated by laser scans (the observation layer of the enhanced
//! occupancy grid).
//!
//! Each beam is traced from the sensor to its end point through the cells it passes
//! ([`crate::grids::cell_traversal`]): the cells before the end are evidence of free space (`miss`), the end
//! cell of a beam that returned is evidence of an obstacle (`hit`). A beam with no return clears the
//! cells up to the end point it is given and marks nothing occupied. A return beyond `max_range`
//! is treated as no return and clears only up to `max_range`.
//!
//! Within one scan every cell is updated at most once, and a hit wins over a miss: many beams of a
//! scan pass the cells near the sensor, and counting each would make one scan as strong as a
//! thousand (Cartographer and OctoMap update the same way). Log-odds are clamped to
//! `[min, max]` so that a cell can change its state again after a change in the world.
//!
//! Cells are row-major and the ROW INDEX GROWS WITH +y (nav_msgs/OccupancyGrid order: cell (0, 0)
//! at the origin). The lattice is fixed by an anchor point: every cell boundary lies at
//! `anchor + k * resolution`. The grid grows by whole cells when a scan reaches beyond it, up to a
//! cell budget; a scan that would need more is refused and the grid is left as it was (the submodule
//! `growth`).

use crate::error::{check_finite, invalid, try_filled, IcpError, Result, MAX_COORDINATE};
use crate::grids::cell_traversal::for_each_cell;

mod growth;

/// Finest resolution accepted, metres per cell.
pub const MIN_RESOLUTION: f64 = 1e-4;

/// How far the grid's cells may reach, metres: points are limited to [`MAX_COORDINATE`], but the
/// cell holding a point on that limit (or a return moved behind its surface) may end beyond it.
const EXTENT_LIMIT: f64 = 2.0 * MAX_COORDINATE;

/// Cells added beyond a scan's reach when the grid grows, at least (more on large grids: a
/// quarter of the current side), so that a robot driving out of the grid does not regrow it on
/// every scan.
const GROWTH_CELLS: i64 = 64;

/// Log-odds increments and limits of the occupancy update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OccupancyModel {
    /// Added to a cell where a beam ends with a return (> 0).
    pub hit: f32,
    /// Added to a cell a beam passes through (< 0).
    pub miss: f32,
    /// Lower clamp of the log-odds (< 0).
    pub min: f32,
    /// Upper clamp of the log-odds (> 0).
    pub max: f32,
}

/// `ln(p / (1 - p))`.
pub fn log_odds(p: f64) -> f32 {
    (p / (1.0 - p)).ln() as f32
}

impl Default for OccupancyModel {
    /// OctoMap's sensor model: p(hit) 0.7, p(miss) 0.4, clamped to [0.12, 0.97].
    fn default() -> Self {
        Self { hit: log_odds(0.7), miss: log_odds(0.4), min: log_odds(0.12), max: log_odds(0.97) }
    }
}

impl OccupancyModel {
    /// Checks the signs and finiteness of every field; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        if !(self.hit.is_finite() && self.hit > 0.0) {
            return Err(invalid("hit log-odds", self.hit, "must be finite and > 0 (p(hit) > 0.5)"));
        }
        if !(self.miss.is_finite() && self.miss < 0.0) {
            return Err(invalid("miss log-odds", self.miss, "must be finite and < 0 (p(miss) < 0.5)"));
        }
        if !(self.min.is_finite() && self.min < 0.0) {
            return Err(invalid("minimum log-odds", self.min, "must be finite and < 0"));
        }
        if !(self.max.is_finite() && self.max > 0.0) {
            return Err(invalid("maximum log-odds", self.max, "must be finite and > 0"));
        }
        Ok(())
    }
}

/// How far (cells) a return is moved along its beam before its cell is taken (see [`behind_surface`]).
const SURFACE_NUDGE: f64 = 1e-6;

/// The end point `end` of a return moved a millionth of a cell further along the beam from
/// `start` (cell units): a surface that lies exactly on a cell boundary (walls drawn on a grid,
/// noise-free simulation) then occupies the cell behind it, not the free cell in front of it.
#[inline]
fn behind_surface(start: [f64; 2], end: [f64; 2]) -> [f64; 2] {
    let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
    let length = dx.hypot(dy);
    if length > 0.0 {
        [end[0] + dx / length * SURFACE_NUDGE, end[1] + dy / length * SURFACE_NUDGE]
    } else {
        end
    }
}

/// One cell of the grid.
#[derive(Debug, Clone, Copy, Default)]
struct Cell {
    /// Log-odds of occupancy, 0 when unobserved.
    log_odds: f32,
    /// The number of the last scan that updated the cell, 0 when none has.
    stamp: u32,
}

/// A growing log-odds occupancy grid.
#[derive(Debug, Clone)]
pub struct LogOddsGrid {
    resolution: f64,
    anchor: [f64; 2],
    /// Lattice index of column 0 and row 0 (cells from the anchor).
    first: [i64; 2],
    rows: usize,
    cols: usize,
    /// Row-major cells (log-odds and stamp side by side: a beam reads and writes both).
    cells: Vec<Cell>,
    /// Number of the scan being integrated (scans integrated so far, wrapping).
    scan: u32,
    scans: u64,
    model: OccupancyModel,
    max_cells: usize,
    /// Beam end points of the current scan, map frame, and whether each is a return.
    ends: Vec<([f64; 2], bool)>,
}

impl LogOddsGrid {
    /// An empty grid (every cell unobserved) of `rows x cols` cells of `resolution` metres whose
    /// cell (0, 0) has its lower-left corner at `origin` (map frame, metres). `max_cells` bounds
    /// growth.
    ///
    /// Errors: an empty shape, more than `max_cells` cells, a resolution that is not finite or
    /// below [`MIN_RESOLUTION`], an origin or extent that is not finite or beyond
    /// [`MAX_COORDINATE`], an invalid model.
    pub fn new(
        rows: usize,
        cols: usize,
        resolution: f64,
        origin: [f64; 2],
        model: OccupancyModel,
        max_cells: usize,
    ) -> Result<Self> {
        model.validate()?;
        if !(resolution.is_finite() && resolution >= MIN_RESOLUTION) {
            return Err(invalid("grid resolution", resolution, "must be a finite number of metres >= 1e-4"));
        }
        if rows == 0 || cols == 0 {
            return Err(invalid(
                "grid shape",
                format!("({rows} rows, {cols} cols)"),
                "needs at least one row and one column",
            ));
        }
        let cells = rows.saturating_mul(cols);
        if cells > max_cells {
            return Err(IcpError::GridTooLarge { cells: cells as f64, limit: max_cells, resolution });
        }
        let within = |v: f64| v.is_finite() && v.abs() <= MAX_COORDINATE;
        let far = [origin[0] + cols as f64 * resolution, origin[1] + rows as f64 * resolution];
        if !(within(origin[0]) && within(origin[1]) && within(far[0]) && within(far[1])) {
            return Err(invalid(
                "grid extent",
                format!("{origin:?} to {far:?}"),
                "must be finite and lie within +-1e9 m",
            ));
        }
        Ok(Self {
            resolution,
            anchor: origin,
            first: [0, 0],
            rows,
            cols,
            cells: try_filled(cells, Cell::default(), "the occupancy grid's cells")?,
            scan: 0,
            scans: 0,
            model,
            max_cells,
            ends: Vec::new(),
        })
    }

    /// `(rows, cols)`.
    pub fn shape(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    /// Metres per cell.
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Map-frame (x, y) of the lower-left corner of cell (0, 0), metres.
    pub fn origin(&self) -> [f64; 2] {
        [
            self.anchor[0] + self.first[0] as f64 * self.resolution,
            self.anchor[1] + self.first[1] as f64 * self.resolution,
        ]
    }

    /// The update model.
    pub fn model(&self) -> OccupancyModel {
        self.model
    }

    /// Most cells the grid may grow to.
    pub fn max_cells(&self) -> usize {
        self.max_cells
    }

    /// Scans integrated so far.
    pub fn scans(&self) -> u64 {
        self.scans
    }

    /// Log-odds of every cell, row-major, rows growing with +y (0 where unobserved).
    pub fn log_odds(&self) -> impl Iterator<Item = f32> + '_ {
        self.cells.iter().map(|c| c.log_odds)
    }

    /// Whether each cell has been updated by at least one scan, row-major.
    pub fn observed(&self) -> impl Iterator<Item = bool> + '_ {
        self.cells.iter().map(|c| c.stamp != 0)
    }

    /// Integrates one scan: beams from `sensor` (map frame, metres) to each point of `hits`
    /// (returns) and of `misses` (end points of beams that returned nothing: cleared up to there).
    /// Returns beyond `max_range` metres from the sensor count as no return, cleared up to
    /// `max_range`; no-return end points beyond it are also cut there. Grows the grid first when
    /// the beams reach beyond it.
    ///
    /// Errors (the grid is unchanged): a sensor or point that is not finite or beyond
    /// [`MAX_COORDINATE`], a `max_range` that is not finite and positive, a scan whose reach would
    /// grow the grid beyond its cell budget.
    pub fn integrate(
        &mut self,
        sensor: [f64; 2],
        hits: &[[f64; 2]],
        misses: &[[f64; 2]],
        max_range: f64,
    ) -> Result<()> {
        check_finite("sensor position", &[sensor])?;
        check_finite("scan points", hits)?;
        check_finite("no-return end points", misses)?;
        if !(max_range.is_finite() && max_range > 0.0) {
            return Err(invalid("max_range", max_range, "must be a finite number of metres > 0"));
        }
        let mut ends = std::mem::take(&mut self.ends);
        ends.clear();
        let cut = |p: &[f64; 2]| {
            let (dx, dy) = (p[0] - sensor[0], p[1] - sensor[1]);
            let d = dx.hypot(dy);
            if d > max_range {
                let s = max_range / d;
                ([sensor[0] + dx * s, sensor[1] + dy * s], true)
            } else {
                (*p, false)
            }
        };
        ends.extend(hits.iter().map(|p| {
            let (end, was_cut) = cut(p);
            (end, !was_cut)
        }));
        ends.extend(misses.iter().map(|p| (cut(p).0, false)));
        let grown = self.reach(sensor, &ends);
        if let Err(e) = grown {
            self.ends = ends;
            return Err(e);
        }
        self.next_scan();
        let scan = self.scan;
        let (hit, miss, lo, hi) = (self.model.hit, self.model.miss, self.model.min, self.model.max);
        // Returns first, so that a beam passing a cell another beam of this scan ended in does not
        // clear it.
        let start = self.cell_units(sensor);
        for &(end, returned) in &ends {
            if returned {
                let k = self.index_of(behind_surface(start, self.cell_units(end)));
                let cell = &mut self.cells[k];
                if cell.stamp != scan {
                    cell.stamp = scan;
                    cell.log_odds = (cell.log_odds + hit).min(hi);
                }
            }
        }
        let (cols, first) = (self.cols as i64, self.first);
        for &(end, returned) in &ends {
            let end_cell =
                if returned { behind_surface(start, self.cell_units(end)) } else { self.cell_units(end) };
            let last = (end_cell[0].floor() as i64, end_cell[1].floor() as i64);
            let cells = &mut self.cells;
            for_each_cell(start, end_cell, |c, r| {
                if returned && (c, r) == last {
                    return;
                }
                let cell = &mut cells[((r - first[1]) * cols + (c - first[0])) as usize];
                if cell.stamp != scan {
                    cell.stamp = scan;
                    cell.log_odds = (cell.log_odds + miss).max(lo);
                }
            });
        }
        self.ends = ends;
        self.scans += 1;
        Ok(())
    }

    /// Position in lattice cell units (cell `(c, r)` of the lattice covers `[c, c+1) x [r, r+1)`).
    #[inline]
    fn cell_units(&self, p: [f64; 2]) -> [f64; 2] {
        [(p[0] - self.anchor[0]) / self.resolution, (p[1] - self.anchor[1]) / self.resolution]
    }

    /// Storage index of the cell holding `u` (lattice cell units), which must lie in the grid.
    #[inline]
    fn index_of(&self, u: [f64; 2]) -> usize {
        let (c, r) = (u[0].floor() as i64 - self.first[0], u[1].floor() as i64 - self.first[1]);
        r as usize * self.cols + c as usize
    }

    /// Advances the scan number; after 2^32 - 1 scans, restarts the numbering (keeping which
    /// cells were ever observed).
    fn next_scan(&mut self) {
        if self.scan == u32::MAX {
            for c in &mut self.cells {
                c.stamp = u32::from(c.stamp != 0);
            }
            self.scan = 1;
        }
        self.scan += 1;
    }
}

#[cfg(test)]
mod tests;
