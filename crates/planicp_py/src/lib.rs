//! `planicp._core`: a thin pyo3 layer over `icp_core`.
//!
//! Inputs are copied out of numpy arrays, the GIL is released for the numerical work, core errors
//! become `PlanicpError` (a `ValueError`), and a panic inside the core is caught and raised as
//! `PlanicpInternalError` (a `RuntimeError`) instead of crossing into Python. Calls that can run
//! for seconds on their input (alignments, searches, map and index builds) look for Python signals
//! every 50 ms, so that Ctrl-C stops them with KeyboardInterrupt.

use crate::conversions::{points_from, points_to_array, shape_text, unsigned_arg, BoolPair};
use crate::errors::{core_error, guarded, PlanicpError, PlanicpInternalError};
use crate::interrupt::interruptible;
use icp_core::icp::CorrespondenceSearch;
use icp_core::{IcpConfig, IcpResult, PointMap, Pose2};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::sync::Arc;

mod conversions;
mod errors;
mod global_search;
mod interrupt;
mod log_odds_grid;

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
    /// with `scan` (N, 2, base frame), only over the arc its returns span.
    #[pyo3(signature = (pose, max_range, directions, scan=None, ranges=true))]
    #[allow(clippy::too_many_arguments)]
    fn view_from(
        &self,
        py: Python<'_>,
        pose: (f64, f64, f64),
        max_range: f64,
        directions: &Bound<'_, PyAny>,
        scan: Option<PyReadonlyArray2<'_, f64>>,
        ranges: bool,
    ) -> PyResult<WallView> {
        let directions = usize::try_from(unsigned_arg("directions", directions)?).unwrap_or(usize::MAX);
        let scan = scan.map(|s| points_from("scan", &s)).transpose()?;
        let map = Arc::clone(&self.inner);
        let pose = Pose2 { x: pose.0, y: pose.1, yaw: pose.2 };
        let view =
            py.detach(|| guarded(|| map.view_from(pose, max_range, directions, scan.as_deref(), ranges)))?;
        Ok(WallView { inner: Arc::new(view) })
    }
}

/// What a range sensor at a pose sees of the plan (`icp_core::wall_view::WallView`): the visible
/// wall points and the range to the first wall in each of `directions` evenly spaced directions.
#[pyclass(frozen, module = "planicp._core")]
pub(crate) struct WallView {
    inner: Arc<icp_core::visibility::wall_view::WallView>,
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

/// Validated ICP settings (see `planicp.IcpConfig` for their meaning).
#[pyclass(frozen, module = "planicp._core")]
pub(crate) struct IcpSettings {
    pub(crate) inner: IcpConfig,
}

#[pymethods]
impl IcpSettings {
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (max_correspondence_distance, max_iterations, trim_ratio, translation_tolerance,
                        rotation_tolerance, subsample, correspondence_schedule, use_visibility,
                        accelerate, visibility_range=None, auto_trim=false, search="wall_index"))]
    fn new(
        max_correspondence_distance: f64,
        max_iterations: &Bound<'_, PyAny>,
        trim_ratio: f64,
        translation_tolerance: f64,
        rotation_tolerance: f64,
        subsample: &Bound<'_, PyAny>,
        correspondence_schedule: Vec<f64>,
        use_visibility: bool,
        accelerate: bool,
        visibility_range: Option<f64>,
        auto_trim: bool,
        search: &str,
    ) -> PyResult<Self> {
        let search = match search {
            "wall_index" => CorrespondenceSearch::WallIndex,
            "kd_tree" => CorrespondenceSearch::KdTree,
            other => {
                return Err(core_error(icp_core::error::invalid(
                    "correspondence_search",
                    format!("{other:?}"),
                    "must be \"wall_index\" or \"kd_tree\"",
                )))
            }
        };
        // Through unsigned_arg: a negative int is a PlanicpError, not pyo3's OverflowError.
        let count = |what: &str, v: &Bound<'_, PyAny>| {
            unsigned_arg(what, v).map(|n| usize::try_from(n).unwrap_or(usize::MAX))
        };
        let max_iterations = count("max_iterations", max_iterations)?;
        let subsample = count("subsample", subsample)?;
        let inner = IcpConfig {
            max_correspondence_distance,
            max_iterations,
            trim_ratio,
            auto_trim,
            translation_tolerance,
            rotation_tolerance,
            subsample,
            correspondence_schedule,
            use_visibility,
            accelerate,
            visibility_range,
            search,
        };
        inner.validate().map_err(core_error)?;
        Ok(Self { inner })
    }
}

/// The raw outcome of `align`; `planicp.IcpResult` wraps it.
#[pyclass(frozen, module = "planicp._core")]
pub(crate) struct Alignment {
    pub(crate) inner: IcpResult,
}

