//! Grids: rasters over the plane and the walks of beams through them.
//!
//! - [`bounding_box`]: the box around a set of points, which every raster over them spans.
//! - [`cell_traversal`]: the cells a segment passes through (Amanatides-Woo).
//! - [`clearance`]: each cell's distance to the nearest occupied one, so beams jump across empty space.
//! - [`wall_raster`]: the raster of the plan's wall points that visibility casts through.
//! - [`ray_casting`]: a simulated LIDAR: exact ranges through an occupancy raster, noise, dropouts.
//! - [`likelihood_grid`]: the plan as a likelihood field (a Gaussian of the distance to its points).
//! - [`log_odds_grid`]: the occupancy grid built from scans (log-odds, per-scan updates, growth).
//!
//! Nothing here knows about plans' points beyond their coordinates, nor about ICP.

pub mod bounding_box;
pub mod cell_traversal;
pub mod clearance;
pub mod likelihood_grid;
pub mod log_odds_grid;
pub mod ray_casting;
pub mod wall_raster;
