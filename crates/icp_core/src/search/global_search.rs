//! Global scan matching with no initial guess: a correlative search with branch and bound.
//!
//! The fast correlative scan matcher of Olson (2009), as in Cartographer's
//! `FastCorrelativeScanMatcher2D` (Hess et al. 2016):
//! 1. The scan is thinned on a voxel grid of the search resolution (at most `max_scan_points`).
//! 2. Rotations are swept at `angular_step` (2 degrees by default), or at a step that moves the
//!    far scan points by about one cell (`acos(1 - res^2 / (2 r^2))`, `r` the 95th percentile of
//!    the scan's ranges).
//! 3. For each rotation, translations on the cell lattice of the window are searched by branch
//!    and bound over the [`LikelihoodPyramid`]: a node covering a `2^h x 2^h` block of
//!    translations is bounded by the mean of the level-`h` values under the scan's cells, which no
//!    translation in the block can beat. All rotations share one priority queue: the node with
//!    the highest bound is expanded next (best first, so leaves come out best first), and nodes
//!    whose bound cannot enter the list of the best candidates are dropped. The queue holds at
//!    most `max_nodes` nodes (20 bytes each).
//! 4. The best `max_candidates` leaves that are distinct (farther apart than `nms_distance` metres
//!    or `nms_angle` radians) are kept (non-maximum suppression), with their score: the mean
//!    likelihood of the scan's points, i.e. the share of them the plan explains (0..1). Leaves
//!    below `relative_score` times the best score are no rivals and are pruned too.
//!
//! The result is a set of hypotheses on a `resolution` lattice; [`crate::search::relocalization`] refines
//! them with ICP and ranks them.
//!
//! This file holds the settings, the window, the results and the [`GlobalMatcher`]; the search's
//! parts are its submodules: `search_space` thins the scan and lays out the rotations and the
//! translation lattice (steps 1-2), `node_scoring` bounds a block of translations by the pyramid
//! and keeps the best distinct leaves (3-4), and `branch_and_bound` expands the nodes best first, a
//! budget of nodes at a time, where a search stops when cancelled ([`SearchRun`]).

use crate::cancel::Cancel;
use crate::error::{check_finite, invalid, Result};
use crate::grids::bounding_box::bounding_box;
use crate::maps::point_map::PointMap;
use crate::pose::Pose2;
use crate::search::likelihood_field::{LikelihoodPyramid, MAX_LEVELS};

mod branch_and_bound;
mod node_scoring;
mod search_space;

pub use branch_and_bound::SearchRun;

/// Fewest scan points (after the voxel thinning) a global search accepts.
pub const MIN_SEARCH_POINTS: usize = 10;

/// Most rotations one search may sweep.
pub const MAX_ROTATIONS: usize = 20_000;

/// Nodes scored between two polls of a [`Cancel`] hook (a node costs tens to hundreds of
/// nanoseconds: a poll every 0.1 ms or so).
pub const NODES_PER_POLL: u64 = 1024;

/// Settings of the global search. Distances in metres, angles in radians.
#[derive(Clone, Debug, PartialEq)]
pub struct GlobalSearchConfig {
    /// Cell size of the likelihood field and of the translation lattice.
    pub resolution: f64,
    /// Width of the likelihood Gaussian around each wall.
    pub sigma: f64,
    /// Pyramid levels; the coarsest block is `2^(levels-1)` cells wide.
    pub levels: usize,
    /// Rotation step (default 2 degrees: ICP refines a heading from far wider); `None`: from the
    /// resolution and the scan's extent (see the module docs).
    pub angular_step: Option<f64>,
    /// Largest automatic rotation step.
    pub max_angular_step: f64,
    /// Most candidates returned.
    pub max_candidates: usize,
    /// Candidates scoring below this (share of scan points explained, 0..1) are not returned.
    pub min_score: f64,
    /// Candidates scoring below this share of the best candidate's score are not returned either:
    /// they are no rivals of the best, and pruning them early is what keeps large plans fast.
    pub relative_score: f64,
    /// Two poses closer than this in position and `nms_angle` in heading are the same candidate.
    pub nms_distance: f64,
    /// See `nms_distance`.
    pub nms_angle: f64,
    /// The scan is thinned to at most this many points.
    pub max_scan_points: usize,
    /// Budget of scored search nodes; the search stops there and says it is incomplete.
    pub max_nodes: u64,
}

