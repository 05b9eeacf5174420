//! The exceptions of `planicp._core` and the boundary every call into the core goes through: a
//! core error becomes `PlanicpError` (a `ValueError`), a panic `PlanicpInternalError` (a
//! `RuntimeError`) instead of crossing into Python.

use icp_core::IcpError;
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};

create_exception!(
    _core,
    PlanicpError,
    PyValueError,
    "An input planicp cannot work with; the message names the problem."
);
create_exception!(
    _core,
    PlanicpInternalError,
    PyRuntimeError,
    "A bug inside planicp's native core (a Rust panic, caught at the boundary). Please report it."
);

/// A core error as a `PlanicpError`.
pub(crate) fn core_error(err: IcpError) -> PyErr {
    PlanicpError::new_err(err.to_string())
}

/// Runs `f`, turning a core error into `PlanicpError` and a panic into `PlanicpInternalError`.
pub(crate) fn guarded<T>(f: impl FnOnce() -> Result<T, IcpError>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(core_error(e)),
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(PlanicpInternalError::new_err(format!("internal error in planicp's native core: {msg}")))
        }
    }
}

/// Panics inside the guarded boundary, to prove that a panic surfaces as PlanicpInternalError.
#[pyfunction]
pub(crate) fn _panic_for_tests() -> PyResult<()> {
    guarded(|| -> Result<(), IcpError> { panic!("deliberate panic for the boundary test") })
}
