//! The plan as a likelihood field: how likely a return is at each point of the plane.
//!
//! Every cell centre holds `exp(-d^2 / (2 sigma^2))`, `d` the distance to the nearest plan point,
//! 0 beyond `3 sigma` (the field of a likelihood-field particle filter, or of Cartographer's
//! probability grid). Values are bytes (`round(255 g)`): a field of a campus-sized plan at 5 cm
//! stays at a byte per cell. Between centres the field is interpolated bilinearly, and its gradient
//! with it, which is what [`crate::icp::posterior_refinement`] climbs.
//!
//! The field is built by stamping each plan point's Gaussian into the cells within `3 sigma` of
//! it, keeping the largest value per cell: exact at the centres (the largest `g` is the nearest
//! point's), in time proportional to the points, not to the raster.
//!
//! Cell `(col, row)` has its centre at `origin + ((col + 0.5) res, (row + 0.5) res)`; rows grow
//! with `y`. Outside the raster the field is 0.

use crate::error::{invalid, IcpError, Result};
use crate::grids::bounding_box::bounding_box;

/// Most cells a field may hold (one byte each: 256 MiB).
pub const MAX_FIELD_CELLS: usize = 256 * 1024 * 1024;

/// Cut of the Gaussian, in `sigma`s: beyond it a cell holds 0 (`exp(-4.5)` is 1 % of the peak).
pub const CUT_SIGMAS: f64 = 3.0;

/// Most times `sigma` [`LikelihoodGrid::within_budget`] coarsens a field's sampling to.
pub const MAX_COARSENING: f64 = 1e3;

/// Metres a field sampled every `resolution` metres extends beyond its points: the Gaussian's cut
/// (`CUT_SIGMAS * sigma`) and two cells.
fn field_margin(resolution: f64, sigma: f64) -> f64 {
    CUT_SIGMAS * sigma + 2.0 * resolution
}

/// [cols, rows] (as floats: they may not fit a usize) of a field over the box `lo`-`hi` sampled
/// every `resolution` metres, with its [`field_margin`].
fn raster_shape(lo: [f64; 2], hi: [f64; 2], resolution: f64, sigma: f64) -> [f64; 2] {
    let margin = field_margin(resolution, sigma);
    [
        ((hi[0] - lo[0] + 2.0 * margin) / resolution).ceil() + 1.0,
        ((hi[1] - lo[1] + 2.0 * margin) / resolution).ceil() + 1.0,
    ]
}

/// A likelihood raster of the plan (see the module).
#[derive(Debug, Clone)]
pub struct LikelihoodGrid {
    resolution: f64,
    sigma: f64,
    origin: [f64; 2],
    cols: usize,
    rows: usize,
    cells: Vec<u8>,
}

