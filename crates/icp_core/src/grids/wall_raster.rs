//! A raster over the plan's extent in which a cell is a wall when a wall point falls into it.
//!
//! Used for ray casting (visibility). Cell `(row, col)` covers
//! `x in [origin_x + col*res, origin_x + (col+1)*res)` and the same for `y` with `row`.
//! Wall points spaced no more than one cell apart along a wall give an 8-connected chain of wall
//! cells, which a cell-by-cell ray traversal cannot slip through.

use crate::error::{check_finite, invalid, IcpError, Result};
use crate::grids::bounding_box::bounding_box;
use crate::grids::clearance::chebyshev_clearance;

/// Most cells a raster may have (one byte each plus the point index).
pub const MAX_RASTER_CELLS: usize = 256 * 1024 * 1024;

/// Occupancy raster of wall points plus, for every wall cell, the points inside it.
#[derive(Debug, Clone)]
pub struct WallRaster {
    resolution: f64,
    origin: [f64; 2],
    cols: usize,
    rows: usize,
    /// Per cell: 0 for a wall cell, else the Chebyshev distance in cells to the nearest wall cell
    /// (see [`crate::grids::clearance`]).
    clearance: Vec<u8>,
    /// Cell index of every point, sorted ascending; `point_of_slot` holds the matching point index.
    cell_of_slot: Vec<u32>,
    point_of_slot: Vec<u32>,
}

