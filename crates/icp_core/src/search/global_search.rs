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

use crate::cancel::{self, Cancel};
use crate::error::{check_finite, invalid, IcpError, Result};
use crate::maps::point_map::PointMap;
use crate::pose::{wrap_angle, Pose2};
use crate::search::likelihood_field::{LikelihoodPyramid, MAX_LEVELS};
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f64::consts::PI;

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

/// Where to search: positions within `half_width` metres (a square) of `center` and headings
/// within `half_angle` radians of its yaw (`>= pi`: every heading).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchWindow {
    /// Centre of the window, `T_map_base`.
    pub center: Pose2,
    /// Half the side of the square of positions, metres.
    pub half_width: f64,
    /// Half the range of headings, radians.
    pub half_angle: f64,
}

impl SearchWindow {
    /// Checks the window.
    pub fn validate(&self) -> Result<()> {
        if !self.center.is_finite() {
            return Err(invalid("window center", format!("{:?}", self.center), "must be finite"));
        }
        check_finite("window center", &[[self.center.x, self.center.y]])?;
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

/// A search node: a `2^level` block of translations from `(ix, iy)` at one rotation.
#[derive(Clone, Copy, Debug)]
struct Node {
    rotation: u32,
    ix: i32,
    iy: i32,
    level: u8,
    score: f32,
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

/// The scan's cells at one rotation, for the window's centre translation.
struct RotatedScan {
    yaw: f64,
    cells: Vec<[i64; 2]>,
}

/// The best distinct leaves so far.
struct BestList {
    entries: Vec<Candidate>,
    capacity: usize,
    floor: f64,
    relative: f64,
    nms_distance: f64,
    nms_angle: f64,
}

impl BestList {
    /// A node must score above this to matter.
    fn threshold(&self) -> f64 {
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

    fn insert(&mut self, c: Candidate) {
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

impl GlobalMatcher {
    /// Builds the likelihood pyramid of `map`'s wall points.
    pub fn new(map: &PointMap, config: GlobalSearchConfig) -> Result<Self> {
        config.validate()?;
        let pyramid = LikelihoodPyramid::new(map.points(), config.resolution, config.sigma, config.levels)?;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in map.points() {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
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

    /// Thins `scan` (robot frame, metres) to one point per cell, then to at most
    /// `max_scan_points` by an even stride.
    pub fn thin_scan(&self, scan: &[[f64; 2]]) -> Result<Vec<[f64; 2]>> {
        if scan.is_empty() {
            return Err(IcpError::Empty { what: "scan" });
        }
        check_finite("scan", scan)?;
        let res = self.config.resolution;
        let mut keyed: Vec<((i64, i64), usize)> = scan
            .iter()
            .enumerate()
            .map(|(i, p)| (((p[0] / res).floor() as i64, (p[1] / res).floor() as i64), i))
            .collect();
        keyed.sort_unstable();
        keyed.dedup_by_key(|k| k.0);
        let mut kept: Vec<usize> = keyed.into_iter().map(|(_, i)| i).collect();
        kept.sort_unstable();
        if kept.len() < MIN_SEARCH_POINTS {
            return Err(IcpError::TooFewPoints {
                what: "scan (one point per search cell)",
                got: kept.len(),
                need: MIN_SEARCH_POINTS,
            });
        }
        let stride = kept.len().div_ceil(self.config.max_scan_points);
        Ok(kept.into_iter().step_by(stride).map(|i| scan[i]).collect())
    }

    /// The rotation step for `points`: far points move by about one cell per step.
    fn angular_step(&self, points: &[[f64; 2]]) -> f64 {
        if let Some(step) = self.config.angular_step {
            return step.min(PI);
        }
        let mut ranges: Vec<f64> = points.iter().map(|p| p[0].hypot(p[1])).collect();
        let k = (ranges.len() * 95 / 100).min(ranges.len() - 1);
        let (_, r, _) = ranges.select_nth_unstable_by(k, f64::total_cmp);
        let r = r.max(self.config.resolution);
        let res = self.config.resolution;
        let step = (1.0 - res * res / (2.0 * r * r)).clamp(-1.0, 1.0).acos();
        step.min(self.config.max_angular_step)
    }

    /// Searches the whole plan (`window` `None`) or a window for the poses that best explain
    /// `scan` (points in the robot frame, metres).
    ///
    /// `cancel` is polled every [`NODES_PER_POLL`] nodes; when it returns true the search stops
    /// with [`IcpError::Interrupted`] (callers that cannot be cancelled pass [`cancel::NEVER`]).
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

    /// A search of the whole plan (`window` `None`) or a window for `scan` (robot frame, metres)
    /// that has not scored any node yet: [`SearchRun::advance`] does the work a budget of nodes
    /// at a time, and a run advanced to its end finds what [`GlobalMatcher::search`] finds.
    pub fn start(&self, scan: &[[f64; 2]], window: Option<&SearchWindow>) -> Result<SearchRun> {
        if let Some(w) = window {
            w.validate()?;
        }
        let points = self.thin_scan(scan)?;
        let res = self.config.resolution;
        let step = self.angular_step(&points);
        let (center, half_cells, yaws) = match window {
            None => {
                let [lo, hi] = self.bounds;
                let center = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
                let half = [((hi[0] - lo[0]) / 2.0 / res).ceil(), ((hi[1] - lo[1]) / 2.0 / res).ceil()];
                (center, half, full_circle(step))
            }
            Some(w) => {
                // A window wider than the plan along an axis is the plan's extent there (the whole
                // plan's search covers exactly that extent): a huge window costs no more than the
                // whole plan. Any other window is searched as given, on its own lattice. (Clipping
                // every window to the plan moved the lattice of those near its edges by up to half
                // a cell and left a window beyond them a single position; fhw's recovery, over
                // odometry seeds 1-5, then lost 63-84 % of the scans instead of 43-60 %.)
                let [lo, hi] = self.bounds;
                let clip = |c: f64, axis: usize| {
                    if 2.0 * w.half_width >= hi[axis] - lo[axis] {
                        ((lo[axis] + hi[axis]) / 2.0, ((hi[axis] - lo[axis]) / 2.0 / res).ceil())
                    } else {
                        (c, (w.half_width / res).ceil())
                    }
                };
                let ((cx, hx), (cy, hy)) = (clip(w.center.x, 0), clip(w.center.y, 1));
                let yaws = if w.half_angle >= PI {
                    full_circle(step)
                } else {
                    let m = (w.half_angle / step).ceil() as i64;
                    let n = (2 * m + 1) as usize;
                    if n > MAX_ROTATIONS {
                        return Err(rotations_error(n));
                    }
                    let d = if m > 0 { w.half_angle / m as f64 } else { 0.0 };
                    Ok((-m..=m).map(|k| w.center.yaw + k as f64 * d).collect())
                };
                ([cx, cy], [hx, hy], yaws)
            }
        };
        let yaws = yaws?;
        // The lattice must fit in i32 offsets and in the node budget's meaning.
        if !(half_cells[0] < 1e8 && half_cells[1] < 1e8) {
            return Err(invalid(
                "window half_width",
                half_cells[0].max(half_cells[1]) * res,
                "is too large for the search lattice; search a smaller window",
            ));
        }
        let (wx, wy) = (half_cells[0] as i32, half_cells[1] as i32);
        let rotated: Vec<RotatedScan> = yaws
            .iter()
            .map(|&yaw| {
                let pose = Pose2::new(center[0], center[1], yaw);
                let cells = points.iter().map(|p| self.pyramid.cell_of(pose.transform_point(*p))).collect();
                RotatedScan { yaw, cells }
            })
            .collect();
        let top = self.config.levels - 1;
        let block = 1i64 << top;
        let blocks = |w: i32| ((2 * i64::from(w)) / block + 1) as usize;
        Ok(SearchRun {
            rotated,
            inv_n: 1.0 / (255.0 * points.len() as f32),
            limits: [wx, wy],
            nodes: 0,
            max_nodes: self.config.max_nodes,
            complete: true,
            finished: false,
            best: BestList {
                entries: Vec::new(),
                capacity: self.config.max_candidates,
                floor: self.config.min_score,
                relative: self.config.relative_score,
                nms_distance: self.config.nms_distance,
                nms_angle: self.config.nms_angle,
            },
            center,
            res,
            step,
            scan_points: points.len(),
            top,
            root_blocks: [blocks(wx), blocks(wy)],
            next_root: 0,
            roots: Vec::new(),
            queue: BinaryHeap::new(),
        })
    }
}

fn rotations_error(n: usize) -> IcpError {
    invalid(
        "angular_step",
        format!("{n} rotations"),
        "would sweep more than 20000 rotations; give a larger step",
    )
}

/// Headings `k * step'` around the circle, `step'` the largest divisor of 2 pi not above `step`.
fn full_circle(step: f64) -> Result<Vec<f64>> {
    let n = (2.0 * PI / step).ceil().max(1.0);
    if n > MAX_ROTATIONS as f64 {
        return Err(rotations_error(n as usize));
    }
    let n = n as usize;
    Ok((0..n).map(|k| wrap_angle(k as f64 * 2.0 * PI / n as f64)).collect())
}

/// A branch-and-bound search in progress (see the module documentation), made by
/// [`GlobalMatcher::start`]: each [`SearchRun::advance`] scores up to a budget of nodes and stops
/// where it is, so a search of seconds can be spread over many short calls (a tracker's updates).
/// The roots (every rotation's coarsest blocks) are scored first, in order; then the node with the
/// highest bound is expanded next, exactly as one uninterrupted search would. Memory: the queue
/// holds up to `max_nodes` nodes of 20 bytes.
pub struct SearchRun {
    rotated: Vec<RotatedScan>,
    inv_n: f32,
    limits: [i32; 2],
    nodes: u64,
    max_nodes: u64,
    complete: bool,
    finished: bool,
    best: BestList,
    center: [f64; 2],
    res: f64,
    step: f64,
    scan_points: usize,
    /// Level of the roots.
    top: usize,
    /// Roots per rotation along x and y.
    root_blocks: [usize; 2],
    /// Index of the next root to score, over rotations x x-blocks x y-blocks.
    next_root: usize,
    /// The roots scored so far, until all are and become the queue.
    roots: Vec<Node>,
    queue: BinaryHeap<Node>,
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
        let cells = &self.rotated[rotation as usize].cells;
        let (dx, dy) = (ix as i64, iy as i64);
        let sum: u32 = cells.iter().map(|c| pyramid.get(level, c[0] + dx, c[1] + dy) as u32).sum();
        Node { rotation, ix, iy, level: level as u8, score: sum as f32 * self.inv_n }
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
            let yaw = self.rotated[n.rotation as usize].yaw;
            let pose = Pose2::new(
                self.center[0] + n.ix as f64 * self.res,
                self.center[1] + n.iy as f64 * self.res,
                yaw,
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Points every 5 cm along the segment `a`-`b`.
    pub(crate) fn segment(pts: &mut Vec<[f64; 2]>, a: [f64; 2], b: [f64; 2]) {
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (len / 0.05).round().max(1.0) as usize;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }

    /// An asymmetric floor: a 12 x 8 m hall, an inner wall with a door, a pillar and a diagonal.
    pub(crate) fn asymmetric_floor() -> Vec<[f64; 2]> {
        let mut p = Vec::new();
        for (a, b) in [
            ([0.0, 0.0], [12.0, 0.0]),
            ([12.0, 0.0], [12.0, 8.0]),
            ([12.0, 8.0], [0.0, 8.0]),
            ([0.0, 8.0], [0.0, 0.0]),
            ([5.0, 0.0], [5.0, 3.0]),
            ([5.0, 4.2], [5.0, 8.0]),
            ([8.0, 5.0], [8.6, 5.0]),
            ([8.6, 5.0], [8.6, 5.6]),
            ([8.6, 5.6], [8.0, 5.6]),
            ([8.0, 5.6], [8.0, 5.0]),
            ([0.0, 6.0], [2.0, 8.0]),
            ([9.0, 0.0], [9.0, 2.0]),
        ] {
            segment(&mut p, a, b);
        }
        p
    }

    /// A 360-degree scan of `n` beams from `pose` (robot frame), ray cast against the segments of
    /// the plan points' visibility: the visible plan points, resampled to beam directions.
    pub(crate) fn scan_from(map: &PointMap, pose: Pose2, rng: &mut ChaCha8Rng, noise: f64) -> Vec<[f64; 2]> {
        let inv = pose.inverse();
        map.visible_from(pose, 30.0)
            .unwrap()
            .iter()
            .map(|&i| {
                let p = inv.transform_point(map.points()[i as usize]);
                [p[0] + rng.random_range(-noise..=noise), p[1] + rng.random_range(-noise..=noise)]
            })
            .collect()
    }

    fn close(a: &Pose2, b: &Pose2, metres: f64, radians: f64) -> bool {
        (a.x - b.x).hypot(a.y - b.y) < metres && wrap_angle(a.yaw - b.yaw).abs() < radians
    }

    #[test]
    fn a_window_larger_than_the_plan_searches_the_plan() {
        // A 10 km window around a 12 x 8 m plan: clipped to the plan it scores the roots of the
        // whole plan's search, not 10^9 of them (which aborted the process allocating 10 GB).
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let truth = Pose2::new(2.5, 2.0, 0.7);
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let huge = SearchWindow { center: Pose2::new(6.0, 4.0, 0.0), half_width: 1e4, half_angle: PI };
        let clipped = matcher.search(&scan, Some(&huge), cancel::NEVER).unwrap();
        let whole = matcher.search(&scan, None, cancel::NEVER).unwrap();
        assert_eq!(clipped.nodes, whole.nodes);
        assert!(close(&clipped.candidates[0].pose, &truth, 0.3, 0.1), "{:?}", clipped.candidates[0]);
        // Wholly outside the plan: searched where it is (nothing to find), no error.
        let away = SearchWindow { center: Pose2::new(500.0, 4.0, 0.0), half_width: 2.0, half_angle: 0.1 };
        assert!(matcher.search(&scan, Some(&away), cancel::NEVER).is_ok());
    }

    #[test]
    fn a_window_across_the_plans_edge_keeps_its_own_lattice() {
        // A window around a pose 0.33 m inside the wall at x = 0 reaches 0.67 m past the plan: it is
        // searched on the lattice centred on its centre, as the same window well inside the plan
        // would be, not clipped to the plan and re-centred (which shifted its lattice by half a
        // cell and changed what a recovery near the edge found).
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        let res = GlobalSearchConfig::default().resolution;
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let truth = Pose2::new(0.33 + 0.37 * res, 3.0 + 0.21 * res, 0.4);
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let centre = Pose2::new(0.33, 3.0, 0.4);
        let window = SearchWindow { center: centre, half_width: 1.0, half_angle: 0.2 };
        let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
        assert!(out.complete && !out.candidates.is_empty());
        for c in &out.candidates {
            for (v, c0) in [(c.pose.x, centre.x), (c.pose.y, centre.y)] {
                let k = (v - c0) / res;
                assert!((k - k.round()).abs() < 1e-6, "{c:?} is off the window's lattice ({k} cells)");
            }
        }
        assert!(close(&out.candidates[0].pose, &truth, res, 0.05), "{:?}", out.candidates[0]);
    }

    #[test]
    fn a_search_with_more_roots_than_max_nodes_ends_at_max_nodes() {
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let config = GlobalSearchConfig { max_nodes: 100, ..GlobalSearchConfig::default() };
        let matcher = GlobalMatcher::new(&map, config).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let scan = scan_from(&map, Pose2::new(2.5, 2.0, 0.7), &mut rng, 0.01);
        let out = matcher.search(&scan, None, cancel::NEVER).unwrap();
        assert!(!out.complete && out.nodes == 100, "{out:?}");
    }

    #[test]
    fn finds_the_pose_from_no_guess() {
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for truth in [Pose2::new(2.5, 2.0, 0.7), Pose2::new(9.5, 6.5, -2.4), Pose2::new(7.0, 3.0, 3.0)] {
            let scan = scan_from(&map, truth, &mut rng, 0.01);
            let out = matcher.search(&scan, None, cancel::NEVER).unwrap();
            assert!(out.complete);
            let best = out.candidates[0];
            assert!(close(&best.pose, &truth, 0.15, 0.04), "{truth:?}: best {best:?}");
            assert!(best.score > 0.8, "{best:?}");
            assert!(out.candidates.windows(2).all(|w| w[0].score >= w[1].score));
        }
    }

    #[test]
    fn branch_and_bound_equals_exhaustive_search() {
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let cfg = GlobalSearchConfig { max_candidates: 1, ..GlobalSearchConfig::default() };
        let matcher = GlobalMatcher::new(&map, cfg).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let truth = Pose2::new(3.0, 5.0, 0.2);
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let window = SearchWindow { center: Pose2::new(3.3, 4.8, 0.25), half_width: 0.6, half_angle: 0.1 };
        let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
        let best = out.candidates[0];
        // Exhaustive: every lattice translation at every swept rotation.
        let points = matcher.thin_scan(&scan).unwrap();
        let (m, step) = ((0.1 / out.angular_step).ceil() as i64, 0.1 / (0.1 / out.angular_step).ceil());
        let mut top = 0.0f64;
        for k in -m..=m {
            for ix in -6..=6 {
                for iy in -6..=6 {
                    let pose =
                        Pose2::new(3.3 + ix as f64 * 0.1, 4.8 + iy as f64 * 0.1, 0.25 + k as f64 * step);
                    let s: u32 = points
                        .iter()
                        .map(|p| {
                            let q = Pose2::new(3.3, 4.8, pose.yaw).transform_point(*p);
                            let c = matcher.pyramid.cell_of(q);
                            matcher.pyramid.get(0, c[0] + ix, c[1] + iy) as u32
                        })
                        .sum();
                    top = top.max((s as f32 / (255.0 * points.len() as f32)) as f64);
                }
            }
        }
        assert!((best.score - top).abs() < 1e-5, "bnb {} vs exhaustive {top}", best.score);
    }

    #[test]
    fn a_symmetric_room_gives_several_candidates() {
        let mut pts = Vec::new();
        for (a, b) in [([0.0, 0.0], [10.0, 0.0]), ([10.0, 0.0], [10.0, 6.0]), ([10.0, 6.0], [0.0, 6.0])] {
            segment(&mut pts, a, b);
        }
        segment(&mut pts, [0.0, 6.0], [0.0, 0.0]);
        let map = PointMap::new(pts, None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let truth = Pose2::new(3.0, 2.0, 0.4);
        let scan = scan_from(&map, truth, &mut rng, 0.005);
        let out = matcher.search(&scan, None, cancel::NEVER).unwrap();
        assert!(out.candidates.len() >= 2, "{:?}", out.candidates);
        let mirrored = Pose2::new(7.0, 4.0, 0.4 + PI);
        let (a, b) = (out.candidates[0], out.candidates[1]);
        assert!(
            (close(&a.pose, &truth, 0.15, 0.04) && close(&b.pose, &mirrored, 0.15, 0.04))
                || (close(&b.pose, &truth, 0.15, 0.04) && close(&a.pose, &mirrored, 0.15, 0.04)),
            "{a:?} {b:?}"
        );
        assert!((a.score - b.score).abs() < 0.05, "{a:?} {b:?}");
    }

    #[test]
    fn a_window_restricts_the_search() {
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(14);
        let truth = Pose2::new(10.0, 3.5, 1.0);
        let scan = scan_from(&map, truth, &mut rng, 0.01);
        let window = SearchWindow { center: Pose2::new(10.4, 3.2, 1.2), half_width: 1.0, half_angle: 0.4 };
        let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
        let full = matcher.search(&scan, None, cancel::NEVER).unwrap();
        assert!(out.nodes < full.nodes / 5, "window {} vs whole plan {} nodes", out.nodes, full.nodes);
        assert!(close(&out.candidates[0].pose, &truth, 0.15, 0.04), "{:?}", out.candidates[0]);
        for c in &out.candidates {
            assert!((c.pose.x - 10.4).abs() <= 1.05 && (c.pose.y - 3.2).abs() <= 1.05, "{c:?}");
            assert!(wrap_angle(c.pose.yaw - 1.2).abs() <= 0.4 + 1e-9, "{c:?}");
        }
        // A window that excludes the truth finds nothing as good.
        let away = SearchWindow { center: Pose2::new(2.0, 2.0, -2.0), half_width: 0.5, half_angle: 0.1 };
        let out = matcher.search(&scan, Some(&away), cancel::NEVER).unwrap();
        assert!(out.candidates.iter().all(|c| c.score < full.candidates[0].score - 0.2));
    }

    #[test]
    fn a_run_advanced_in_small_budgets_finds_what_one_search_finds() {
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let scan = scan_from(&map, Pose2::new(3.2, 5.4, 0.7), &mut rng, 0.01);
        let whole = matcher.search(&scan, None, cancel::NEVER).unwrap();
        let mut run = matcher.start(&scan, None).unwrap();
        let mut calls = 0;
        let mut before = 0;
        while !run.advance(&matcher, 500, cancel::NEVER).unwrap() {
            calls += 1;
            // An expansion scores up to four children: a call ends at most three past its budget.
            assert!(
                (500..=503).contains(&(run.nodes() - before)),
                "{} nodes in one call",
                run.nodes() - before
            );
            before = run.nodes();
        }
        assert!(
            run.finished() && calls as u64 >= whole.nodes / 500 - 1,
            "{calls} calls for {} nodes",
            whole.nodes
        );
        assert_eq!(run.outcome(), whole);
        // A finished run stays finished and scores nothing more.
        assert!(run.advance(&matcher, 500, cancel::NEVER).unwrap());
        assert_eq!(run.nodes(), whole.nodes);
    }

    #[test]
    fn an_interrupted_run_stops_between_nodes_and_resumes_to_the_same_result() {
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let scan = scan_from(&map, Pose2::new(3.2, 5.4, 0.7), &mut rng, 0.01);
        let whole = matcher.search(&scan, None, cancel::NEVER).unwrap();
        assert!(whole.nodes > 4 * NODES_PER_POLL, "{} nodes: too few to interrupt", whole.nodes);
        // Stop at the third poll: after 3 * NODES_PER_POLL nodes (up to three more), not later.
        let polls = std::cell::Cell::new(0u32);
        let third = || {
            polls.set(polls.get() + 1);
            polls.get() >= 3
        };
        let mut run = matcher.start(&scan, None).unwrap();
        assert_eq!(run.advance(&matcher, u64::MAX, &third), Err(IcpError::Interrupted));
        assert_eq!(polls.get(), 3);
        assert!(!run.finished() && (3 * NODES_PER_POLL..3 * NODES_PER_POLL + 4).contains(&run.nodes()));
        assert!(run.advance(&matcher, u64::MAX, cancel::NEVER).unwrap());
        assert_eq!(run.outcome(), whole);
        assert_eq!(matcher.search(&scan, None, &|| true).unwrap_err(), IcpError::Interrupted);
    }

    #[test]
    fn the_node_budget_makes_the_search_incomplete() {
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        // 19 headings of one coarsest cell each: room for the roots, not for expanding them.
        let cfg = GlobalSearchConfig { max_nodes: 25, ..GlobalSearchConfig::default() };
        let matcher = GlobalMatcher::new(&map, cfg).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(15);
        let scan = scan_from(&map, Pose2::new(2.5, 2.0, 0.7), &mut rng, 0.01);
        let window = SearchWindow { center: Pose2::new(2.5, 2.0, 0.7), half_width: 1.0, half_angle: 0.3 };
        let out = matcher.search(&scan, Some(&window), cancel::NEVER).unwrap();
        assert!(!out.complete && out.nodes <= 25 + 3, "{out:?}");
    }

    #[test]
    fn rejects_bad_input() {
        let map = PointMap::new(asymmetric_floor(), None).unwrap();
        let matcher = GlobalMatcher::new(&map, GlobalSearchConfig::default()).unwrap();
        let good: Vec<[f64; 2]> =
            (0..50).map(|i| [(i as f64 * 0.3).cos() * 3.0, (i as f64 * 0.3).sin()]).collect();
        assert_eq!(matcher.search(&[], None, cancel::NEVER).unwrap_err(), IcpError::Empty { what: "scan" });
        let mut nan = good.clone();
        nan[7][1] = f64::NAN;
        assert_eq!(
            matcher.search(&nan, None, cancel::NEVER).unwrap_err(),
            IcpError::NonFinite { what: "scan", row: 7 }
        );
        assert!(matches!(
            matcher.search(&[[1.0, 0.0], [1.0, 0.01], [0.0, 2.0]], None, cancel::NEVER),
            Err(IcpError::TooFewPoints { need: MIN_SEARCH_POINTS, .. })
        ));
        for w in [
            SearchWindow { center: Pose2::new(f64::NAN, 0.0, 0.0), half_width: 1.0, half_angle: 0.1 },
            SearchWindow { center: Pose2::new(1.0, 1.0, 0.0), half_width: -1.0, half_angle: 0.1 },
            SearchWindow { center: Pose2::new(1.0, 1.0, 0.0), half_width: 1.0, half_angle: f64::INFINITY },
        ] {
            assert!(
                matches!(
                    matcher.search(&good, Some(&w), cancel::NEVER),
                    Err(IcpError::InvalidParameter { .. })
                ),
                "{w:?}"
            );
        }
        let cfg = GlobalSearchConfig::default();
        for bad in [
            GlobalSearchConfig { resolution: 0.0, ..cfg.clone() },
            GlobalSearchConfig { sigma: f64::NAN, ..cfg.clone() },
            GlobalSearchConfig { levels: 0, ..cfg.clone() },
            GlobalSearchConfig { levels: 13, ..cfg.clone() },
            GlobalSearchConfig { angular_step: Some(-0.1), ..cfg.clone() },
            GlobalSearchConfig { max_candidates: 0, ..cfg.clone() },
            GlobalSearchConfig { min_score: 1.0, ..cfg.clone() },
            GlobalSearchConfig { relative_score: 1.5, ..cfg.clone() },
            GlobalSearchConfig { nms_distance: 0.0, ..cfg.clone() },
            GlobalSearchConfig { max_scan_points: 3, ..cfg.clone() },
            GlobalSearchConfig { max_nodes: 0, ..cfg.clone() },
        ] {
            assert!(
                matches!(GlobalMatcher::new(&map, bad.clone()), Err(IcpError::InvalidParameter { .. })),
                "{bad:?}"
            );
        }
        let tiny = GlobalSearchConfig { angular_step: Some(1e-6), ..cfg };
        let m = GlobalMatcher::new(&map, tiny).unwrap();
        assert!(matches!(
            m.search(&good, None, cancel::NEVER),
            Err(IcpError::InvalidParameter { name: "angular_step", .. })
        ));
    }
}
