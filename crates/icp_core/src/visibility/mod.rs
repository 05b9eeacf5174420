//! Visibility: which parts of the plan a range sensor can see, cast through the
//! [`wall_raster`](crate::grids::wall_raster).
//!
//! - [`visible_points`]: the wall points a sensor at a position sees (a fan of rays, refined at
//!   depth jumps).
//! - [`wall_view`]: one cast from a pose for both the visible points and each direction's wall range.
//! - [`wall_facing`]: the directions each wall point can be seen from, to refuse pairings with hidden
//!   faces without casting.

pub mod visible_points;
pub mod wall_facing;
pub mod wall_view;
