//! `planicp._core.LogOddsGrid`: the scan occupancy layer of the enhanced occupancy grid
//! (`icp_core::grids::log_odds_grid`).

use crate::conversions::{count_arg, points_from};
use crate::errors::guarded;
use icp_core::grids::log_odds_grid::{LogOddsGrid as CoreGrid, OccupancyModel};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;

/// A growing log-odds occupancy grid updated by scans. Cells are (rows, cols) with the ROW INDEX
/// GROWING WITH +y; `origin` is the map-frame (x, y) of the lower-left corner of cell (0, 0).
/// `integrate` releases the GIL; one grid must not be integrated from two threads at once (the
/// second call raises instead of racing).
#[pyclass(module = "planicp._core")]
pub struct LogOddsGrid {
    inner: CoreGrid,
}

#[pymethods]
impl LogOddsGrid {
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (rows, cols, resolution, origin, hit, miss, min, max, max_cells))]
    fn new(
        rows: &Bound<'_, PyAny>,
        cols: &Bound<'_, PyAny>,
        resolution: f64,
        origin: (f64, f64),
        hit: f32,
        miss: f32,
        min: f32,
        max: f32,
        max_cells: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let (rows, cols, max_cells) =
            (count_arg("rows", rows)?, count_arg("cols", cols)?, count_arg("max_cells", max_cells)?);
        let model = OccupancyModel { hit, miss, min, max };
        let inner =
            guarded(|| CoreGrid::new(rows, cols, resolution, [origin.0, origin.1], model, max_cells))?;
        Ok(Self { inner })
    }

    /// Integrates one scan: beams from `sensor` (x, y; map frame, metres) to each row of `hits`
    /// ((N, 2) returns) and of `misses` ((M, 2) end points of no-return beams), returns beyond
    /// `max_range` metres counted as no return. Grows the grid when needed; on error the grid is
    /// unchanged.
    #[pyo3(signature = (sensor, hits, misses, max_range))]
    fn integrate(
        &mut self,
        py: Python<'_>,
        sensor: (f64, f64),
        hits: PyReadonlyArray2<'_, f64>,
        misses: PyReadonlyArray2<'_, f64>,
        max_range: f64,
    ) -> PyResult<()> {
        let hits = points_from("scan points", &hits)?;
        let misses = points_from("no-return end points", &misses)?;
        let grid = &mut self.inner;
        py.detach(|| guarded(|| grid.integrate([sensor.0, sensor.1], &hits, &misses, max_range)))
    }

    /// (rows, cols).
    #[getter]
    fn shape(&self) -> (usize, usize) {
        self.inner.shape()
    }

    /// Metres per cell.
    #[getter]
    fn resolution(&self) -> f64 {
        self.inner.resolution()
    }

    /// Map-frame (x, y) of the lower-left corner of cell (0, 0), metres.
    #[getter]
    fn origin(&self) -> (f64, f64) {
        let [x, y] = self.inner.origin();
        (x, y)
    }

    /// Scans integrated so far.
    #[getter]
    fn scans(&self) -> u64 {
        self.inner.scans()
    }

    /// Most cells the grid may grow to.
    #[getter]
    fn max_cells(&self) -> usize {
        self.inner.max_cells()
    }

    /// (rows, cols) float32 log-odds, 0 where unobserved (a copy).
    fn log_odds<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        let (rows, cols) = self.inner.shape();
        let data: Vec<f32> = self.inner.log_odds().collect();
        Array2::from_shape_vec((rows, cols), data).expect("the grid holds rows * cols cells").into_pyarray(py)
    }

    /// (rows, cols) bool: whether a scan has updated the cell (a copy).
    fn observed<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<bool>> {
        let (rows, cols) = self.inner.shape();
        let data: Vec<bool> = self.inner.observed().collect();
        Array2::from_shape_vec((rows, cols), data).expect("the grid holds rows * cols cells").into_pyarray(py)
    }
}