impl LikelihoodGrid {
    /// The field of `points` (plan points, metres, map frame) with a Gaussian of `sigma` metres,
    /// sampled every `resolution` metres.
    pub fn new(points: &[[f64; 2]], resolution: f64, sigma: f64) -> Result<Self> {
        for (name, v) in [("resolution", resolution), ("sigma", sigma)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(name, v, "must be a positive finite number of metres"));
            }
        }
        if points.is_empty() {
            return Err(IcpError::Empty { what: "plan points" });
        }
        let reach = CUT_SIGMAS * sigma;
        let (lo, hi) = bounding_box(points);
        let margin = field_margin(resolution, sigma);
        let origin = [lo[0] - margin, lo[1] - margin];
        let [cols_f, rows_f] = raster_shape(lo, hi, resolution, sigma);
        let cells_f = cols_f * rows_f;
        if !(cells_f.is_finite() && cells_f <= MAX_FIELD_CELLS as f64) {
            return Err(IcpError::RasterTooLarge {
                what: "likelihood field",
                resolution,
                cells: cells_f,
                limit: MAX_FIELD_CELLS,
            });
        }
        let (cols, rows) = (cols_f as usize, rows_f as usize);
        let mut cells = vec![0u8; cols * rows];
        let span = (reach / resolution).ceil() as i64;
        let inv_two_sigma2 = 1.0 / (2.0 * sigma * sigma);
        let reach2 = reach * reach;
        for p in points {
            let c0 = ((p[0] - origin[0]) / resolution - 0.5).round() as i64;
            let r0 = ((p[1] - origin[1]) / resolution - 0.5).round() as i64;
            for r in (r0 - span).max(0)..=(r0 + span).min(rows as i64 - 1) {
                let dy = origin[1] + (r as f64 + 0.5) * resolution - p[1];
                let row = r as usize * cols;
                for c in (c0 - span).max(0)..=(c0 + span).min(cols as i64 - 1) {
                    let dx = origin[0] + (c as f64 + 0.5) * resolution - p[0];
                    let d2 = dx * dx + dy * dy;
                    if d2 > reach2 {
                        continue;
                    }
                    let v = (255.0 * (-d2 * inv_two_sigma2).exp()).round() as u8;
                    let cell = &mut cells[row + c as usize];
                    if v > *cell {
                        *cell = v;
                    }
                }
            }
        }
        Ok(Self { resolution, sigma, origin, cols, rows, cells })
    }

    /// The field of `points` with a Gaussian of `sigma` metres, sampled every `resolution` metres,
    /// or, where that would take more than [`MAX_FIELD_CELLS`] cells (a square of 800 m at 5 cm),
    /// at the first of `resolution` times 1.25, 1.25^2, ... that fits: the Gaussian keeps its
    /// `sigma`, the interpolation between samples is coarser. Errors as [`Self::new`], and
    /// [`IcpError::RasterTooLarge`] (at `resolution`) when the fitting resolution would exceed
    /// [`MAX_COARSENING`] times `sigma`: samples that far apart no longer show the Gaussian.
    pub fn within_budget(points: &[[f64; 2]], resolution: f64, sigma: f64) -> Result<Self> {
        if points.is_empty()
            || !(resolution.is_finite() && resolution > 0.0 && sigma.is_finite() && sigma > 0.0)
        {
            return Self::new(points, resolution, sigma);
        }
        let (lo, hi) = bounding_box(points);
        let cells = |res: f64| {
            let [cols, rows] = raster_shape(lo, hi, res, sigma);
            cols * rows
        };
        let mut fitting = resolution;
        loop {
            let needed = cells(fitting);
            if needed.is_finite() && needed <= MAX_FIELD_CELLS as f64 {
                break;
            }
            fitting *= 1.25;
            if fitting.is_nan() || fitting > MAX_COARSENING * sigma {
                return Err(IcpError::RasterTooLarge {
                    what: "likelihood field",
                    resolution,
                    cells: cells(resolution),
                    limit: MAX_FIELD_CELLS,
                });
            }
        }
        Self::new(points, fitting, sigma)
    }

    /// Metres between cell centres.
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// The Gaussian's standard deviation, metres.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// (cols, rows).
    pub fn shape(&self) -> (usize, usize) {
        (self.cols, self.rows)
    }

    /// The stored value of cell `(col, row)` over 255 (0 outside the raster).
    fn at(&self, col: i64, row: i64) -> f64 {
        if col < 0 || row < 0 || col >= self.cols as i64 || row >= self.rows as i64 {
            return 0.0;
        }
        f64::from(self.cells[row as usize * self.cols + col as usize]) / 255.0
    }

    /// The field at `p` (map frame, metres), in [0, 1], and its gradient (per metre), both
    /// interpolated bilinearly between the four nearest cell centres.
    pub fn value_and_gradient(&self, p: [f64; 2]) -> (f64, [f64; 2]) {
        let u = (p[0] - self.origin[0]) / self.resolution - 0.5;
        let v = (p[1] - self.origin[1]) / self.resolution - 0.5;
        if !(u.is_finite() && v.is_finite()) {
            return (0.0, [0.0, 0.0]);
        }
        let (c, r) = (u.floor(), v.floor());
        let (fu, fv) = (u - c, v - r);
        let (c, r) = (c as i64, r as i64);
        let (a, b) = (self.at(c, r), self.at(c + 1, r));
        let (d, e) = (self.at(c, r + 1), self.at(c + 1, r + 1));
        let value = a * (1.0 - fu) * (1.0 - fv) + b * fu * (1.0 - fv) + d * (1.0 - fu) * fv + e * fu * fv;
        let du = (b - a) * (1.0 - fv) + (e - d) * fv;
        let dv = (d - a) * (1.0 - fu) + (e - b) * fu;
        (value, [du / self.resolution, dv / self.resolution])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_on_the_points_and_falls_as_a_gaussian() {
        let points: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 0.05, 0.0]).collect();
        let grid = LikelihoodGrid::new(&points, 0.01, 0.05).unwrap();
        let (on, slope) = grid.value_and_gradient([2.0, 0.0]);
        assert!(on > 0.95, "{on}");
        assert!(slope[1].abs() < 0.5, "{slope:?}");
        let (off, slope) = grid.value_and_gradient([2.0, 0.05]);
        let expected = (-0.5f64).exp();
        assert!((off - expected).abs() < 0.02, "{off} against {expected}");
        // Uphill is towards the wall: a negative y-gradient above it.
        assert!(slope[1] < -5.0, "{slope:?}");
        assert_eq!(grid.value_and_gradient([2.0, 0.2]).0, 0.0);
        assert_eq!(grid.value_and_gradient([-5.0, 0.0]).0, 0.0);
    }

    #[test]
    fn a_field_too_large_at_its_resolution_is_sampled_coarser_within_the_limit() {
        // 820 m square at 5 cm: 269 Mi cells, over the 256 Mi limit.
        let square = [[0.0, 0.0], [820.0, 0.0], [820.0, 820.0], [0.0, 820.0]];
        assert!(matches!(LikelihoodGrid::new(&square, 0.05, 0.05), Err(IcpError::RasterTooLarge { .. })));
        let grid = LikelihoodGrid::within_budget(&square, 0.05, 0.05).unwrap();
        assert!((grid.resolution() - 0.0625).abs() < 1e-12, "{}", grid.resolution());
        assert_eq!(grid.sigma(), 0.05);
        let (cols, rows) = grid.shape();
        assert!(cols * rows <= MAX_FIELD_CELLS);
        assert!(grid.value_and_gradient([820.0, 820.0]).0 > 0.6);
        // One that fits is sampled as asked.
        assert_eq!(LikelihoodGrid::within_budget(&square[..2], 0.05, 0.05).unwrap().resolution(), 0.05);
        // Two points 10^8 m apart would need samples 2,900 sigmas apart: refused, at the
        // resolution asked for, and so are bad arguments.
        match LikelihoodGrid::within_budget(&[[0.0, 0.0], [1e8, 1e8]], 0.05, 0.05) {
            Err(IcpError::RasterTooLarge { what: "likelihood field", resolution, .. }) => {
                assert_eq!(resolution, 0.05)
            }
            other => panic!("{other:?}"),
        }
        assert!(LikelihoodGrid::within_budget(&square, 0.05, -1.0).is_err());
        assert!(LikelihoodGrid::within_budget(&[], 0.05, 0.05).is_err());
    }

    #[test]
    fn refuses_a_bad_sigma_and_no_points() {
        assert!(LikelihoodGrid::new(&[[0.0, 0.0]], 0.05, 0.0).is_err());
        assert!(LikelihoodGrid::new(&[], 0.05, 0.05).is_err());
        assert!(LikelihoodGrid::new(&[[0.0, 0.0], [1e6, 1e6]], 1e-3, 0.05).is_err());
    }
}