#[pymethods]
impl Alignment {
    /// (x, y, yaw) of T_map_base: metres, metres, radians.
    #[getter]
    fn pose(&self) -> (f64, f64, f64) {
        let p = self.inner.pose;
        (p.x, p.y, p.yaw)
    }
    #[getter]
    fn converged(&self) -> bool {
        self.inner.converged
    }
    #[getter]
    fn iterations(&self) -> usize {
        self.inner.iterations
    }
    #[getter]
    fn num_inliers(&self) -> usize {
        self.inner.num_inliers
    }
    #[getter]
    fn inlier_ratio(&self) -> f64 {
        self.inner.inlier_ratio
    }
    #[getter]
    fn rmse(&self) -> f64 {
        self.inner.rmse
    }
    #[getter]
    fn num_target_points(&self) -> usize {
        self.inner.num_target_points
    }
    /// 3x3 covariance over (x, y, yaw).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let c = &self.inner.covariance;
        Array2::from_shape_fn((3, 3), |(i, j)| c[(i, j)]).into_pyarray(py)
    }
    /// 3x3 wall-normal constraint H = sum J J^T of the inliers.
    #[getter]
    fn constraint<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let c = &self.inner.constraint;
        Array2::from_shape_fn((3, 3), |(i, j)| c[(i, j)]).into_pyarray(py)
    }
    /// (N,) bool: which scan points are inliers.
    #[getter]
    fn inlier_mask<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.inner.inlier_mask.clone().into_pyarray(py)
    }
}

/// Aligns scan points (N, 2, robot frame, metres) to the map from initial (x, y, yaw); `view`, a
/// WallView cast from `initial`, gives the visible plan points instead of casting them again.
#[pyfunction]
#[pyo3(signature = (map, scan, initial, settings, view=None))]
fn align(
    py: Python<'_>,
    map: &PyPointMap,
    scan: PyReadonlyArray2<'_, f64>,
    initial: (f64, f64, f64),
    settings: &IcpSettings,
    view: Option<&WallView>,
) -> PyResult<Alignment> {
    let pts = points_from("scan points", &scan)?;
    let map = Arc::clone(&map.inner);
    let config = settings.inner.clone();
    let initial = Pose2::new(initial.0, initial.1, initial.2);
    let view = view.map(|v| Arc::clone(&v.inner));
    let inner = interruptible(py, |cancel| {
        icp_core::icp::align(
            &map,
            &pts,
            initial,
            &config,
            view.as_ref().map(|v| v.visible.as_slice()),
            cancel,
        )
    })?;
    Ok(Alignment { inner })
}

/// The range (metres) an alignment with `settings` casts its visibility to for `scan` (N, 2,
/// robot frame): the farthest scan point plus the largest stage distance, or the settings' own.
#[pyfunction]
fn visibility_range(scan: PyReadonlyArray2<'_, f64>, settings: &IcpSettings) -> PyResult<f64> {
    let pts = points_from("scan points", &scan)?;
    Ok(icp_core::icp::visibility_range(&pts, &settings.inner))
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("MIN_SCAN_POINTS", icp_core::icp::rigid_solver::MIN_PAIRS)?;
    m.add("MIN_SEARCH_POINTS", icp_core::search::global_search::MIN_SEARCH_POINTS)?;
    m.add("PlanicpError", m.py().get_type::<PlanicpError>())?;
    m.add("PlanicpInternalError", m.py().get_type::<PlanicpInternalError>())?;
    m.add_class::<PyPointMap>()?;
    m.add_class::<IcpSettings>()?;
    m.add_class::<Alignment>()?;
    m.add_class::<WallView>()?;
    m.add_class::<OccupancyGrid>()?;
    m.add_class::<log_odds_grid::LogOddsGrid>()?;
    m.add_class::<global_search::GlobalMatcher>()?;
    m.add_class::<global_search::Relocalization>()?;
    m.add_class::<global_search::RelocalizationCandidate>()?;
    m.add_class::<global_search::SearchRun>()?;
    m.add_function(wrap_pyfunction!(global_search::relocalize, m)?)?;
    m.add_function(wrap_pyfunction!(align, m)?)?;
    m.add_function(wrap_pyfunction!(visibility_range, m)?)?;
    m.add_function(wrap_pyfunction!(errors::_panic_for_tests, m)?)?;
    Ok(())
}

/// An occupancy grid to simulate LIDAR scans in (`icp_core::ray_casting`). `cells` is (rows, cols)
/// bool, True = occupied, with the ROW INDEX GROWING WITH +y (row 0 is the lowest y, as in
/// `planicp.sim.Floor`); `origin` is the map-frame (x, y) of the lower-left corner of cell (0, 0).
#[pyclass(frozen, module = "planicp._core")]
struct OccupancyGrid {
    inner: Arc<icp_core::grids::ray_casting::OccupancyRaster>,
}

