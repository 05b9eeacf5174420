//! The settings of one alignment ([`IcpConfig`]), their checks, and the schedule of stages they
//! imply: each stage's rejection distance and the range of the visibility cast.

use crate::error::{invalid, Result};
use crate::icp::termination::Tolerances;

/// The range (metres) of the visibility cast for `scan` (robot frame): `config.visibility_range`,
/// or the scan's farthest point plus the largest stage distance, so that every plan point a scan
/// point could pair with is cast.
pub fn visibility_range(scan: &[[f64; 2]], config: &IcpConfig) -> f64 {
    let range = match config.visibility_range {
        Some(r) => r,
        None => {
            let farthest = scan.iter().map(|p| p[0].hypot(p[1])).fold(0.0, f64::max);
            farthest + largest_pair_distance(config)
        }
    };
    // A huge correspondence distance can make the sum overflow; nothing lies beyond a few times
    // the coordinate limit anyway (found by the fuzz target).
    range.min(4.0 * crate::error::MAX_COORDINATE)
}

/// The farthest a scan point and a plan point can be apart and still be paired by an alignment
/// with `config` (metres): the largest schedule factor (at least 1) times
/// `max_correspondence_distance`; no stage rejects farther (the spacing floor of
/// [`stage_distance`] never exceeds `max_correspondence_distance`).
pub fn largest_pair_distance(config: &IcpConfig) -> f64 {
    let largest_factor = config.correspondence_schedule.iter().copied().fold(1.0, f64::max);
    largest_factor * config.max_correspondence_distance
}

/// A stage's rejection distance: `factor * max_distance`, but never below `SPACING_FLOOR` plan
/// point spacings (nor above `max_distance`): closer than that, correct pairs are lost to the
/// plan's sampling (a scan point between two samples is half a spacing from both) plus noise.
pub fn stage_distance(factor: f64, max_distance: f64, spacing: f64) -> f64 {
    let floor = (SPACING_FLOOR * spacing).min(max_distance);
    (factor * max_distance).max(floor)
}

/// See [`stage_distance`].
pub const SPACING_FLOOR: f64 = 2.0;

/// Settings of one alignment. Distances in metres, angles in radians.
#[derive(Clone, Debug, PartialEq)]
pub struct IcpConfig {
    /// Pairs farther apart than this are outliers (things not in the plan).
    pub max_correspondence_distance: f64,
    /// Most iterations over all stages.
    pub max_iterations: usize,
    /// Share (0, 1] of the in-range pairs, the closest ones, used by each update (with
    /// `auto_trim`: the most that may be kept).
    pub trim_ratio: f64,
    /// Drop pairs beyond three robust standard deviations of the pair distances at every
    /// iteration ([`crate::icp::correspondence::trim_auto`]); `trim_ratio` caps what is kept.
    pub auto_trim: bool,
    /// A stage stops when a step moves less than this (and rotates less than `rotation_tolerance`).
    pub translation_tolerance: f64,
    /// See `translation_tolerance`. Both zero: every iteration runs.
    pub rotation_tolerance: f64,
    /// Use every k-th scan point for the iterations (all points are scored at the end).
    pub subsample: usize,
    /// Stage distances as factors of `max_correspondence_distance`, applied in order.
    pub correspondence_schedule: Vec<f64>,
    /// Match only against the plan points visible from the initial guess.
    pub use_visibility: bool,
    /// Extrapolate slowly converging iterations (see [`crate::icp::acceleration`]).
    pub accelerate: bool,
    /// Range for the visibility ray casting; `None`: the scan's farthest point plus the largest
    /// stage distance.
    pub visibility_range: Option<f64>,
    /// How nearest plan points are found.
    pub search: CorrespondenceSearch,
}

/// How the nearest plan point of a scan point is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CorrespondenceSearch {
    /// The plan's precomputed nearest-wall index ([`crate::maps::nearest_wall_index`]): a few
    /// nanoseconds per look-up. `use_visibility` refuses pairings with the far face of a wall
    /// ([`crate::visibility::wall_facing`]) instead of ray casting. Alignments whose largest stage distance
    /// exceeds the index's reach, or plans whose index cannot be built, use the KD-tree.
    #[default]
    WallIndex,
    /// Exact KD-tree queries (against the points visible from the initial guess with
    /// `use_visibility`), reused across iterations by a
    /// [`CandidateCache`](crate::icp::candidate_cache::CandidateCache).
    KdTree,
}

impl Default for IcpConfig {
    fn default() -> Self {
        Self {
            max_correspondence_distance: 0.25,
            max_iterations: 30,
            trim_ratio: 1.0,
            auto_trim: false,
            translation_tolerance: 1e-4,
            rotation_tolerance: 1e-4,
            subsample: 1,
            correspondence_schedule: vec![1.0, 0.5, 0.25],
            use_visibility: true,
            accelerate: true,
            visibility_range: None,
            search: CorrespondenceSearch::default(),
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

impl IcpConfig {
    /// Checks every value; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        positive_finite("max_correspondence_distance", self.max_correspondence_distance)?;
        if self.max_iterations == 0 {
            return Err(invalid("max_iterations", 0, "must be at least 1"));
        }
        if !(self.trim_ratio > 0.0 && self.trim_ratio <= 1.0) {
            return Err(invalid("trim_ratio", self.trim_ratio, "must be in (0, 1]"));
        }
        for (name, v) in [
            ("translation_tolerance", self.translation_tolerance),
            ("rotation_tolerance", self.rotation_tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(name, v, "must be a finite number >= 0 (0 disables it)"));
            }
        }
        if self.subsample == 0 {
            return Err(invalid("subsample", 0, "must be at least 1"));
        }
        if self.correspondence_schedule.is_empty() {
            return Err(invalid("correspondence_schedule", "[]", "needs at least one stage"));
        }
        for &f in &self.correspondence_schedule {
            positive_finite("correspondence_schedule factor", f)?;
        }
        if let Some(r) = self.visibility_range {
            positive_finite("visibility_range", r)?;
        }
        Ok(())
    }

    pub(crate) fn tolerances(&self) -> Tolerances {
        Tolerances { translation: self.translation_tolerance, rotation: self.rotation_tolerance }
    }
}
