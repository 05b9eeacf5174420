//! `planicp._core.LikelihoodGrid`: the plan as a likelihood field and the pose of highest posterior
//! in it (`icp_core::grids::likelihood_grid`, `icp_core::icp::posterior_refinement`).

use crate::conversions::points_from;
use crate::errors::{guarded, PlanicpError};
use icp_core::grids::likelihood_grid::{FieldProfile, LikelihoodGrid as CoreGrid};
use icp_core::icp::posterior_refinement::{cost, refine, Prior};
use icp_core::Pose2;
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use std::sync::Arc;

/// The plan's likelihood field at cell centres `resolution` metres apart, bilinear between them:
/// `exp(-d^2 / (2 sigma^2))` of the distance `d` to the nearest of `points` (metres, map frame)
/// (`profile="nearest"`, wall surfaces), or the points' summed Gaussians over the largest sum
/// within `3 sigma` (`profile="density"`, an occupancy grid's occupied cells).
#[pyclass(frozen, module = "planicp._core")]
pub(crate) struct LikelihoodGrid {
    inner: Arc<CoreGrid>,
}

/// The prior of mean `pose` and covariance `covariance`, or a clear error.
fn prior_of(pose: (f64, f64, f64), covariance: [[f64; 3]; 3]) -> PyResult<Prior> {
    Prior::from_covariance(Pose2::new(pose.0, pose.1, pose.2), covariance).ok_or_else(|| {
        PlanicpError::new_err(format!(
            "prior_covariance must be finite and invertible, got {covariance:?}: give every direction a \
             positive variance (a tiny one pins it)"
        ))
    })
}

/// The profile named `name`, or a clear error.
fn profile_of(name: &str) -> PyResult<FieldProfile> {
    match name {
        "nearest" => Ok(FieldProfile::Nearest),
        "density" => Ok(FieldProfile::Density),
        _ => Err(PlanicpError::new_err(format!(
            "profile must be \"nearest\" (wall surfaces) or \"density\" (an occupancy grid's occupied \
             cells), got {name:?}"
        ))),
    }
}

/// The field `make` builds from `points` (checked first) in the profile named `profile`, without
/// the GIL.
fn built(
    py: Python<'_>,
    points: &PyReadonlyArray2<'_, f64>,
    profile: &str,
    make: impl FnOnce(&[[f64; 2]], FieldProfile) -> icp_core::Result<CoreGrid> + Send,
) -> PyResult<LikelihoodGrid> {
    let profile = profile_of(profile)?;
    let pts = points_from("plan points", points)?;
    let grid = py.detach(|| guarded(|| make(&pts, profile)))?;
    Ok(LikelihoodGrid { inner: Arc::new(grid) })
}

/// The pose refined: (x, y, yaw), cost, cost at the start, the 3x3 information, accepted steps.
type Refined = ((f64, f64, f64), f64, f64, [[f64; 3]; 3], usize);

#[pymethods]
impl LikelihoodGrid {
    #[new]
    #[pyo3(signature = (points, resolution, sigma, profile="nearest"))]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        resolution: f64,
        sigma: f64,
        profile: &str,
    ) -> PyResult<Self> {
        built(py, &points, profile, |pts, profile| CoreGrid::new(pts, resolution, sigma, profile))
    }

    /// The field sampled every `resolution` metres, or coarser by steps of a quarter where that
    /// would exceed the native limit of cells (see `icp_core`'s `LikelihoodGrid::within_budget`).
    #[staticmethod]
    #[pyo3(signature = (points, resolution, sigma, profile="nearest"))]
    fn within_budget(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        resolution: f64,
        sigma: f64,
        profile: &str,
    ) -> PyResult<Self> {
        built(py, &points, profile, |pts, profile| CoreGrid::within_budget(pts, resolution, sigma, profile))
    }

    /// Metres between cell centres.
    #[getter]
    fn resolution(&self) -> f64 {
        self.inner.resolution()
    }

    /// The Gaussian's standard deviation, metres.
    #[getter]
    fn sigma(&self) -> f64 {
        self.inner.sigma()
    }

    /// (cols, rows).
    #[getter]
    fn shape(&self) -> (usize, usize) {
        self.inner.shape()
    }

    /// The field at (x, y), in [0, 1], and its gradient (per metre).
    fn value_and_gradient(&self, x: f64, y: f64) -> (f64, (f64, f64)) {
        let (v, g) = self.inner.value_and_gradient([x, y]);
        (v, (g[0], g[1]))
    }

    /// The cost `weight * sum (1 - g)^2 + d^T P^-1 d` of the robot-frame `scan` at `pose`, `d`
    /// the pose's difference from `prior_pose` (covariance `prior_covariance`).
    fn cost(
        &self,
        scan: PyReadonlyArray2<'_, f64>,
        pose: (f64, f64, f64),
        prior_pose: (f64, f64, f64),
        prior_covariance: [[f64; 3]; 3],
        weight: f64,
    ) -> PyResult<f64> {
        let pts = points_from("scan", &scan)?;
        let prior = prior_of(prior_pose, prior_covariance)?;
        Ok(cost(&self.inner, &pts, Pose2::new(pose.0, pose.1, pose.2), &prior, weight))
    }

    /// Levenberg-Marquardt from `start` on `cost`: (pose, cost, cost at start, information,
    /// accepted steps).
    #[pyo3(signature = (scan, start, prior_pose, prior_covariance, weight, max_iterations=30))]
    #[allow(clippy::too_many_arguments)] // Python's keyword arguments, as the other bindings
    fn refine(
        &self,
        py: Python<'_>,
        scan: PyReadonlyArray2<'_, f64>,
        start: (f64, f64, f64),
        prior_pose: (f64, f64, f64),
        prior_covariance: [[f64; 3]; 3],
        weight: f64,
        max_iterations: usize,
    ) -> PyResult<Refined> {
        if !(weight.is_finite() && weight > 0.0) {
            return Err(PlanicpError::new_err(format!(
                "weight must be a positive finite number, got {weight}"
            )));
        }
        let pts = points_from("scan", &scan)?;
        let prior = prior_of(prior_pose, prior_covariance)?;
        let start = Pose2::new(start.0, start.1, start.2);
        let grid = Arc::clone(&self.inner);
        let found = py.detach(|| refine(&grid, &pts, start, &prior, weight, max_iterations));
        let info = found.information;
        Ok((
            (found.pose.x, found.pose.y, found.pose.yaw),
            found.cost,
            found.start_cost,
            [
                [info[(0, 0)], info[(0, 1)], info[(0, 2)]],
                [info[(1, 0)], info[(1, 1)], info[(1, 2)]],
                [info[(2, 0)], info[(2, 1)], info[(2, 2)]],
            ],
            found.iterations,
        ))
    }
}
