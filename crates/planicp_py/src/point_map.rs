//! `planicp._core.PointMap` and `WallView`: the plan as the core holds it, and what a sensor at a
//! pose sees of it (`icp_core::maps::point_map`, `icp_core::visibility::wall_view`).

use crate::conversions::{count_arg, points_from, points_to_array, BoolPair};
use crate::errors::{guarded, PlanicpError};
use crate::interrupt::interruptible;
use icp_core::visibility::wall_view::ViewScan;
use icp_core::{PointMap, Pose2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use std::sync::Arc;

/// Wall points of a plan (metres, map frame) with their KD-tree, normals and visibility raster;
/// points denser than two per 5 mm square on average are thinned to one per square.
#[pyclass(frozen, module = "planicp._core", name = "PointMap")]
pub(crate) struct PyPointMap {
    pub(crate) inner: Arc<PointMap>,
}

#[pymethods]
impl PyPointMap {
    #[new]
    #[pyo3(signature = (points, raster_resolution=None, normals=None))]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        raster_resolution: Option<f64>,
        normals: Option<PyReadonlyArray2<'_, f64>>,
    ) -> PyResult<Self> {
        let pts = points_from("plan points", &points)?;
        let normals = normals.map(|n| points_from("normals", &n)).transpose()?;
        let map = interruptible(py, |cancel| PointMap::build(pts, normals, raster_resolution, cancel))?;
        Ok(Self { inner: Arc::new(map) })
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    /// (N, 2) copy of the wall points.
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        points_to_array(py, self.inner.points())
    }

    /// (N, 2) unit wall normals ((0, 0) where none could be fitted).
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        points_to_array(py, self.inner.normals())
    }

    /// Cell size of the visibility raster, metres.
    #[getter]
    fn raster_resolution(&self) -> f64 {
        self.inner.raster().resolution()
    }

    /// Median distance between neighbouring wall points, metres (0.05 m when it cannot be told).
    #[getter]
    fn spacing(&self) -> f64 {
        self.inner.spacing()
    }

    /// Builds the nearest-wall index if not built yet (it is kept) and returns its sizes:
    /// (cell m, reach m, memory bytes, stored blocks, blocks, candidates).
    fn wall_index_stats(&self, py: Python<'_>) -> PyResult<(f64, f64, usize, usize, usize, usize)> {
        let map = Arc::clone(&self.inner);
        interruptible(py, |cancel| {
            map.wall_index(cancel).map(|index| {
                let s = index.stats();
                (index.cell(), index.reach(), s.memory_bytes, s.stored_blocks, s.blocks, s.candidates)
            })
        })
    }

    /// Indices of the wall points visible from (x, y) within max_range metres.
    fn visible_indices<'py>(
        &self,
        py: Python<'py>,
        x: f64,
        y: f64,
        max_range: f64,
    ) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let map = Arc::clone(&self.inner);
        let idx = py.detach(|| guarded(|| map.visible_from(Pose2::new(x, y, 0.0), max_range)))?;
        Ok(idx.into_pyarray(py))
    }

    /// The plan as seen from pose (x, y, yaw), within max_range metres, in `directions` evenly
    /// spaced directions: one ray cast for the visible points and each direction's wall range;
    /// with `scan` (N, 2, base frame), only over the arc its returns span, and with
    /// `pair_distance` (metres; only without ranges) only as far as its returns can pair.
    #[pyo3(signature = (pose, max_range, directions, scan=None, ranges=true, pair_distance=None))]
    #[allow(clippy::too_many_arguments)]
    fn view_from(
        &self,
        py: Python<'_>,
        pose: (f64, f64, f64),
        max_range: f64,
        directions: &Bound<'_, PyAny>,
        scan: Option<PyReadonlyArray2<'_, f64>>,
        ranges: bool,
        pair_distance: Option<f64>,
    ) -> PyResult<WallView> {
        let directions = count_arg("directions", directions)?;
        let scan = scan.map(|s| points_from("scan", &s)).transpose()?;
        if pair_distance.is_some() && scan.is_none() {
            return Err(PlanicpError::new_err(
                "pair_distance limits a cast to what a scan's returns can pair with: pass the scan too",
            ));
        }
        let map = Arc::clone(&self.inner);
        let pose = Pose2 { x: pose.0, y: pose.1, yaw: pose.2 };
        let view = py.detach(|| {
            guarded(|| {
                let scan = scan.as_deref().map(|returns| ViewScan { returns, pair_distance });
                map.view_from(pose, max_range, directions, scan, ranges)
            })
        })?;
        Ok(WallView { inner: Arc::new(view) })
    }
}

/// What a range sensor at a pose sees of the plan (`icp_core::visibility::wall_view::WallView`): the visible
/// wall points and the range to the first wall in each of `directions` evenly spaced directions.
#[pyclass(frozen, module = "planicp._core")]
pub(crate) struct WallView {
    pub(crate) inner: Arc<icp_core::visibility::wall_view::WallView>,
}

#[pymethods]
impl WallView {
    /// (x, y, yaw) the view was cast from, `T_map_base`.
    #[getter]
    fn pose(&self) -> (f64, f64, f64) {
        let p = self.inner.pose;
        (p.x, p.y, p.yaw)
    }

    /// (K,) uint32: indices (ascending) of the plan points visible from the pose.
    #[getter]
    fn visible_indices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u32>> {
        self.inner.visible.clone().into_pyarray(py)
    }

    /// (directions,) float64: metres to the first wall along base-frame angle
    /// -pi + j * 2 pi / directions, inf when none lies within the cast's range.
    #[getter]
    fn ranges<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.ranges.clone().into_pyarray(py)
    }

    /// (in_front, beyond), each (N,) bool: which base-frame points lie more than margin metres
    /// short of the wall in their direction, and which more than margin beyond it.
    fn classify<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'_, f64>,
        margin: f64,
    ) -> PyResult<BoolPair<'py>> {
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(PlanicpError::new_err(format!(
                "margin must be a finite number of metres >= 0, got {margin}"
            )));
        }
        if self.inner.ranges.is_empty() {
            return Err(PlanicpError::new_err(
                "this view was cast without ranges (ranges=False): cast it with them",
            ));
        }
        let pts = points_from("points", &points)?;
        let view = Arc::clone(&self.inner);
        let classes = py.detach(|| guarded(|| Ok(view.classify(&pts, margin))))?;
        Ok((classes.in_front.into_pyarray(py), classes.beyond.into_pyarray(py)))
    }
}
