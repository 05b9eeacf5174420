//! `planicp._core.GlobalMatcher` and `relocalize`: global relocalization on the plan
//! (`icp_core::search::global_search`, `icp_core::search::relocalization`). `planicp.relocalize` wraps them.

use crate::alignment::{Alignment, IcpSettings};
use crate::conversions::points_from;
use crate::errors::{guarded, PlanicpError};
use crate::interrupt::interruptible;
use crate::point_map::PyPointMap;
use icp_core::search::global_search::{
    GlobalMatcher as CoreMatcher, GlobalSearchConfig, SearchRun as CoreRun, SearchWindow,
};
use icp_core::search::relocalization::{refine as core_refine, relocalize as core_relocalize, RankingConfig};
use icp_core::{PointMap, Pose2};
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// (x, y, yaw) of a pose.
type PoseTuple = (f64, f64, f64);

fn tuple(p: Pose2) -> PoseTuple {
    (p.x, p.y, p.yaw)
}

/// A search window as (x, y, yaw, half_width, half_angle, lever_x, lever_y): metres and radians.
type WindowTuple = (f64, f64, f64, f64, f64, f64, f64);

fn window_from(w: Option<WindowTuple>) -> Option<SearchWindow> {
    // The yaw as given; the core checks finiteness (Pose2::new would turn NaN into NaN anyway).
    w.map(|(x, y, yaw, half_width, half_angle, lx, ly)| SearchWindow {
        center: Pose2 { x, y, yaw },
        half_width,
        half_angle,
        lever: [lx, ly],
    })
}

/// The likelihood pyramid of a plan with the global search settings (see
/// `planicp.RelocalizationConfig` for their meaning); built once, searched many times.
#[pyclass(frozen, module = "planicp._core")]
pub struct GlobalMatcher {
    map: Arc<PointMap>,
    inner: Arc<CoreMatcher>,
}

/// The search fields of a `planicp.RelocalizationConfig` (or of any object that has them), read by
/// name; the core's `GlobalSearchConfig::validate` checks them again (see `IcpConfigFields`).
#[derive(FromPyObject)]
struct SearchConfigFields {
    resolution: f64,
    sigma: f64,
    levels: usize,
    angular_step: Option<f64>,
    max_angular_step: f64,
    search_candidates: usize,
    min_score: f64,
    relative_score: f64,
    nms_distance: f64,
    nms_angle: f64,
    max_scan_points: usize,
    max_nodes: u64,
}

#[pymethods]
impl GlobalMatcher {
    #[new]
    fn new(py: Python<'_>, map: &PyPointMap, config: SearchConfigFields) -> PyResult<Self> {
        let config = GlobalSearchConfig {
            resolution: config.resolution,
            sigma: config.sigma,
            levels: config.levels,
            angular_step: config.angular_step,
            max_angular_step: config.max_angular_step,
            max_candidates: config.search_candidates,
            min_score: config.min_score,
            relative_score: config.relative_score,
            nms_distance: config.nms_distance,
            nms_angle: config.nms_angle,
            max_scan_points: config.max_scan_points,
            max_nodes: config.max_nodes,
        };
        let map = Arc::clone(&map.inner);
        let inner = py.detach(|| guarded(|| CoreMatcher::new(&map, config)))?;
        Ok(Self { map, inner: Arc::new(inner) })
    }

    /// (cols, rows) of the likelihood raster.
    #[getter]
    fn shape(&self) -> (usize, usize) {
        self.inner.pyramid().shape()
    }

    /// Metres per cell of the likelihood raster and the translation lattice.
    #[getter]
    fn resolution(&self) -> f64 {
        self.inner.config().resolution
    }

    /// Pyramid levels.
    #[getter]
    fn levels(&self) -> usize {
        self.inner.pyramid().num_levels()
    }

    /// A search of scan points (N, 2, robot frame, metres) over the whole plan, or within
    /// `window` (x, y, yaw, half_width, half_angle, lever_x, lever_y), that has scored no node
    /// yet: see `SearchRun`.
    #[pyo3(signature = (scan, window))]
    fn start(&self, scan: PyReadonlyArray2<'_, f64>, window: Option<WindowTuple>) -> PyResult<SearchRun> {
        let pts = points_from("scan points", &scan)?;
        let window = window_from(window);
        let run = guarded(|| self.inner.start(&pts, window.as_ref()))?;
        Ok(SearchRun { run, scan: pts, map: Arc::clone(&self.map), matcher: Arc::clone(&self.inner) })
    }

    /// Mean likelihood (0..1) of scan points (N, 2, robot frame) at pose (x, y, yaw).
    fn score_at(&self, scan: PyReadonlyArray2<'_, f64>, pose: PoseTuple) -> PyResult<f64> {
        let pts = points_from("scan points", &scan)?;
        guarded(|| {
            icp_core::error::check_finite("scan", &pts)?;
            Ok(self.inner.score_at(&pts, Pose2::new(pose.0, pose.1, pose.2)))
        })
    }
}

/// A global search in progress (`GlobalMatcher.start`): `advance` scores a budget of search nodes
/// at a time (releasing the GIL), so that a search of seconds is spread over many short calls;
/// `finish` refines and ranks the candidates as `relocalize` does. Advanced to its end, it finds
/// what `relocalize` finds for the same scan.
#[pyclass(module = "planicp._core")]
pub struct SearchRun {
    run: CoreRun,
    scan: Vec<[f64; 2]>,
    map: Arc<PointMap>,
    matcher: Arc<CoreMatcher>,
}