#[pymethods]
impl OccupancyGrid {
    #[new]
    fn new(py: Python<'_>, cells: &Bound<'_, PyAny>, resolution: f64, origin: (f64, f64)) -> PyResult<Self> {
        use numpy::{PyArrayMethods, PyUntypedArray};
        let untyped = cells.cast::<PyUntypedArray>().map_err(|_| {
            let name = cells.get_type().name().map(|n| n.to_string()).unwrap_or_default();
            pyo3::exceptions::PyTypeError::new_err(format!(
                "cells must be a numpy bool array of shape (rows, cols), got {name}"
            ))
        })?;
        if untyped.ndim() != 2 {
            return Err(PlanicpError::new_err(format!(
                "cells must be a 2-D (rows, cols) array, got shape {}",
                shape_text(untyped.shape())
            )));
        }
        let typed = cells.cast::<PyArray2<bool>>().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "cells must have dtype bool (True = occupied), got {}; convert explicitly, e.g. cells != 0",
                untyped.dtype()
            ))
        })?;
        let cells = typed.readonly();
        let shape = cells.shape();
        let (rows, cols) = (shape[0], shape[1]);
        // Logical (row-major) order, whatever the array's memory layout.
        let flat: Vec<bool> = cells.as_array().iter().copied().collect();
        let origin = [origin.0, origin.1];
        let raster = py.detach(|| {
            guarded(|| {
                icp_core::grids::ray_casting::OccupancyRaster::new(flat, rows, cols, resolution, origin)
            })
        })?;
        Ok(Self { inner: Arc::new(raster) })
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

    /// (in_front, beyond), each (N,) bool: the occlusion rule's classes of the base-frame points
    /// against the walls of this grid seen from pose (x, y, yaw) in `directions` directions: more
    /// than margin metres short of the wall in their direction, and more than margin beyond it.
    /// Only the arc the points span is cast.
    fn classify_returns<'py>(
        &self,
        py: Python<'py>,
        pose: (f64, f64, f64),
        points: PyReadonlyArray2<'_, f64>,
        margin: f64,
        directions: &Bound<'py, PyAny>,
    ) -> PyResult<BoolPair<'py>> {
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(PlanicpError::new_err(format!(
                "margin must be a finite number of metres >= 0, got {margin}"
            )));
        }
        let directions = usize::try_from(unsigned_arg("directions", directions)?).unwrap_or(usize::MAX);
        let pts = points_from("points", &points)?;
        let raster = Arc::clone(&self.inner);
        let pose = Pose2 { x: pose.0, y: pose.1, yaw: pose.2 };
        let classes = py.detach(|| {
            guarded(|| {
                icp_core::visibility::wall_view::classify_exact(&raster, pose, &pts, margin, directions)
            })
        })?;
        Ok((classes.in_front.into_pyarray(py), classes.beyond.into_pyarray(py)))
    }

    /// (beams,) float64 ranges of a LIDAR at sensor_pose (x, y, yaw; map frame), REP-117 style:
    /// +inf for no return within range_max (and dropouts), -inf below range_min. `discs` is an
    /// optional (K, 3) array of (x, y, radius) moving obstacles; `seed` makes the noise reproducible.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (sensor_pose, angle_min, angle_increment, beams, range_min, range_max,
                        range_sigma=0.0, dropout=0.0, seed=None, discs=None))]
    fn cast<'py>(
        &self,
        py: Python<'py>,
        sensor_pose: (f64, f64, f64),
        angle_min: f64,
        angle_increment: f64,
        beams: &Bound<'py, PyAny>,
        range_min: f64,
        range_max: f64,
        range_sigma: f64,
        dropout: f64,
        seed: Option<&Bound<'py, PyAny>>,
        discs: Option<numpy::PyArrayLikeDyn<'py, f64, numpy::AllowTypeChange>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        use icp_core::grids::ray_casting::{add_noise, cast_ranges, noise_rng, Disc, LidarModel};
        let beams = usize::try_from(unsigned_arg("beams", beams)?).unwrap_or(usize::MAX);
        let seed = seed.map(|s| unsigned_arg("seed", s)).transpose()?;
        let discs: Vec<Disc> = match discs {
            None => Vec::new(),
            Some(d) => {
                let shape = d.shape();
                if shape.len() != 2 || shape[1] != 3 {
                    return Err(PlanicpError::new_err(format!(
                        "discs must have shape (K, 3) of (x, y, radius), got {}",
                        shape_text(shape)
                    )));
                }
                let d = d.as_array();
                (0..shape[0]).map(|k| Disc { x: d[[k, 0]], y: d[[k, 1]], radius: d[[k, 2]] }).collect()
            }
        };
        let raster = Arc::clone(&self.inner);
        let model = LidarModel { angle_min, angle_increment, beams, range_min, range_max };
        // The yaw as given (not wrapped): the beam angles round exactly as the numpy reference's
        // (tests/numpy_ray_caster.py).
        let pose = Pose2 { x: sensor_pose.0, y: sensor_pose.1, yaw: sensor_pose.2 };
        let ranges = py.detach(|| {
            guarded(|| {
                // Noise settings first, so that bad ones fail before any casting.
                add_noise(&mut [], &model, range_sigma, dropout, &mut noise_rng(Some(0)))?;
                let mut out = Vec::new();
                cast_ranges(&raster, pose, &model, &discs, &mut out)?;
                add_noise(&mut out, &model, range_sigma, dropout, &mut noise_rng(seed))?;
                Ok(out)
            })
        })?;
        Ok(ranges.into_pyarray(py))
    }
}
