//! `planicp._core`: a thin pyo3 layer over `icp_core`.
//!
//! Inputs are copied out of numpy arrays, the GIL is released for the numerical work, core errors
//! become `PlanicpError` (a `ValueError`), and a panic inside the core is caught and raised as
//! `PlanicpInternalError` (a `RuntimeError`) instead of crossing into Python. Calls that can run
//! for seconds on their input (alignments, searches, map and index builds) look for Python signals
//! every 50 ms, so that Ctrl-C stops them with KeyboardInterrupt.
//!
//! One file per concept: `point_map` (the plan and what a pose sees of it), `alignment` (ICP
//! settings, `align`), `occupancy_grid` (the simulated LIDAR's raster), `log_odds_grid`, `likelihood_grid` (the plan's
//! likelihood field and the pose of highest posterior in it),
//! `global_search` (relocalization); `errors`, `interrupt` and `conversions` are the
//! boundary they share. This file only registers them in the module `_core`.

use pyo3::prelude::*;

mod alignment;
mod conversions;
mod errors;
mod global_search;
mod interrupt;
mod likelihood_grid;
mod log_odds_grid;
mod occupancy_grid;
mod point_map;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("MIN_SCAN_POINTS", icp_core::icp::rigid_solver::MIN_PAIRS)?;
    m.add("MIN_SEARCH_POINTS", icp_core::search::global_search::MIN_SEARCH_POINTS)?;
    m.add("MAX_RASTER_CELLS", icp_core::grids::wall_raster::MAX_RASTER_CELLS)?;
    m.add("PlanicpError", m.py().get_type::<errors::PlanicpError>())?;
    m.add("PlanicpInternalError", m.py().get_type::<errors::PlanicpInternalError>())?;
    m.add_class::<point_map::PyPointMap>()?;
    m.add_class::<alignment::IcpSettings>()?;
    m.add_class::<alignment::Alignment>()?;
    m.add_class::<point_map::WallView>()?;
    m.add_class::<occupancy_grid::OccupancyGrid>()?;
    m.add_class::<log_odds_grid::LogOddsGrid>()?;
    m.add_class::<likelihood_grid::LikelihoodGrid>()?;
    m.add_class::<global_search::GlobalMatcher>()?;
    m.add_class::<global_search::Relocalization>()?;
    m.add_class::<global_search::RelocalizationCandidate>()?;
    m.add_class::<global_search::SearchRun>()?;
    m.add_function(wrap_pyfunction!(global_search::relocalize, m)?)?;
    m.add_function(wrap_pyfunction!(alignment::align, m)?)?;
    m.add_function(wrap_pyfunction!(alignment::visibility_range, m)?)?;
    m.add_function(wrap_pyfunction!(alignment::largest_pair_distance, m)?)?;
    m.add_function(wrap_pyfunction!(errors::_panic_for_tests, m)?)?;
    Ok(())
}
