//! `planicp._core.align` with its `IcpSettings` and `Alignment`: one ICP alignment of a scan to the
//! plan (`icp_core::icp`). `planicp.localize` wraps them.

use crate::conversions::{count_arg, points_from};
use crate::errors::core_error;
use crate::interrupt::interruptible;
use crate::point_map::{PyPointMap, WallView};
use icp_core::icp::CorrespondenceSearch;
use icp_core::{IcpConfig, IcpResult, Pose2};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use std::sync::Arc;

/// ICP settings checked by the core (`IcpConfig::validate`), read off a `planicp.IcpConfig`.
#[pyclass(frozen, module = "planicp._core")]
pub(crate) struct IcpSettings {
    pub(crate) inner: IcpConfig,
}

/// The fields of a `planicp.IcpConfig` (or of any object that has them), read by name: the Python
/// dataclass defines the settings, their defaults and what a user may type; the core's
/// `IcpConfig::validate` checks them again here, since the core never runs with settings it has
/// not checked, whoever made them (Rust callers, the fuzz tests, this binding called directly).
#[derive(FromPyObject)]
struct IcpConfigFields<'py> {
    max_correspondence_distance: f64,
    // Through count_arg: a negative int is a PlanicpError, not pyo3's OverflowError.
    max_iterations: Bound<'py, PyAny>,
    trim_ratio: f64,
    auto_trim: bool,
    translation_tolerance: f64,
    rotation_tolerance: f64,
    subsample: Bound<'py, PyAny>,
    correspondence_schedule: Vec<f64>,
    use_visibility: bool,
    accelerate: bool,
    visibility_range: Option<f64>,
    correspondence_search: String,
}

#[pymethods]
impl IcpSettings {
    #[new]
    fn new(config: IcpConfigFields<'_>) -> PyResult<Self> {
        let search = match config.correspondence_search.as_str() {
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
        let inner = IcpConfig {
            max_correspondence_distance: config.max_correspondence_distance,
            max_iterations: count_arg("max_iterations", &config.max_iterations)?,
            trim_ratio: config.trim_ratio,
            auto_trim: config.auto_trim,
            translation_tolerance: config.translation_tolerance,
            rotation_tolerance: config.rotation_tolerance,
            subsample: count_arg("subsample", &config.subsample)?,
            correspondence_schedule: config.correspondence_schedule,
            use_visibility: config.use_visibility,
            accelerate: config.accelerate,
            visibility_range: config.visibility_range,
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
pub(crate) fn align(
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

/// The farthest (metres) a scan point and a plan point can be apart and still be paired by an
/// alignment with `settings`: the largest schedule factor (at least 1) times
/// `max_correspondence_distance`.
#[pyfunction]
pub(crate) fn largest_pair_distance(settings: &IcpSettings) -> f64 {
    icp_core::icp::largest_pair_distance(&settings.inner)
}

/// The range (metres) an alignment with `settings` casts its visibility to for `scan` (N, 2,
/// robot frame): the farthest scan point plus the largest stage distance, or the settings' own.
#[pyfunction]
pub(crate) fn visibility_range(scan: PyReadonlyArray2<'_, f64>, settings: &IcpSettings) -> PyResult<f64> {
    let pts = points_from("scan points", &scan)?;
    Ok(icp_core::icp::visibility_range(&pts, &settings.inner))
}
