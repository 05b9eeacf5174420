//! `planicp._core.OccupancyGrid`: a raster to simulate LIDAR scans in (`icp_core::grids::ray_casting`)
//! and to classify returns against exactly (`icp_core::visibility::wall_view::classify_exact`).

use crate::conversions::{count_arg, points_from, shape_text, unsigned_arg, BoolPair};
use crate::errors::{guarded, PlanicpError};
use icp_core::Pose2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::sync::Arc;

/// An occupancy grid to simulate LIDAR scans in (`icp_core::grids::ray_casting`). `cells` is (rows, cols)
/// bool, True = occupied, with the ROW INDEX GROWING WITH +y (row 0 is the lowest y, as in
/// `planicp.sim.Floor`); `origin` is the map-frame (x, y) of the lower-left corner of cell (0, 0).
#[pyclass(frozen, module = "planicp._core")]
pub(crate) struct OccupancyGrid {
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
        // Logical (row-major) order, whatever the array's memory layout (one copy when C-contiguous).
        let flat: Vec<bool> = match cells.as_slice() {
            Ok(contiguous) => contiguous.to_vec(),
            Err(_) => cells.as_array().iter().copied().collect(),
        };
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
        let directions = count_arg("directions", directions)?;
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
        let beams = count_arg("beams", beams)?;
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
