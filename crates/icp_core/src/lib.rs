//! `icp_core`: the numerical engine of planicp.
//!
//! Aligns 2D LIDAR scans to a floor plan given as wall-surface points (metres, map frame).
//! Everything here is pure Rust; the Python bindings live in the `planicp_py` crate.
//!
//! One concept per module:
//! - [`pose`]: SE(2) poses (x, y, yaw) and their composition.
//! - [`maps`]: the plan's wall points with their KD-tree, normals and visibility raster, built once,
//!   and the nearest-wall index that pairs scan points with them.
//! - [`grids`]: rasters and beams through them: cell traversal, clearance, the wall raster, the
//!   simulated LIDAR, the log-odds occupancy grid.
//! - [`visibility`]: which wall points a LIDAR at a pose can see (ray casting), the ranges to the
//!   walls, and the directions each wall point can be seen from.
//! - [`correspondence`]: nearest-point pairing with a maximum distance.
//! - [`candidate_cache`]: exact reuse of radius queries across ICP iterations.
//! - [`rigid_solver`]: the closed-form least-squares rigid transform between paired points.
//! - [`termination`]: when an ICP stage stops.
//! - [`acceleration`]: extrapolation of slowly converging iterations, with a safeguard.
//! - [`icp`]: the trimmed, coarse-to-fine ICP loop and its configuration and result.
//! - [`likelihood_field`]: the plan as a likelihood raster with max-pooled levels.
//! - [`global_search`]: correlative branch-and-bound search for a pose with no initial guess.
//! - [`relocalization`]: global search candidates refined by ICP, ranked, with their ambiguity.
//! - [`covariance`]: the pose covariance of a finished alignment.
//! - [`error`]: every way the core can refuse its input.
//! - [`cancel`]: the hook through which a caller stops a long computation (Ctrl-C).

pub mod acceleration;
pub mod cancel;
pub mod candidate_cache;
pub mod correspondence;
pub mod covariance;
pub mod error;
pub mod global_search;
pub mod grids;
pub mod icp;
pub mod likelihood_field;
pub mod maps;
pub mod pose;
pub mod relocalization;
pub mod rigid_solver;
pub mod termination;
pub mod visibility;
pub mod visible_through_index;

pub use error::{IcpError, Result};
pub use icp::{align, IcpConfig, IcpResult};
pub use maps::point_map::PointMap;
pub use pose::Pose2;
