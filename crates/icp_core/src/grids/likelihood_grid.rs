//! The plan as a likelihood field: how likely a return is at each point of the plane.
//!
//! Two profiles ([`FieldProfile`]), for the two kinds of plan points:
//!
//! - [`FieldProfile::Nearest`], for wall surfaces (a drawing's faces, vector walls): every cell
//!   centre holds `exp(-d^2 / (2 sigma^2))`, `d` the distance to the nearest plan point (the field
//!   of a likelihood-field particle filter, or of Cartographer's probability grid). Both faces of
//!   a wall 10 cm thick stay peaks of their own. Built by stamping each point's Gaussian into the
//!   cells within `3 sigma` and keeping the largest value per cell: exact at the centres.
//! - [`FieldProfile::Density`], for an occupancy grid's occupied cells (a map made by SLAM): the
//!   cells are where returns ended, a wall drawn two or three cells thick by the scatter of the
//!   beams that made it, its surface most likely in the band's middle. The nearest-point field is
//!   flat on top across such a band (every cell of it is a point at distance 0), so a scan can
//!   slide a cell either way at no cost. Here every cell holds the sum of the points' Gaussians
//!   (a kernel density estimate of where returns end), divided by the largest sum within `3 sigma`
//!   of it, or by 1 where that is smaller (an isolated point keeps its peak of 1): a band peaks in
//!   its middle and its ridge is 1 however thick it is drawn, a line of points spaced `sigma` or
//!   less is the same Gaussian across it as the nearest-point field, without the ripple between
//!   points, and a speck is a single Gaussian as there.
//!
//! Values are bytes (`round(255 g)`): a field of a campus-sized plan at 5 cm stays at a byte per
//! cell, and the density's sums are made in bands of rows, so building one never holds more than
//! a few hundred rows of floats. Between centres the field is interpolated bilinearly, and its
//! gradient with it, which is what [`crate::icp::posterior_refinement`] climbs. Both take time
//! proportional to the points (and the density, to the raster, a few operations per cell).
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

/// Rows of floats a density field's sums are made in at a time (and twice `3 sigma` more).
const DENSITY_BAND_ROWS: usize = 256;

