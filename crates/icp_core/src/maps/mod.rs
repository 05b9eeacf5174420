//! Maps: the plan as ICP sees it, and the indexes that find its nearest points.
//!
//! - [`point_map`]: the plan's wall points with their KD-tree, normals and visibility raster,
//!   built once and shared.
//! - [`kd_tree`]: the KD-tree over the wall points, split across the longer side (walls along an axis).
//! - [`nearest_wall_index`]: exact nearest-wall look-ups from a precomputed raster of candidates.
//! - [`wall_normals`]: the wall normal at every plan point (a line fitted to its neighbours).
//! - [`pair`]: a scan point paired with its nearest plan point, what the look-ups answer.
//! - [`bucket_grid`]: exact fixed-radius range queries over a small point set.

pub mod bucket_grid;
pub mod kd_tree;
pub mod nearest_wall_index;
pub mod pair;
pub mod point_map;
pub mod wall_normals;
