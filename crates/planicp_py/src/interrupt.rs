//! Ctrl-C during a long native call: calls that can run for seconds on their input (alignments,
//! searches, map and index builds) hand the core a cancel hook (`icp_core::cancel`) that looks for
//! Python signals.

use crate::errors::guarded;
use icp_core::cancel::Cancel;
use icp_core::IcpError;
use pyo3::prelude::*;
use std::cell::{Cell, RefCell};
use std::time::{Duration, Instant};

/// Longest a native call runs between two looks for Python signals (Ctrl-C), seconds.
const SIGNAL_CHECK_INTERVAL: Duration = Duration::from_millis(50);

/// The hook a long core computation polls (`icp_core::cancel`): at most every
/// [`SIGNAL_CHECK_INTERVAL`] it attaches to Python and runs its signal handlers; an exception they
/// raise (KeyboardInterrupt for Ctrl-C) is kept and stops the computation. Between those looks a
/// poll only reads the clock.
struct SignalCheck {
    last: Cell<Instant>,
    raised: RefCell<Option<PyErr>>,
}

impl SignalCheck {
    fn new() -> Self {
        Self { last: Cell::new(Instant::now()), raised: RefCell::new(None) }
    }

    fn poll(&self) -> bool {
        if self.raised.borrow().is_some() {
            return true;
        }
        let now = Instant::now();
        if now.duration_since(self.last.get()) < SIGNAL_CHECK_INTERVAL {
            return false;
        }
        self.last.set(now);
        // No Python to ask (the interpreter is shutting down): go on.
        match Python::try_attach(|py| py.check_signals()) {
            Some(Err(raised)) => {
                *self.raised.borrow_mut() = Some(raised);
                true
            }
            _ => false,
        }
    }
}

/// Runs `f` with the GIL released, as [`guarded`] does, handing it a cancel hook that looks for
/// Python signals every [`SIGNAL_CHECK_INTERVAL`]: a Ctrl-C during a long computation stops it
/// and raises its KeyboardInterrupt (not a PlanicpError) when `f` has returned.
pub(crate) fn interruptible<T: Send>(
    py: Python<'_>,
    f: impl FnOnce(Cancel<'_>) -> Result<T, IcpError> + Send,
) -> PyResult<T> {
    py.detach(|| {
        let signals = SignalCheck::new();
        let out = guarded(|| f(&|| signals.poll()));
        match signals.raised.into_inner() {
            Some(raised) => Err(raised),
            None => out,
        }
    })
}
