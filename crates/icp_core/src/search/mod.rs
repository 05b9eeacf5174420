//! Search: a pose found with no initial guess.
//!
//! - [`likelihood_field`]: the plan as a likelihood raster with max-pooled levels, the bound that
//!   branch and bound needs.
//! - [`global_search`]: correlative branch-and-bound search for a pose over a window or the whole plan.
//! - [`relocalization`]: global search candidates refined by ICP, ranked, with their ambiguity.

pub mod global_search;
pub mod likelihood_field;
pub mod relocalization;