impl WallRaster {
    /// Rasterises `points` at `resolution` metres per cell, with a one-cell free margin.
    ///
    /// Errors: a resolution that is not positive and finite, no points, a point that is not
    /// finite or beyond [`crate::error::MAX_COORDINATE`], a raster over [`MAX_RASTER_CELLS`].
    pub fn new(points: &[[f64; 2]], resolution: f64) -> Result<Self> {
        if !(resolution.is_finite() && resolution > 0.0) {
            return Err(invalid(
                "raster resolution",
                resolution,
                "must be a positive finite number of metres",
            ));
        }
        if points.is_empty() {
            return Err(IcpError::Empty { what: "plan" });
        }
        // A NaN would be skipped by the bounds and then fall outside the raster.
        check_finite("plan", points)?;
        let (lo, hi) = bounding_box(points);
        let origin = [lo[0] - resolution, lo[1] - resolution];
        let cols_f = ((hi[0] - origin[0]) / resolution).floor() + 2.0;
        let rows_f = ((hi[1] - origin[1]) / resolution).floor() + 2.0;
        let cells = cols_f * rows_f;
        if !(cells.is_finite() && cells <= MAX_RASTER_CELLS as f64) {
            return Err(IcpError::RasterTooLarge {
                what: "visibility raster",
                resolution,
                cells,
                limit: MAX_RASTER_CELLS,
            });
        }
        let (cols, rows) = (cols_f as usize, rows_f as usize);
        let mut raster = Self {
            resolution,
            origin,
            cols,
            rows,
            clearance: Vec::new(),
            cell_of_slot: Vec::with_capacity(points.len()),
            point_of_slot: Vec::with_capacity(points.len()),
        };
        let mut slots: Vec<(u32, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let cell = raster.cell_of(*p).expect("every plan point lies inside its own raster");
                (cell as u32, i as u32)
            })
            .collect();
        slots.sort_unstable();
        let mut occupied = vec![false; cols * rows];
        for &(cell, point) in &slots {
            occupied[cell as usize] = true;
            raster.cell_of_slot.push(cell);
            raster.point_of_slot.push(point);
        }
        raster.clearance = chebyshev_clearance(&occupied, rows, cols);
        Ok(raster)
    }

    /// Metres per cell.
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Map-frame position of the lower-left corner of cell (0, 0), metres.
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }

    /// `(cols, rows)`.
    pub fn shape(&self) -> (usize, usize) {
        (self.cols, self.rows)
    }

    /// Linear index (`row * cols + col`) of the cell holding `p`, or `None` outside the raster.
    #[inline]
    pub fn cell_of(&self, p: [f64; 2]) -> Option<usize> {
        let c = ((p[0] - self.origin[0]) / self.resolution).floor();
        let r = ((p[1] - self.origin[1]) / self.resolution).floor();
        if c >= 0.0 && r >= 0.0 && (c as usize) < self.cols && (r as usize) < self.rows {
            Some(r as usize * self.cols + c as usize)
        } else {
            None
        }
    }

    /// Whether cell `(col, row)` holds a wall point. Outside the raster is free.
    #[inline]
    pub fn is_wall(&self, col: i64, row: i64) -> bool {
        col >= 0
            && row >= 0
            && (col as usize) < self.cols
            && (row as usize) < self.rows
            && self.clearance[row as usize * self.cols + col as usize] == 0
    }

    /// The clearance of cell `(col, row)`, which must lie inside the raster: 0 for a wall cell, else
    /// its Chebyshev distance in cells to the nearest wall cell, capped at 255.
    #[inline]
    pub(crate) fn clearance(&self, col: usize, row: usize) -> u8 {
        self.clearance[row * self.cols + col]
    }

    /// This raster with every clearance capped at 1: casts through it step cell by cell (tests
    /// compare them with the jumping casts).
    #[cfg(test)]
    pub(crate) fn without_jumps(&self) -> Self {
        let mut plain = self.clone();
        for c in plain.clearance.iter_mut() {
            *c = (*c).min(1);
        }
        plain
    }

    /// Indices of the plan points inside the cell with linear index `cell`.
    pub fn points_in_cell(&self, cell: usize) -> &[u32] {
        let cell = cell as u32;
        let start = self.cell_of_slot.partition_point(|&c| c < cell);
        let end = start + self.cell_of_slot[start..].partition_point(|&c| c == cell);
        &self.point_of_slot[start..end]
    }

    /// Indices (ascending) of the plan points inside the cells with the linear indices `cells`
    /// (ascending, unique).
    pub fn points_in_cells(&self, cells: &[usize]) -> Vec<u32> {
        let mut out = Vec::new();
        // Both lists are sorted: each cell's slots are searched for after the previous cell's.
        let mut from = 0usize;
        for &cell in cells {
            let cell = cell as u32;
            let rest = &self.cell_of_slot[from..];
            let start = from + rest.partition_point(|&c| c < cell);
            let end = start + self.cell_of_slot[start..].iter().take_while(|&&c| c == cell).count();
            out.extend_from_slice(&self.point_of_slot[start..end]);
            from = end;
        }
        out.sort_unstable();
        out
    }

    /// Number of wall cells.
    pub fn wall_cells(&self) -> usize {
        self.clearance.iter().filter(|&&c| c == 0).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_points_are_refused_not_a_panic() {
        // Found by the core fuzz target `wall_raster`: a NaN coordinate escaped the bounds and
        // the "every point lies inside its raster" expectation panicked.
        for bad in [f64::NAN, f64::INFINITY, 1e300] {
            let err = WallRaster::new(&[[0.0, 0.0], [1.0, bad]], 0.1).unwrap_err();
            assert!(
                matches!(err, IcpError::NonFinite { row: 1, .. } | IcpError::OutOfRange { row: 1, .. }),
                "{err}"
            );
        }
    }

    #[test]
    fn points_land_in_their_cells() {
        let pts = [[0.0, 0.0], [0.26, 0.0], [0.27, 0.01], [1.0, 1.0]];
        let r = WallRaster::new(&pts, 0.1).unwrap();
        let c0 = r.cell_of(pts[1]).unwrap();
        assert_eq!(r.points_in_cell(c0), &[1, 2]);
        assert_eq!(r.points_in_cell(r.cell_of(pts[3]).unwrap()), &[3]);
        assert_eq!(r.wall_cells(), 3);
        let free = r.cell_of([0.55, 0.55]).unwrap();
        assert!(r.points_in_cell(free).is_empty());
    }

    #[test]
    fn rejects_bad_resolution_and_huge_extent() {
        assert!(matches!(WallRaster::new(&[[0.0, 0.0]], 0.0), Err(IcpError::InvalidParameter { .. })));
        assert!(matches!(WallRaster::new(&[[0.0, 0.0]], f64::NAN), Err(IcpError::InvalidParameter { .. })));
        let far = [[0.0, 0.0], [1e7, 1e7]];
        assert!(matches!(WallRaster::new(&far, 0.01), Err(IcpError::RasterTooLarge { .. })));
    }
}
