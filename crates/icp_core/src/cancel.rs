//! Asking a long computation to stop: a hook the core polls between units of work.
//!
//! The core's long loops (ICP iterations, batches of global-search nodes, batches of plan points
//! while a map and its nearest-wall index are built) call a [`Cancel`] hook between units of work;
//! when it returns true they stop with [`IcpError::Interrupted`], leaving nothing half-built behind
//! (a [`crate::search::global_search::SearchRun`] can be advanced again). The hook is called often, up to
//! a few million times a second on small units, so it should be cheap: the Python binding's reads
//! the clock and looks for Ctrl-C (`PyErr_CheckSignals`) at most every 50 ms.

use crate::error::{IcpError, Result};

/// Polled between units of work; returning true stops the computation with
/// [`IcpError::Interrupted`].
pub type Cancel<'a> = &'a dyn Fn() -> bool;

fn never_stop() -> bool {
    false
}

/// A hook that never asks to stop, for callers that cannot be cancelled: given it, no function
/// returns [`IcpError::Interrupted`].
pub const NEVER: Cancel<'static> = &never_stop;

/// `Err(Interrupted)` when `cancel` asks to stop.
#[inline]
pub fn check(cancel: Cancel<'_>) -> Result<()> {
    if cancel() {
        Err(IcpError::Interrupted)
    } else {
        Ok(())
    }
}

/// Points (or cells, or blocks) handled between two polls in the per-point loops of map building.
pub const POLL_EVERY: usize = 4096;

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    #[test]
    fn never_never_stops_and_a_hook_that_says_so_does() {
        assert_eq!(check(NEVER), Ok(()));
        let calls = Cell::new(0);
        let after_two = || {
            calls.set(calls.get() + 1);
            calls.get() > 2
        };
        assert_eq!(check(&after_two), Ok(()));
        assert_eq!(check(&after_two), Ok(()));
        assert_eq!(check(&after_two), Err(IcpError::Interrupted));
    }
}