#[pymethods]
impl SearchRun {
    /// Scores `budget` (>= 1) more nodes (up to three more: an expansion scores four children),
    /// and, with `seconds`, stops where it is at the first poll (every 1024 nodes) after that
    /// long; returns whether the search has ended.
    #[pyo3(signature = (budget, seconds=None))]
    fn advance(&mut self, py: Python<'_>, budget: u64, seconds: Option<f64>) -> PyResult<bool> {
        let until = match seconds {
            None => None,
            Some(s) if s.is_finite() && s >= 0.0 => {
                Some(Instant::now() + Duration::from_secs_f64(s.min(1e6)))
            }
            Some(s) => {
                return Err(PlanicpError::new_err(format!(
                    "seconds must be a finite number of seconds >= 0 or None, got {s}"
                )))
            }
        };
        let (run, matcher) = (&mut self.run, &self.matcher);
        interruptible(py, |cancel| run.advance_until(matcher, budget, until, cancel))
    }

    /// Whether the search has ended.
    #[getter]
    fn finished(&self) -> bool {
        self.run.finished()
    }

    /// Nodes scored so far.
    #[getter]
    fn nodes(&self) -> u64 {
        self.run.nodes()
    }

    /// The candidates so far refined by ICP with `settings` and ranked (see `relocalize`).
    /// Releases the GIL.
    #[pyo3(signature = (settings, max_candidates, ambiguity_margin))]
    fn finish(
        &self,
        py: Python<'_>,
        settings: &IcpSettings,
        max_candidates: usize,
        ambiguity_margin: f64,
    ) -> PyResult<Relocalization> {
        let icp = settings.inner.clone();
        let ranking = RankingConfig { max_candidates, ambiguity_margin };
        let outcome = self.run.outcome();
        let out = interruptible(py, |cancel| {
            core_refine(&self.map, &self.matcher, &self.scan, outcome, &icp, &ranking, cancel)
        })?;
        wrap(py, out)
    }
}

/// One refined hypothesis of `relocalize`.
#[pyclass(frozen, module = "planicp._core")]
pub struct RelocalizationCandidate {
    #[pyo3(get)]
    pose: PoseTuple,
    #[pyo3(get)]
    score: f64,
    #[pyo3(get)]
    search_score: f64,
    #[pyo3(get)]
    search_pose: PoseTuple,
    #[pyo3(get)]
    alignment: Py<Alignment>,
}

/// The raw outcome of `relocalize`; `planicp.Relocalization` wraps it.
#[pyclass(frozen, module = "planicp._core")]
pub struct Relocalization {
    #[pyo3(get)]
    candidates: Vec<Py<RelocalizationCandidate>>,
    #[pyo3(get)]
    ambiguity: f64,
    #[pyo3(get)]
    ambiguous: bool,
    #[pyo3(get)]
    rotations: usize,
    #[pyo3(get)]
    angular_step: f64,
    #[pyo3(get)]
    nodes: u64,
    #[pyo3(get)]
    complete: bool,
    #[pyo3(get)]
    scan_points: usize,
}

/// Global relocalization of scan points (N, 2, robot frame, metres) on the matcher's plan: over
/// the whole plan, or within `window` (x, y, yaw, half_width, half_angle, lever_x, lever_y).
/// Releases the GIL.
#[pyfunction]
#[pyo3(signature = (matcher, scan, window, settings, max_candidates, ambiguity_margin))]
pub fn relocalize(
    py: Python<'_>,
    matcher: &GlobalMatcher,
    scan: PyReadonlyArray2<'_, f64>,
    window: Option<WindowTuple>,
    settings: &IcpSettings,
    max_candidates: usize,
    ambiguity_margin: f64,
) -> PyResult<Relocalization> {
    let pts = points_from("scan points", &scan)?;
    let (map, core) = (Arc::clone(&matcher.map), Arc::clone(&matcher.inner));
    let icp = settings.inner.clone();
    let ranking = RankingConfig { max_candidates, ambiguity_margin };
    let window = window_from(window);
    let out = interruptible(py, |cancel| {
        core_relocalize(&map, &core, &pts, window.as_ref(), &icp, &ranking, cancel)
    })?;
    wrap(py, out)
}

/// The Python view of a core relocalization.
fn wrap(py: Python<'_>, out: icp_core::search::relocalization::Relocalization) -> PyResult<Relocalization> {
    let candidates = out
        .candidates
        .into_iter()
        .map(|c| {
            let alignment = Py::new(py, Alignment { inner: c.alignment })?;
            Py::new(
                py,
                RelocalizationCandidate {
                    pose: tuple(c.pose),
                    score: c.score,
                    search_score: c.search_score,
                    search_pose: tuple(c.search_pose),
                    alignment,
                },
            )
        })
        .collect::<PyResult<Vec<_>>>()?;
    Ok(Relocalization {
        candidates,
        ambiguity: out.ambiguity,
        ambiguous: out.ambiguous,
        rotations: out.search.rotations,
        angular_step: out.search.angular_step,
        nodes: out.search.nodes,
        complete: out.search.complete,
        scan_points: out.search.scan_points,
    })
}