impl Default for GlobalSearchConfig {
    fn default() -> Self {
        Self {
            resolution: 0.2,
            sigma: 0.2,
            levels: 6,
            angular_step: Some(2f64.to_radians()),
            max_angular_step: 2f64.to_radians(),
            max_candidates: 8,
            min_score: 0.2,
            relative_score: 0.8,
            nms_distance: 1.0,
            nms_angle: 20f64.to_radians(),
            max_scan_points: 100,
            max_nodes: 4_000_000,
        }
    }
}

fn positive_finite(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(invalid(name, v, "must be a positive finite number"))
    }
}

impl GlobalSearchConfig {
    /// Checks every value; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        positive_finite("resolution", self.resolution)?;
        positive_finite("sigma", self.sigma)?;
        if !(1..=MAX_LEVELS).contains(&self.levels) {
            return Err(invalid("levels", self.levels, "must be between 1 and 12"));
        }
        if let Some(step) = self.angular_step {
            positive_finite("angular_step", step)?;
        }
        positive_finite("max_angular_step", self.max_angular_step)?;
        if self.max_candidates == 0 {
            return Err(invalid("max_candidates", 0, "must be at least 1"));
        }
        if !(self.min_score.is_finite() && (0.0..1.0).contains(&self.min_score)) {
            return Err(invalid("min_score", self.min_score, "must be in [0, 1)"));
        }
        if !(self.relative_score.is_finite() && (0.0..=1.0).contains(&self.relative_score)) {
            return Err(invalid("relative_score", self.relative_score, "must be in [0, 1]"));
        }
        positive_finite("nms_distance", self.nms_distance)?;
        positive_finite("nms_angle", self.nms_angle)?;
        if self.max_scan_points < MIN_SEARCH_POINTS {
            return Err(invalid("max_scan_points", self.max_scan_points, "must be at least 10"));
        }
        if self.max_nodes == 0 {
            return Err(invalid("max_nodes", 0, "must be at least 1"));
        }
        Ok(())
    }
}

/// Where to search: headings within `half_angle` radians of `center`'s yaw (`>= pi`: every
/// heading) and, at heading `yaw`, positions within `half_width` metres (a square) of `center`'s
/// position plus `lever` turned by `yaw - center.yaw`.
///
/// With a zero `lever` the positions are the same square at every heading. A nonzero one ties
/// position to heading: a robot that drove `lever` (map frame, metres) from `center`'s position
/// while its heading there was unknown is, at heading `yaw`, at the end of the lever turned by
/// the heading's error `yaw - center.yaw` (`center.yaw`: the heading the drive ends at when that
/// error is zero). The positions then form a ring of squares around `center` rather than a disk
/// of the lever's length, `(lever / half_width)^2 / pi` times fewer of them for a long lever.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchWindow {
    /// Centre of the window, `T_map_base`.
    pub center: Pose2,
    /// Half the side of the square of positions, metres.
    pub half_width: f64,
    /// Half the range of headings, radians.
    pub half_angle: f64,
    /// Offset of the square from `center` at heading `center.yaw` (map frame, metres), turned
    /// with the heading.
    pub lever: [f64; 2],
}

impl SearchWindow {
    /// A square of half-width `half_width` around `center` at every heading within `half_angle`
    /// of its yaw (no lever).
    pub fn new(center: Pose2, half_width: f64, half_angle: f64) -> Self {
        SearchWindow { center, half_width, half_angle, lever: [0.0, 0.0] }
    }

