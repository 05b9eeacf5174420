//! The occupancy raster that simulated beams are cast through, with every free cell's clearance
//! (its distance to the nearest occupied cell) so that beams cross empty space in jumps.

use crate::error::{invalid, Result, MAX_COORDINATE};
use crate::grids::clearance::chebyshev_clearance;

/// Finest raster resolution accepted, metres per cell (keeps cell indices exact in an `f64`).
pub const MIN_RESOLUTION: f64 = 1e-6;
/// Most cells an [`OccupancyRaster`] may have.
pub const MAX_CELLS: usize = crate::grids::wall_raster::MAX_RASTER_CELLS;

/// An occupancy grid to cast beams through.
///
/// Cells are row-major and the ROW INDEX GROWS WITH +y: row 0 is the lowest y (the convention of
/// `planicp.sim.Floor`, not image order). Cell `(row, col)` covers
/// `x in [origin_x + col * res, origin_x + (col + 1) * res)` and the same for `y` with `row`.
/// Everything outside the raster is free.
#[derive(Debug, Clone)]
pub struct OccupancyRaster {
    pub(super) rows: usize,
    pub(super) cols: usize,
    pub(super) resolution: f64,
    pub(super) origin: [f64; 2],
    /// Per cell: 0 when occupied, else the Chebyshev distance in cells to the nearest occupied cell
    /// (1 next to one), capped at 255. Every cell within `clearance - 1` cells is free.
    pub(super) clearance: Vec<u8>,
}

impl OccupancyRaster {
    /// A raster of `rows x cols` cells (`cells[row * cols + col]`, true = occupied) with square
    /// cells of `resolution` metres and `origin` the map-frame (x, y) of the lower-left CORNER of
    /// cell (0, 0).
    ///
    /// Errors: an empty shape, more than [`MAX_CELLS`] cells, `cells.len() != rows * cols`, a
    /// resolution that is not finite or below [`MIN_RESOLUTION`], an origin or extent that is not
    /// finite or reaches beyond [`MAX_COORDINATE`].
    pub fn new(
        cells: Vec<bool>,
        rows: usize,
        cols: usize,
        resolution: f64,
        origin: [f64; 2],
    ) -> Result<Self> {
        if rows == 0 || cols == 0 {
            return Err(invalid(
                "raster shape",
                format!("({rows} rows, {cols} cols)"),
                "needs at least one row and one column",
            ));
        }
        let n = rows.checked_mul(cols).filter(|&n| n <= MAX_CELLS).ok_or_else(|| {
            invalid("raster shape", format!("({rows} rows, {cols} cols)"), "may have at most 2^28 cells")
        })?;
        if cells.len() != n {
            return Err(invalid(
                "raster cells",
                format!("{} values for {rows} rows x {cols} cols", cells.len()),
                "must hold exactly rows * cols values, row-major",
            ));
        }
        if !(resolution.is_finite() && resolution >= MIN_RESOLUTION) {
            return Err(invalid(
                "raster resolution",
                resolution,
                "must be a finite number of metres >= 1e-6",
            ));
        }
        let far = [origin[0] + cols as f64 * resolution, origin[1] + rows as f64 * resolution];
        let within = |v: f64| v.is_finite() && v.abs() <= MAX_COORDINATE;
        if !(within(origin[0]) && within(origin[1])) {
            return Err(invalid("raster origin", format!("{origin:?}"), "must be finite, within +-1e9 m"));
        }
        if !(within(far[0]) && within(far[1])) {
            return Err(invalid(
                "raster extent",
                format!("{origin:?} to {far:?}"),
                "must lie within +-1e9 m",
            ));
        }
        let clearance = chebyshev_clearance(&cells, rows, cols);
        Ok(Self { rows, cols, resolution, origin, clearance })
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
        self.origin
    }

    /// Whether cell `(row, col)` is occupied; outside the raster is free.
    pub fn is_occupied(&self, row: i64, col: i64) -> bool {
        self.index(col, row).is_some_and(|k| self.clearance[k] == 0)
    }

    /// Number of occupied cells.
    pub fn occupied_cells(&self) -> usize {
        self.clearance.iter().filter(|&&c| c == 0).count()
    }

    /// Linear index of cell (col, row), `None` outside.
    #[inline]
    fn index(&self, col: i64, row: i64) -> Option<usize> {
        let (c, r) = (usize::try_from(col).ok()?, usize::try_from(row).ok()?);
        (c < self.cols && r < self.rows).then_some(r * self.cols + c)
    }
}
