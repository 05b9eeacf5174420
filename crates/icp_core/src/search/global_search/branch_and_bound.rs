//! The branch-and-bound driver of a global search: the roots scored in order, then the node with
//! the highest bound expanded next, a budget of nodes at a time, polling a [`Cancel`] hook between
//! nodes.

use crate::cancel::{self, Cancel};
use crate::error::Result;
use crate::pose::Pose2;
use crate::search::global_search::node_scoring::{BestList, Node, RotatedScan};
use crate::search::global_search::{Candidate, GlobalMatcher, SearchOutcome, NODES_PER_POLL};
use crate::search::likelihood_field::LikelihoodPyramid;
use std::collections::BinaryHeap;
use std::time::Instant;

/// A branch-and-bound search in progress (see [`crate::search::global_search`]), made by
/// [`GlobalMatcher::start`]: each [`SearchRun::advance`] scores up to a budget of nodes and stops
/// where it is, so a search of seconds can be spread over many short calls (a tracker's updates).
/// The roots (every rotation's coarsest blocks) are scored first, in order; then the node with the
/// highest bound is expanded next, exactly as one uninterrupted search would. Memory: the queue
/// holds up to `max_nodes` nodes of 20 bytes.
pub struct SearchRun {
    pub(super) rotated: Vec<RotatedScan>,
    pub(super) inv_n: f32,
    pub(super) limits: [i32; 2],
    pub(super) nodes: u64,
    pub(super) max_nodes: u64,
    pub(super) complete: bool,
    pub(super) finished: bool,
    pub(super) best: BestList,
    pub(super) res: f64,
    pub(super) step: f64,
    pub(super) scan_points: usize,
    /// Level of the roots.
    pub(super) top: usize,
    /// Roots per rotation along x and y.
    pub(super) root_blocks: [usize; 2],
    /// Index of the next root to score, over rotations x x-blocks x y-blocks.
    pub(super) next_root: usize,
    /// The roots scored so far, until all are and become the queue.
    pub(super) roots: Vec<Node>,
    pub(super) queue: BinaryHeap<Node>,
}

impl SearchRun {
    /// Scores `budget` more nodes of the search (three more at most: an expansion scores four
    /// children) with `matcher`'s pyramid (the matcher that started the run); returns whether the
    /// search has ended (every node that could beat the
    /// candidates expanded, or `max_nodes` scored in all).
    ///
    /// `cancel` is polled every [`NODES_PER_POLL`] nodes; when it returns true the call stops with
    /// [`IcpError::Interrupted`] ([`cancel::NEVER`]: it cannot be stopped, and never fails). The
    /// run stays where it stopped, between two nodes: advanced again, it goes on as if it had not
    /// been interrupted.
    pub fn advance(&mut self, matcher: &GlobalMatcher, budget: u64, cancel: Cancel<'_>) -> Result<bool> {
        self.advance_until(matcher, budget, None, cancel)
    }

