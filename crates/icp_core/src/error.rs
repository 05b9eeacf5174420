//! Errors: every way the core refuses its input, each with a message that names the problem.

/// Result type of the core.
pub type Result<T> = std::result::Result<T, IcpError>;

/// An input the core cannot work with. The bindings turn each into a Python `ValueError`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IcpError {
    /// A point set that must hold points holds none.
    #[error("{what} is empty: it needs at least one point")]
    Empty {
        /// Which input.
        what: &'static str,
    },
    /// A coordinate is NaN or infinite.
    #[error("{what} has a non-finite coordinate (NaN or inf) at row {row}")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Row of the first offending point.
        row: usize,
    },
    /// A coordinate is finite but too large to be metres in a building.
    #[error(
        "{what} has a coordinate of {value:e} m at row {row}, beyond +-{MAX_COORDINATE:e} m; \
         planicp works in metres: express the points in a local frame"
    )]
    OutOfRange {
        /// Which input.
        what: &'static str,
        /// Row of the first offending point.
        row: usize,
        /// The offending value.
        value: f64,
    },
    /// Fewer usable points than the computation needs.
    #[error("{what} has {got} usable points; at least {need} are needed")]
    TooFewPoints {
        /// Which input.
        what: &'static str,
        /// How many there were.
        got: usize,
        /// How many are needed.
        need: usize,
    },
    /// A configuration value outside its allowed range.
    #[error("invalid {name} = {value}: {requirement}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// What it must satisfy.
        requirement: &'static str,
    },
    /// A raster over a plan (its visibility raster, nearest-wall index or likelihood field) would
    /// be too large to hold.
    #[error(
        "the plan's {what} at {resolution} m would need {cells} cells (limit {limit}); give a coarser \
         resolution, or check the plan for points far from its walls (wrong units, stray points)"
    )]
    RasterTooLarge {
        /// Which raster.
        what: &'static str,
        /// Requested resolution, metres per cell.
        resolution: f64,
        /// Cells it would need.
        cells: f64,
        /// The most cells allowed.
        limit: usize,
    },
    /// An occupancy grid would need more cells than its budget allows.
    #[error(
        "the occupancy grid at {resolution} m would need {cells} cells (limit {limit}); \
         give a coarser resolution, a larger cell budget or a shorter max_range"
    )]
    GridTooLarge {
        /// Cells it would need.
        cells: f64,
        /// The most cells allowed.
        limit: usize,
        /// Resolution, metres per cell.
        resolution: f64,
    },
    /// Memory for an input-sized buffer could not be had.
    #[error(
        "could not allocate {bytes} bytes for {what}; the machine has not that much memory free: \
         give a smaller size (a coarser resolution, a smaller cell budget or region)"
    )]
    OutOfMemory {
        /// What the memory was for.
        what: &'static str,
        /// How many bytes were asked for.
        bytes: u128,
    },
    /// The caller's [`crate::cancel::Cancel`] hook asked the computation to stop (in Python: a
    /// signal such as Ctrl-C arrived; the binding raises its exception instead of this error).
    #[error("interrupted: the caller asked the computation to stop")]
    Interrupted,
}

/// A vector of `n` copies of `value`, allocated fallibly: an error instead of an abort when the
/// memory cannot be had (`n` comes from the input: a grid's or raster's size).
pub fn try_filled<T: Clone>(n: usize, value: T, what: &'static str) -> Result<Vec<T>> {
    let mut v: Vec<T> = Vec::new();
    v.try_reserve_exact(n).map_err(|_| IcpError::OutOfMemory {
        what,
        bytes: (n as u128) * (std::mem::size_of::<T>() as u128),
    })?;
    v.resize(n, value);
    Ok(v)
}

/// Largest coordinate magnitude accepted, metres. At 1e9 m a double still resolves 0.1 micrometre;
/// far beyond it, centimetre geometry and the rasters built from it break down.
pub const MAX_COORDINATE: f64 = 1e9;

/// Checks that every coordinate of `points` is finite and within [`MAX_COORDINATE`].
pub fn check_finite(what: &'static str, points: &[[f64; 2]]) -> Result<()> {
    for (row, p) in points.iter().enumerate() {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(IcpError::NonFinite { what, row });
        }
        if p[0].abs() > MAX_COORDINATE || p[1].abs() > MAX_COORDINATE {
            let value = if p[0].abs() > p[1].abs() { p[0] } else { p[1] };
            return Err(IcpError::OutOfRange { what, row, value });
        }
    }
    Ok(())
}

/// Builds an [`IcpError::InvalidParameter`].
pub fn invalid(name: &'static str, value: impl std::fmt::Display, requirement: &'static str) -> IcpError {
    IcpError::InvalidParameter { name, value: value.to_string(), requirement }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_allocation_the_machine_cannot_make_is_an_error() {
        let err = try_filled(usize::MAX / 16, 0u64, "a test buffer").unwrap_err();
        assert!(matches!(err, IcpError::OutOfMemory { what: "a test buffer", .. }), "{err}");
        assert!(err.to_string().contains("could not allocate"), "{err}");
        assert_eq!(try_filled(3, 7u8, "a small buffer").unwrap(), vec![7, 7, 7]);
    }
}
