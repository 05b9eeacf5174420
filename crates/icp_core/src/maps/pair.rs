//! A scan point paired with a plan point: what a nearest-point look-up answers for one scan point
//! (the nearest-wall index's, [`crate::maps::nearest_wall_index`], or a KD-tree's,
//! [`crate::icp::correspondence`]), and what the steps of an alignment work on.

/// A scan point paired with a plan point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// Index into the scan points.
    pub source: u32,
    /// Index into the plan's points.
    pub target: u32,
    /// Squared distance between them, square metres.
    pub sq_dist: f64,
}