    /// The centre of the square of positions searched at heading `yaw` (map frame, metres).
    pub fn center_at(&self, yaw: f64) -> [f64; 2] {
        let (s, c) = (yaw - self.center.yaw).sin_cos();
        let [lx, ly] = self.lever;
        [self.center.x + c * lx - s * ly, self.center.y + s * lx + c * ly]
    }

    /// Checks the window.
    pub fn validate(&self) -> Result<()> {
        if !self.center.is_finite() {
            return Err(invalid("window center", format!("{:?}", self.center), "must be finite"));
        }
        check_finite("window center", &[[self.center.x, self.center.y]])?;
        check_finite("window lever", &[self.lever])?;
        if !(self.half_width.is_finite() && self.half_width >= 0.0) {
            return Err(invalid("window half_width", self.half_width, "must be a finite number >= 0 metres"));
        }
        if !(self.half_angle.is_finite() && self.half_angle >= 0.0) {
            return Err(invalid(
                "window half_angle",
                self.half_angle,
                "must be a finite number >= 0 radians",
            ));
        }
        Ok(())
    }
}

/// One hypothesis of the search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// `T_map_base` on the search lattice.
    pub pose: Pose2,
    /// Mean likelihood of the thinned scan's points at `pose`, 0..1.
    pub score: f64,
}

/// What a search found and what it cost.
#[derive(Clone, Debug, PartialEq)]
pub struct SearchOutcome {
    /// Distinct candidates, best first.
    pub candidates: Vec<Candidate>,
    /// Rotations swept.
    pub rotations: usize,
    /// Rotation step used, radians.
    pub angular_step: f64,
    /// Search nodes scored.
    pub nodes: u64,
    /// False when `max_nodes` stopped the search before it proved its candidates the best.
    pub complete: bool,
    /// Scan points used after thinning.
    pub scan_points: usize,
}

/// The likelihood pyramid of a plan with the search settings; built once, searched many times.
#[derive(Debug, Clone)]
pub struct GlobalMatcher {
    pyramid: LikelihoodPyramid,
    config: GlobalSearchConfig,
    /// Plan bounding box: lower and upper corners.
    bounds: [[f64; 2]; 2],
}

impl GlobalMatcher {
    /// Builds the likelihood pyramid of `map`'s wall points.
    pub fn new(map: &PointMap, config: GlobalSearchConfig) -> Result<Self> {
        config.validate()?;
        let pyramid = LikelihoodPyramid::new(map.points(), config.resolution, config.sigma, config.levels)?;
        let (lo, hi) = bounding_box(map.points());
        Ok(Self { pyramid, config, bounds: [lo, hi] })
    }

    /// The settings.
    pub fn config(&self) -> &GlobalSearchConfig {
        &self.config
    }

    /// The likelihood pyramid.
    pub fn pyramid(&self) -> &LikelihoodPyramid {
        &self.pyramid
    }

    /// Mean likelihood (level 0) of the scan's points (robot frame) at `pose`, 0..1.
    pub fn score_at(&self, scan: &[[f64; 2]], pose: Pose2) -> f64 {
        if scan.is_empty() {
            return 0.0;
        }
        let sum: f64 = scan.iter().map(|p| self.pyramid.value_at(pose.transform_point(*p))).sum();
        sum / scan.len() as f64
    }
    /// Searches the whole plan (`window` `None`) or a window for the poses that best explain
    /// `scan` (points in the robot frame, metres).
    ///
    /// `cancel` is polled every [`NODES_PER_POLL`] nodes; when it returns true the search stops
    /// with [`IcpError::Interrupted`](crate::error::IcpError::Interrupted) (callers that cannot be
    /// cancelled pass [`cancel::NEVER`](crate::cancel::NEVER)).
    pub fn search(
        &self,
        scan: &[[f64; 2]],
        window: Option<&SearchWindow>,
        cancel: Cancel<'_>,
    ) -> Result<SearchOutcome> {
        let mut run = self.start(scan, window)?;
        run.advance(self, u64::MAX, cancel)?;
        Ok(run.outcome())
    }
}

#[cfg(test)]
pub(crate) mod tests;
