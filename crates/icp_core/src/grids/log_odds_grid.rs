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
//! cell budget; a scan that would need more is refused and the grid is left as it was.

use crate::error::{check_finite, invalid, try_filled, IcpError, Result, MAX_COORDINATE};
use crate::grids::cell_traversal::for_each_cell;

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

    /// Grows the grid so that it holds `sensor` and every end point (lattice cells).
    fn reach(&mut self, sensor: [f64; 2], ends: &[([f64; 2], bool)]) -> Result<()> {
        let mut lo = [i64::MAX; 2];
        let mut hi = [i64::MIN; 2];
        let start = self.cell_units(sensor);
        for &(p, returned) in std::iter::once(&(sensor, false)).chain(ends.iter()) {
            let u = if returned { behind_surface(start, self.cell_units(p)) } else { self.cell_units(p) };
            for a in 0..2 {
                let c = u[a].floor() as i64;
                lo[a] = lo[a].min(c);
                hi[a] = hi[a].max(c);
            }
        }
        let size = [self.cols as i64, self.rows as i64];
        let last = [self.first[0] + size[0] - 1, self.first[1] + size[1] - 1];
        if (0..2).all(|a| lo[a] >= self.first[a] && hi[a] <= last[a]) {
            return Ok(());
        }
        let mut new_first = self.first;
        let mut new_last = last;
        for a in 0..2 {
            let pad = GROWTH_CELLS.max(size[a] / 4);
            if lo[a] < self.first[a] {
                new_first[a] = lo[a] - pad;
            }
            if hi[a] > last[a] {
                new_last[a] = hi[a] + pad;
            }
        }
        let new_cols = (new_last[0] - new_first[0] + 1) as u128;
        let new_rows = (new_last[1] - new_first[1] + 1) as u128;
        let cells = new_cols * new_rows;
        let within = |c: i64| {
            (self.anchor[0].abs().max(self.anchor[1].abs()) + c.unsigned_abs() as f64 * self.resolution)
                <= MAX_COORDINATE
        };
        let padding_fits = (0..2).all(|a| within(new_first[a]) && within(new_last[a] + 1));
        if cells > self.max_cells as u128 || !padding_fits {
            // Without the padding (which may exceed the cell budget or the coordinate limit) the
            // scan might still fit: retry with the exact reach.
            let exact_cols = (hi[0].max(last[0]) - lo[0].min(self.first[0]) + 1) as u128;
            let exact_rows = (hi[1].max(last[1]) - lo[1].min(self.first[1]) + 1) as u128;
            if exact_cols * exact_rows > self.max_cells as u128 {
                return Err(IcpError::GridTooLarge {
                    cells: (exact_cols * exact_rows) as f64,
                    limit: self.max_cells,
                    resolution: self.resolution,
                });
            }
            new_first = [lo[0].min(self.first[0]), lo[1].min(self.first[1])];
            new_last = [hi[0].max(last[0]), hi[1].max(last[1])];
        }
        let far = [
            self.anchor[0] + (new_last[0] + 1) as f64 * self.resolution,
            self.anchor[1] + (new_last[1] + 1) as f64 * self.resolution,
        ];
        let near = [
            self.anchor[0] + new_first[0] as f64 * self.resolution,
            self.anchor[1] + new_first[1] as f64 * self.resolution,
        ];
        if !near.iter().chain(&far).all(|v| v.is_finite() && v.abs() <= EXTENT_LIMIT) {
            return Err(invalid(
                "grown grid extent",
                format!("{near:?} to {far:?}"),
                "must lie within +-2e9 m (points within +-1e9 m)",
            ));
        }
        let cols = (new_last[0] - new_first[0] + 1) as usize;
        let rows = (new_last[1] - new_first[1] + 1) as usize;
        let mut cells = try_filled(rows * cols, Cell::default(), "the grown occupancy grid's cells")?;
        let (dc, dr) = ((self.first[0] - new_first[0]) as usize, (self.first[1] - new_first[1]) as usize);
        for r in 0..self.rows {
            let src = r * self.cols..(r + 1) * self.cols;
            let dst = (r + dr) * cols + dc;
            cells[dst..dst + self.cols].copy_from_slice(&self.cells[src]);
        }
        self.cells = cells;
        self.first = new_first;
        self.rows = rows;
        self.cols = cols;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RES: f64 = 0.1;

    fn grid(rows: usize, cols: usize) -> LogOddsGrid {
        LogOddsGrid::new(rows, cols, RES, [0.0, 0.0], OccupancyModel::default(), 1 << 20).unwrap()
    }

    fn cell(g: &LogOddsGrid, c: usize, r: usize) -> (f32, bool) {
        let k = r * g.shape().1 + c;
        (g.log_odds().nth(k).unwrap(), g.observed().nth(k).unwrap())
    }

    #[test]
    fn one_beam_marks_the_cells_before_its_end_free_and_its_end_occupied() {
        let mut g = grid(10, 10);
        // Sensor in cell (1, 5), return in cell (6, 5).
        g.integrate([0.15, 0.55], &[[0.65, 0.55]], &[], 30.0).unwrap();
        let m = OccupancyModel::default();
        for r in 0..10 {
            for c in 0..10 {
                let (l, seen) = cell(&g, c, r);
                let expected = if r == 5 && (1..6).contains(&c) {
                    m.miss
                } else if r == 5 && c == 6 {
                    m.hit
                } else {
                    0.0
                };
                assert_eq!(l, expected, "cell ({c}, {r})");
                assert_eq!(seen, expected != 0.0, "cell ({c}, {r})");
            }
        }
        assert_eq!(g.scans(), 1);
    }

    #[test]
    fn a_cell_is_updated_once_per_scan_and_hits_win() {
        let mut g = grid(10, 10);
        let m = OccupancyModel::default();
        // Two beams through the same cells; the second ends where the first passes.
        g.integrate([0.15, 0.55], &[[0.85, 0.55], [0.45, 0.55]], &[], 30.0).unwrap();
        assert_eq!(cell(&g, 2, 5).0, m.miss);
        assert_eq!(cell(&g, 4, 5).0, m.hit, "a hit of this scan is not cleared by another beam");
        assert_eq!(cell(&g, 8, 5).0, m.hit);
        // A second scan updates again, with clamping.
        for _ in 0..100 {
            g.integrate([0.15, 0.55], &[[0.85, 0.55]], &[], 30.0).unwrap();
        }
        assert_eq!(cell(&g, 8, 5).0, m.max);
        assert_eq!(cell(&g, 4, 5).0, m.min, "later scans saw the cell free");
    }

    #[test]
    fn a_return_on_a_cell_boundary_occupies_the_cell_behind_it() {
        let hit = OccupancyModel::default().hit;
        // From the left, the surface x = 0.5 belongs to column 5; from the right, to column 4.
        let mut g = grid(10, 10);
        g.integrate([0.15, 0.55], &[[0.5, 0.55]], &[], 30.0).unwrap();
        assert_eq!(cell(&g, 5, 5).0, hit);
        assert!(cell(&g, 4, 5).0 < 0.0);
        let mut g = grid(10, 10);
        g.integrate([0.95, 0.55], &[[0.5, 0.55]], &[], 30.0).unwrap();
        assert_eq!(cell(&g, 4, 5).0, hit);
        assert!(cell(&g, 5, 5).0 < 0.0);
    }

    #[test]
    fn a_beam_without_return_clears_up_to_its_end() {
        let mut g = grid(10, 10);
        g.integrate([0.15, 0.55], &[], &[[0.65, 0.55]], 30.0).unwrap();
        let m = OccupancyModel::default();
        for c in 1..=6 {
            assert_eq!(cell(&g, c, 5).0, m.miss);
        }
        assert!(!cell(&g, 7, 5).1);
    }

    #[test]
    fn a_return_beyond_max_range_clears_up_to_max_range_only() {
        let mut g = grid(10, 10);
        g.integrate([0.15, 0.55], &[[0.95, 0.55]], &[], 0.32).unwrap();
        let m = OccupancyModel::default();
        // Cut at x = 0.47: cells 1..=4 cleared, nothing occupied.
        for c in 1..=4 {
            assert_eq!(cell(&g, c, 5).0, m.miss, "cell {c}");
        }
        for c in 5..10 {
            assert!(!cell(&g, c, 5).1, "cell {c}");
        }
    }

    #[test]
    fn the_grid_grows_keeping_its_lattice_and_contents() {
        let mut g = grid(4, 4);
        g.integrate([0.15, 0.15], &[[0.35, 0.15]], &[], 30.0).unwrap();
        g.integrate([0.15, 0.15], &[[-0.55, 1.25]], &[], 30.0).unwrap();
        let (rows, cols) = g.shape();
        assert!(rows > 4 && cols > 4);
        let o = g.origin();
        // Still on the lattice through (0, 0).
        for v in o {
            assert!(((v / RES).round() * RES - v).abs() < 1e-12, "origin {o:?}");
        }
        // The first scan's hit is still at (0.35, 0.15).
        let c = ((0.35 - o[0]) / RES).floor() as usize;
        let r = ((0.15 - o[1]) / RES).floor() as usize;
        assert_eq!(g.log_odds().nth(r * cols + c), Some(OccupancyModel::default().hit));
        let c = ((-0.55 - o[0]) / RES).floor() as usize;
        let r = ((1.25 - o[1]) / RES).floor() as usize;
        assert_eq!(g.log_odds().nth(r * cols + c), Some(OccupancyModel::default().hit));
    }

    #[test]
    fn a_scan_beyond_the_cell_budget_is_refused_and_the_grid_kept() {
        let mut g = LogOddsGrid::new(10, 10, RES, [0.0, 0.0], OccupancyModel::default(), 400).unwrap();
        g.integrate([0.15, 0.55], &[[0.65, 0.55]], &[], 30.0).unwrap();
        let before: Vec<f32> = g.log_odds().collect();
        let err = g.integrate([0.15, 0.55], &[[25.0, 0.55]], &[], 30.0).unwrap_err();
        assert!(matches!(err, IcpError::GridTooLarge { limit: 400, .. }), "{err}");
        assert!(g.log_odds().eq(before.iter().copied()));
        assert_eq!(g.shape(), (10, 10));
        assert_eq!(g.scans(), 1);
        // Growth that fits the budget only without padding is still done.
        g.integrate([0.15, 0.55], &[[1.45, 0.55]], &[], 30.0).unwrap();
        assert_eq!(g.shape(), (10, 15));
    }

    #[test]
    fn a_return_on_the_coordinate_limit_is_integrated() {
        // The cell behind a surface at -1e9 m starts beyond the limit (found by the fuzz target).
        let mut g = LogOddsGrid::new(20, 20, RES, [-1e9, 0.0], OccupancyModel::default(), 1 << 20).unwrap();
        g.integrate([-1e9 + 0.5, 1.05], &[[-1e9, 1.05]], &[], 30.0).unwrap();
        assert_eq!(g.scans(), 1);
        assert!(g.origin()[0] < -1e9);
    }

    #[test]
    fn bad_input_is_refused() {
        let mut g = grid(4, 4);
        assert!(g.integrate([f64::NAN, 0.0], &[], &[], 30.0).is_err());
        assert!(g.integrate([0.0, 0.0], &[[0.1, f64::INFINITY]], &[], 30.0).is_err());
        assert!(g.integrate([0.0, 0.0], &[], &[[2e9, 0.0]], 30.0).is_err());
        assert!(g.integrate([0.0, 0.0], &[], &[], 0.0).is_err());
        assert!(g.integrate([0.0, 0.0], &[], &[], f64::NAN).is_err());
        assert_eq!(g.scans(), 0);
        let m = OccupancyModel::default();
        for bad in [
            OccupancyModel { hit: -1.0, ..m },
            OccupancyModel { miss: 0.0, ..m },
            OccupancyModel { min: 1.0, ..m },
            OccupancyModel { max: f32::NAN, ..m },
        ] {
            assert!(LogOddsGrid::new(4, 4, RES, [0.0, 0.0], bad, 100).is_err());
        }
        assert!(LogOddsGrid::new(0, 4, RES, [0.0, 0.0], m, 100).is_err());
        assert!(LogOddsGrid::new(4, 4, 0.0, [0.0, 0.0], m, 100).is_err());
        assert!(LogOddsGrid::new(4, 4, RES, [f64::NAN, 0.0], m, 100).is_err());
        assert!(LogOddsGrid::new(20, 20, RES, [0.0, 0.0], m, 100).is_err());
    }

    #[test]
    fn a_wall_seen_from_two_poses_stays_occupied() {
        let mut g = grid(40, 40);
        // A wall along x = 3.05 seen from two positions, beams fanning over it.
        for sensor in [[1.0, 1.0], [1.5, 3.0]] {
            let hits: Vec<[f64; 2]> = (0..30).map(|k| [3.05, 0.55 + 0.1 * k as f64]).collect();
            g.integrate(sensor, &hits, &[], 30.0).unwrap();
        }
        let hit = OccupancyModel::default().hit;
        for r in 5..35 {
            assert_eq!(g.log_odds().nth(r * 40 + 30), Some(2.0 * hit), "wall cell row {r}");
        }
    }
}