    /// [`SearchRun::advance`], and stopped as well (`Ok(false)`, where it is) at the first poll
    /// (every [`NODES_PER_POLL`] nodes) at or after `until`, when given: a time budget for a loop
    /// that must keep to a period whatever a node costs on its plan (a node's cost grows with the
    /// likelihood pyramid's size, from memory, not with the node count).
    pub fn advance_until(
        &mut self,
        matcher: &GlobalMatcher,
        budget: u64,
        until: Option<Instant>,
        cancel: Cancel<'_>,
    ) -> Result<bool> {
        let out_of_time = || until.is_some_and(|t| Instant::now() >= t);
        let pyramid = &matcher.pyramid;
        let mut next_poll = self.nodes.saturating_add(NODES_PER_POLL);
        let stop_at = self.nodes.saturating_add(budget.max(1));
        let [bx, by] = self.root_blocks;
        let roots = self.rotated.len() * bx * by;
        let block = 1i32 << self.top;
        while self.next_root < roots {
            if self.nodes >= stop_at {
                return Ok(false);
            }
            if self.nodes >= next_poll {
                cancel::check(cancel)?;
                if out_of_time() {
                    return Ok(false);
                }
                next_poll = self.nodes.saturating_add(NODES_PER_POLL);
            }
            if self.nodes >= self.max_nodes {
                // More roots than the search may score: it ends without expanding any (and never
                // holds more than `max_nodes` of them).
                self.complete = false;
                self.finished = true;
                self.roots = Vec::new();
                return Ok(true);
            }
            let k = self.next_root;
            self.next_root += 1;
            let (r, rest) = (k / (bx * by), k % (bx * by));
            let (ix, iy) =
                (-self.limits[0] + (rest / by) as i32 * block, -self.limits[1] + (rest % by) as i32 * block);
            let root = self.node(pyramid, r as u32, ix, iy, self.top);
            self.roots.push(root);
        }
        if !self.roots.is_empty() {
            // One heap of every root, as an uninterrupted search builds it (the order of ties).
            self.queue = BinaryHeap::from(std::mem::take(&mut self.roots));
        }
        while !self.finished {
            if self.nodes >= stop_at {
                return Ok(false);
            }
            if self.nodes >= next_poll {
                cancel::check(cancel)?;
                if out_of_time() {
                    return Ok(false);
                }
                next_poll = self.nodes.saturating_add(NODES_PER_POLL);
            }
            self.expand_next(pyramid);
        }
        Ok(true)
    }

    /// Whether the search has ended.
    pub fn finished(&self) -> bool {
        self.finished
    }

    /// Nodes scored so far.
    pub fn nodes(&self) -> u64 {
        self.nodes
    }

    /// The candidates so far (the search's result once it has ended) and what they cost.
    pub fn outcome(&self) -> SearchOutcome {
        SearchOutcome {
            candidates: self.best.entries.clone(),
            rotations: self.rotated.len(),
            angular_step: self.step,
            nodes: self.nodes,
            complete: self.complete,
            scan_points: self.scan_points,
        }
    }

    /// Scores the node at `level`: the mean of the level's values under the scan's cells.
    fn node(&mut self, pyramid: &LikelihoodPyramid, rotation: u32, ix: i32, iy: i32, level: usize) -> Node {
        self.nodes += 1;
        let score = self.rotated[rotation as usize].score(pyramid, ix, iy, level, self.inv_n);
        Node { rotation, ix, iy, level: level as u8, score }
    }

    /// One step of the best-first expansion: the node with the highest bound is a leaf (a
    /// candidate) or is split into its four children; the search ends when no node's bound beats
    /// the threshold, or at `max_nodes`.
    fn expand_next(&mut self, pyramid: &LikelihoodPyramid) {
        let Some(n) = self.queue.pop() else {
            self.finished = true;
            return;
        };
        let threshold = self.best.threshold();
        if (n.score as f64) <= threshold {
            self.finished = true;
            self.queue = BinaryHeap::new();
            return;
        }
        if n.level == 0 {
            let rotated = &self.rotated[n.rotation as usize];
            let pose = Pose2::new(
                rotated.center[0] + n.ix as f64 * self.res,
                rotated.center[1] + n.iy as f64 * self.res,
                rotated.yaw,
            );
            self.best.insert(Candidate { pose, score: n.score as f64 });
            return;
        }
        if self.nodes >= self.max_nodes {
            self.complete = false;
            self.finished = true;
            self.queue = BinaryHeap::new();
            return;
        }
        let level = n.level as usize - 1;
        let half = 1i32 << level;
        for (ox, oy) in [(0, 0), (half, 0), (0, half), (half, half)] {
            let (ix, iy) = (n.ix + ox, n.iy + oy);
            if ix <= self.limits[0] && iy <= self.limits[1] {
                let child = self.node(pyramid, n.rotation, ix, iy, level);
                if child.score as f64 > threshold {
                    self.queue.push(child);
                }
            }
        }
    }
}
