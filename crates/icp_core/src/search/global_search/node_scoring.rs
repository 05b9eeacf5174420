//! The nodes of the branch and bound and their scores: a node's bound is the mean of a pyramid
//! level's values under the scan's cells, and the best distinct leaves are kept with non-maximum
//! suppression.

use crate::pose::{wrap_angle, Pose2};
use crate::search::global_search::Candidate;
use crate::search::likelihood_field::LikelihoodPyramid;
use std::cmp::Ordering;

/// A search node: a `2^level` block of translations from `(ix, iy)` at one rotation.
#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub(super) rotation: u32,
    pub(super) ix: i32,
    pub(super) iy: i32,
    pub(super) level: u8,
    pub(super) score: f32,
}

/// Queue order: higher bound first; among equal bounds the finer node first (reaches leaves).
impl Ord for Node {
    fn cmp(&self, other: &Self) -> Ordering {
        self.score.total_cmp(&other.score).then(other.level.cmp(&self.level))
    }
}

impl PartialOrd for Node {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for Node {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Node {}

/// The scan's cells at one rotation, for the centre of that rotation's square of translations.
pub(super) struct RotatedScan {
    pub(super) yaw: f64,
    /// The centre of the rotation's square of translations (map frame, metres).
    pub(super) center: [f64; 2],
    pub(super) cells: Vec<[i64; 2]>,
}

impl RotatedScan {
    /// The bound of the node at `level` whose block starts at translation `(ix, iy)`: the mean of
    /// the level's values under the scan's cells shifted there (`inv_n`: one over 255 times the
    /// number of cells).
    #[inline]
    pub(super) fn score(
        &self,
        pyramid: &LikelihoodPyramid,
        ix: i32,
        iy: i32,
        level: usize,
        inv_n: f32,
    ) -> f32 {
        let (dx, dy) = (ix as i64, iy as i64);
        let sum: u32 = self.cells.iter().map(|c| pyramid.get(level, c[0] + dx, c[1] + dy) as u32).sum();
        sum as f32 * inv_n
    }
}

/// The best distinct leaves so far.
pub(super) struct BestList {
    pub(super) entries: Vec<Candidate>,
    pub(super) capacity: usize,
    pub(super) floor: f64,
    pub(super) relative: f64,
    pub(super) nms_distance: f64,
    pub(super) nms_angle: f64,
}

impl BestList {
    /// A node must score above this to matter.
    pub(super) fn threshold(&self) -> f64 {
        let Some(best) = self.entries.first() else {
            return self.floor;
        };
        let mut t = self.floor.max(self.relative * best.score);
        if self.entries.len() >= self.capacity {
            t = t.max(self.entries.last().map_or(0.0, |e| e.score));
        }
        t
    }

    fn same_place(&self, a: &Pose2, b: &Pose2) -> bool {
        (a.x - b.x).hypot(a.y - b.y) < self.nms_distance && wrap_angle(a.yaw - b.yaw).abs() < self.nms_angle
    }

    pub(super) fn insert(&mut self, c: Candidate) {
        if let Some(i) = self.entries.iter().position(|e| self.same_place(&e.pose, &c.pose)) {
            if c.score <= self.entries[i].score {
                return;
            }
            self.entries[i] = c;
            // The better pose may now also cover other, weaker entries.
            let keep: Vec<Candidate> = self
                .entries
                .iter()
                .enumerate()
                .filter(|&(j, e)| j == i || !self.same_place(&e.pose, &c.pose))
                .map(|(_, e)| *e)
                .collect();
            self.entries = keep;
        } else {
            self.entries.push(c);
        }
        self.entries.sort_by(|a, b| b.score.total_cmp(&a.score));
        self.entries.truncate(self.capacity);
        let cut = self.relative * self.entries[0].score;
        self.entries.retain(|e| e.score >= cut);
    }
}
