//! How a [`LogOddsGrid`] grows: by whole cells of its lattice, with padding, when a scan reaches
//! beyond it, within its cell budget and the coordinate limit; its contents move along.

use crate::error::{invalid, try_filled, IcpError, Result, MAX_COORDINATE};
use crate::grids::log_odds_grid::{behind_surface, Cell, LogOddsGrid, EXTENT_LIMIT, GROWTH_CELLS};

impl LogOddsGrid {
    /// Grows the grid so that it holds `sensor` and every end point (lattice cells).
    pub(super) fn reach(&mut self, sensor: [f64; 2], ends: &[([f64; 2], bool)]) -> Result<()> {
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