/// How a field's cells are made from the plan points (see the module).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldProfile {
    /// `exp(-d^2 / (2 sigma^2))` of the distance to the nearest point: for wall surfaces.
    Nearest,
    /// The points' summed Gaussians over the largest sum within `3 sigma` (at least 1): for an
    /// occupancy grid's occupied cells, where a wall is a band of cells.
    Density,
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
    /// sampled every `resolution` metres, in `profile`.
    pub fn new(points: &[[f64; 2]], resolution: f64, sigma: f64, profile: FieldProfile) -> Result<Self> {
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
        let stamp = Stamp {
            origin,
            resolution,
            cols,
            rows,
            span: (reach / resolution).ceil() as i64,
            inv_two_sigma2: 1.0 / (2.0 * sigma * sigma),
            reach2: reach * reach,
        };
        let cells = match profile {
            FieldProfile::Nearest => nearest_cells(points, &stamp),
            FieldProfile::Density => density_cells(points, &stamp),
        };
        Ok(Self { resolution, sigma, origin, cols, rows, cells })
    }

    /// The field of `points` with a Gaussian of `sigma` metres, sampled every `resolution` metres,
    /// or, where that would take more than [`MAX_FIELD_CELLS`] cells (a square of 800 m at 5 cm),
    /// at the first of `resolution` times 1.25, 1.25^2, ... that fits: the Gaussian keeps its
    /// `sigma`, the interpolation between samples is coarser. Errors as [`Self::new`], and
    /// [`IcpError::RasterTooLarge`] (at `resolution`) when the fitting resolution would exceed
    /// [`MAX_COARSENING`] times `sigma`: samples that far apart no longer show the Gaussian.
    pub fn within_budget(
        points: &[[f64; 2]],
        resolution: f64,
        sigma: f64,
        profile: FieldProfile,
    ) -> Result<Self> {
        if points.is_empty()
            || !(resolution.is_finite() && resolution > 0.0 && sigma.is_finite() && sigma > 0.0)
        {
            return Self::new(points, resolution, sigma, profile);
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
        Self::new(points, fitting, sigma, profile)
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

/// Where a field's points stamp their Gaussians: the raster and the Gaussian's cut.
struct Stamp {
    origin: [f64; 2],
    resolution: f64,
    cols: usize,
    rows: usize,
    /// Cells the cut reaches either way: `ceil(3 sigma / resolution)`.
    span: i64,
    inv_two_sigma2: f64,
    reach2: f64,
}

impl Stamp {
    /// The (col, row) of the cell whose centre is nearest `p` (may lie outside the raster).
    fn cell_of(&self, p: &[f64; 2]) -> (i64, i64) {
        (
            ((p[0] - self.origin[0]) / self.resolution - 0.5).round() as i64,
            ((p[1] - self.origin[1]) / self.resolution - 0.5).round() as i64,
        )
    }

    /// Calls `visit(row, col, g)` for each cell of rows `first..end` within the cut of `p`, with
    /// `g` the Gaussian of its centre's distance to `p`.
    fn each_cell(&self, p: &[f64; 2], first: i64, end: i64, mut visit: impl FnMut(usize, usize, f64)) {
        let (c0, r0) = self.cell_of(p);
        for r in (r0 - self.span).max(first)..=(r0 + self.span).min(end - 1) {
            let dy = self.origin[1] + (r as f64 + 0.5) * self.resolution - p[1];
            for c in (c0 - self.span).max(0)..=(c0 + self.span).min(self.cols as i64 - 1) {
                let dx = self.origin[0] + (c as f64 + 0.5) * self.resolution - p[0];
                let d2 = dx * dx + dy * dy;
                if d2 <= self.reach2 {
                    visit(r as usize, c as usize, (-d2 * self.inv_two_sigma2).exp());
                }
            }
        }
    }
}

/// The cells of [`FieldProfile::Nearest`]: each the largest of the points' Gaussians.
fn nearest_cells(points: &[[f64; 2]], stamp: &Stamp) -> Vec<u8> {
    let cols = stamp.cols;
    let mut cells = vec![0u8; cols * stamp.rows];
    for p in points {
        stamp.each_cell(p, 0, stamp.rows as i64, |r, c, g| {
            let v = (255.0 * g).round() as u8;
            let cell = &mut cells[r * cols + c];
            if v > *cell {
                *cell = v;
            }
        });
    }
    cells
}

/// The cells of [`FieldProfile::Density`]: each the points' summed Gaussians over the largest
/// sum within `span` cells (a square), or over 1 where that is smaller. Made in bands of
/// [`DENSITY_BAND_ROWS`] rows: a band's sums need the points within `2 span` rows of it, its
/// maxima the sums within `span` rows.
fn density_cells(points: &[[f64; 2]], stamp: &Stamp) -> Vec<u8> {
    let (cols, rows, span) = (stamp.cols, stamp.rows, stamp.span as usize);
    let mut cells = vec![0u8; cols * rows];
    // The points in the order of their rows, to find a band's quickly.
    let mut by_row: Vec<(i64, usize)> =
        points.iter().enumerate().map(|(i, p)| (stamp.cell_of(p).1, i)).collect();
    by_row.sort_unstable();
    let mut sums: Vec<f32> = Vec::new();
    let mut across: Vec<f32> = Vec::new();
    let mut first = 0usize;
    while first < rows {
        let end = (first + DENSITY_BAND_ROWS).min(rows);
        // The sums over the band and `span` rows either side of it.
        let (lo, hi) = (first.saturating_sub(span), (end + span).min(rows));
        let height = hi - lo;
        sums.clear();
        sums.resize(height * cols, 0.0);
        // Each row's first and last column with a sum (most of a building's raster is empty).
        let mut reached = vec![(usize::MAX, 0usize); height];
        let from = by_row.partition_point(|&(r, _)| r < lo as i64 - span as i64);
        let to = by_row.partition_point(|&(r, _)| r <= (hi + span) as i64);
        for &(_, i) in &by_row[from..to] {
            stamp.each_cell(&points[i], lo as i64, hi as i64, |r, c, g| {
                sums[(r - lo) * cols + c] += g as f32;
                let row = &mut reached[r - lo];
                *row = (row.0.min(c), row.1.max(c));
            });
        }
        // The largest sum within `span` columns, then within `span` rows of that.
        across.clear();
        across.resize(height * cols, 0.0);
        for (r, &(c0, c1)) in reached.iter().enumerate() {
            if c0 > c1 {
                continue;
            }
            let row = &sums[r * cols..(r + 1) * cols];
            for c in c0.saturating_sub(span)..(c1 + span + 1).min(cols) {
                let window = &row[c.saturating_sub(span)..(c + span + 1).min(cols)];
                across[r * cols + c] = window.iter().copied().fold(0.0, f32::max);
            }
        }
        for r in first..end {
            let (c0, c1) = reached[r - lo];
            if c0 > c1 {
                continue;
            }
            let (a, b) = (r.saturating_sub(span).max(lo) - lo, (r + span + 1).min(hi) - lo);
            for c in c0..=c1 {
                let sum = sums[(r - lo) * cols + c];
                if sum <= 0.0 {
                    continue;
                }
                let local = (a..b).map(|k| across[k * cols + c]).fold(1.0, f32::max);
                cells[r * cols + c] = (255.0 * (sum / local).min(1.0)).round() as u8;
            }
        }
        first = end;
    }
    cells
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_on_the_points_and_falls_as_a_gaussian() {
        let points: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 0.05, 0.0]).collect();
        let grid = LikelihoodGrid::new(&points, 0.01, 0.05, FieldProfile::Nearest).unwrap();
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
        assert!(matches!(
            LikelihoodGrid::new(&square, 0.05, 0.05, FieldProfile::Nearest),
            Err(IcpError::RasterTooLarge { .. })
        ));
        let grid = LikelihoodGrid::within_budget(&square, 0.05, 0.05, FieldProfile::Nearest).unwrap();
        assert!((grid.resolution() - 0.0625).abs() < 1e-12, "{}", grid.resolution());
        assert_eq!(grid.sigma(), 0.05);
        let (cols, rows) = grid.shape();
        assert!(cols * rows <= MAX_FIELD_CELLS);
        assert!(grid.value_and_gradient([820.0, 820.0]).0 > 0.6);
        // One that fits is sampled as asked.
        assert_eq!(
            LikelihoodGrid::within_budget(&square[..2], 0.05, 0.05, FieldProfile::Nearest)
                .unwrap()
                .resolution(),
            0.05
        );
        // Two points 10^8 m apart would need samples 2,900 sigmas apart: refused, at the
        // resolution asked for, and so are bad arguments.
        match LikelihoodGrid::within_budget(&[[0.0, 0.0], [1e8, 1e8]], 0.05, 0.05, FieldProfile::Nearest) {
            Err(IcpError::RasterTooLarge { what: "likelihood field", resolution, .. }) => {
                assert_eq!(resolution, 0.05)
            }
            other => panic!("{other:?}"),
        }
        assert!(LikelihoodGrid::within_budget(&square, 0.05, -1.0, FieldProfile::Nearest).is_err());
        assert!(LikelihoodGrid::within_budget(&[], 0.05, 0.05, FieldProfile::Nearest).is_err());
    }

    /// The field's values across `x = 2` from `y0` to `y1` in steps of 5 mm.
    fn across(grid: &LikelihoodGrid, y0: f64, y1: f64) -> Vec<(f64, f64)> {
        let n = ((y1 - y0) / 0.005).round() as usize;
        (0..=n).map(|k| y0 + k as f64 * 0.005).map(|y| (y, grid.value_and_gradient([2.0, y]).0)).collect()
    }

    #[test]
    fn a_density_field_of_a_line_is_the_gaussian_across_it_without_ripple_along_it() {
        // Points 5 cm apart along y = 0, sigma 5 cm, sampled every 1 cm.
        let points: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 0.05, 0.0]).collect();
        let density = LikelihoodGrid::new(&points, 0.01, 0.05, FieldProfile::Density).unwrap();
        let nearest = LikelihoodGrid::new(&points, 0.01, 0.05, FieldProfile::Nearest).unwrap();
        for (y, g) in across(&density, -0.2, 0.2) {
            let expected = if y.abs() <= 0.15 { (-y * y / (2.0 * 0.05 * 0.05)).exp() } else { 0.0 };
            assert!((g - expected).abs() < 0.02, "{g} at y {y} against {expected}");
        }
        // Midway between two points the nearest-point field dips to exp(-1/8); the density does not.
        let (between, on) = ([2.025, 0.0], [2.0, 0.0]);
        assert!(nearest.value_and_gradient(between).0 < 0.9);
        assert!(density.value_and_gradient(between).0 > 0.99);
        assert!(density.value_and_gradient(on).0 > 0.99);
    }

    #[test]
    fn a_density_field_peaks_in_the_middle_of_a_band_where_the_nearest_field_is_flat() {
        // A wall drawn as a band 10 cm thick, as a SLAM map draws one several cells thick: rows of
        // points every 1 cm from y = -5 cm to 5 cm.
        let points: Vec<[f64; 2]> =
            (0..100).flat_map(|i| (-5..=5).map(move |k| [i as f64 * 0.05, k as f64 * 0.01])).collect();
        let density = LikelihoodGrid::new(&points, 0.01, 0.05, FieldProfile::Density).unwrap();
        let nearest = LikelihoodGrid::new(&points, 0.01, 0.05, FieldProfile::Nearest).unwrap();
        let peak = |grid: &LikelihoodGrid| {
            let values = across(grid, -0.1, 0.1);
            let top = values.iter().map(|v| v.1).fold(0.0, f64::max);
            let ys: Vec<f64> = values.iter().filter(|v| v.1 >= top - 1e-9).map(|v| v.0).collect();
            (top, ys)
        };
        let (top, ys) = peak(&density);
        assert!(top > 0.99, "{top}");
        assert!(ys.iter().all(|y| y.abs() < 0.006), "{ys:?}");
        // 2.5 cm off the middle is 0.91 of the peak (the band's box smoothed by the Gaussian); the
        // nearest field is flat over the whole band.
        let off = density.value_and_gradient([2.0, 0.025]).0;
        assert!(off < 0.95 && off > 0.85, "{off}");
        let (_, ys) = peak(&nearest);
        assert!(ys.len() >= 15, "the nearest field is flat over {} samples: {ys:?}", ys.len());
        // Uphill is towards the middle on both sides.
        assert!(density.value_and_gradient([2.0, 0.03]).1[1] < -1.0);
        assert!(density.value_and_gradient([2.0, -0.03]).1[1] > 1.0);
    }

    #[test]
    fn a_density_field_keeps_a_speck_at_one_and_is_the_same_made_in_bands() {
        // An isolated point peaks at 1, as in the nearest field (the divisor is at least 1).
        let density = LikelihoodGrid::new(&[[0.0, 0.0]], 0.01, 0.05, FieldProfile::Density).unwrap();
        assert!((density.value_and_gradient([0.0, 0.0]).0 - 1.0).abs() < 0.02);
        let expected = (-0.5f64).exp();
        assert!((density.value_and_gradient([0.05, 0.0]).0 - expected).abs() < 0.02);
        // A plan over more rows than one band: a wall crossing every band boundary and a point
        // stamped into two bands are the same field as a wall in one band.
        let tall: Vec<[f64; 2]> = (0..400).map(|i| [0.0, i as f64 * 0.01]).collect();
        let grid = LikelihoodGrid::new(&tall, 0.005, 0.01, FieldProfile::Density).unwrap();
        assert!(grid.shape().1 > 3 * DENSITY_BAND_ROWS);
        for y in [0.5, 1.28, 1.285, 2.56, 3.0] {
            let (on, slope) = grid.value_and_gradient([0.0, y]);
            assert!(on > 0.99 && slope[1].abs() < 0.5, "{on} {slope:?} at y {y}");
            let off = grid.value_and_gradient([0.01, y]).0;
            assert!((off - expected).abs() < 0.03, "{off} at y {y}");
        }
    }

    #[test]
    fn refuses_a_bad_sigma_and_no_points() {
        assert!(LikelihoodGrid::new(&[[0.0, 0.0]], 0.05, 0.0, FieldProfile::Nearest).is_err());
        assert!(LikelihoodGrid::new(&[], 0.05, 0.05, FieldProfile::Nearest).is_err());
        assert!(LikelihoodGrid::new(&[[0.0, 0.0], [1e6, 1e6]], 1e-3, 0.05, FieldProfile::Nearest).is_err());
        assert!(LikelihoodGrid::new(&[[0.0, 0.0]], f64::NAN, 0.05, FieldProfile::Density).is_err());
        assert!(LikelihoodGrid::new(&[], 0.05, 0.05, FieldProfile::Density).is_err());
    }
}
