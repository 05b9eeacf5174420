//! `icp_core`: the numerical engine of planicp.
//!
//! Aligns 2D LIDAR scans to a floor plan given as wall-surface points (metres, map frame).
//! Everything here is pure Rust; the Python bindings live in the `planicp_py` crate.
//!
//! One folder per concept, each built on the ones listed before it (a module never imports a
//! later folder; `tests/module_layers.rs` checks it):
//! - [`pose`]: SE(2) poses (x, y, yaw), their composition and the one angle wrap.
//! - [`error`]: every way the core can refuse its input.
//! - [`cancel`]: the hook through which a caller stops a long computation (Ctrl-C).
//! - [`parallel`]: one-time preparation spread over the cores, in chunks, stoppable.
//! - [`grids`]: rasters and beams through them: cell traversal, clearance, the wall raster, the
//!   simulated LIDAR, the log-odds occupancy grid.
//! - [`visibility`]: which wall points a LIDAR at a pose can see (ray casting), the ranges to the
//!   walls, and the directions each wall point can be seen from.
//! - [`maps`]: the plan's wall points with their KD-tree, normals and visibility raster, built once,
//!   and the nearest-wall index that pairs scan points with them.
//! - [`icp`]: the trimmed, coarse-to-fine ICP loop: correspondences, the rigid solver, when to
//!   stop, acceleration, and the covariance of the result.
//! - [`search`]: global localization: a likelihood field of the plan searched by branch and bound,
//!   its candidates refined by ICP and ranked.

pub mod cancel;
pub mod error;
pub mod grids;
pub mod icp;
pub mod maps;
pub mod parallel;
pub mod pose;
pub mod search;
pub mod visibility;

pub use error::{IcpError, Result};
pub use icp::{align, IcpConfig, IcpResult};
pub use maps::point_map::PointMap;
pub use pose::Pose2;
