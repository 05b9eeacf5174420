//! ICP: a scan aligned to the plan from an initial guess.
//!
//! - [`alignment`]: the trimmed, coarse-to-fine ICP loop and its result ([`align`], [`IcpResult`],
//!   re-exported here).
//! - [`icp_config`]: the settings of an alignment ([`IcpConfig`], re-exported here) and the stages
//!   they imply.
//! - [`correspondence`]: nearest-point pairing with a maximum distance, and trimming.
//! - [`visible_through_index`]: nearest *visible* plan points, answered mostly by the nearest-wall index.
//! - [`candidate_cache`]: exact reuse of radius queries across ICP iterations (the KD-tree search).
//! - [`rigid_solver`]: the closed-form least-squares rigid transform between paired points.
//! - [`termination`]: when an ICP stage stops.
//! - [`acceleration`]: extrapolation of slowly converging iterations, with a safeguard.
//! - [`covariance`]: the pose covariance of a finished alignment.
//! - [`posterior_refinement`]: the pose of highest posterior in the plan's likelihood field, given
//!   a prior (the odometry prediction).

pub mod acceleration;
pub mod alignment;
pub mod candidate_cache;
pub mod correspondence;
pub mod covariance;
pub mod icp_config;
pub mod posterior_refinement;
pub mod rigid_solver;
pub mod termination;
pub mod visible_through_index;

pub use alignment::{align, IcpResult};
pub use icp_config::{largest_pair_distance, visibility_range, CorrespondenceSearch, IcpConfig};
