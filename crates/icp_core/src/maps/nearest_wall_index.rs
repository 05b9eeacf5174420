//! A precomputed nearest-wall-point index: a raster over the plan's extent whose every cell lists
//! the only wall points that can be nearest to a query inside it.
//!
//! For a cell with centre `c`, half-diagonal `r` and nearest wall point at distance `d(c)`, any
//! query `q` in the cell has its nearest wall point within `d(c) + r` of `q`, hence within
//! `d(c) + 2r` of `c`. The cell lists exactly the points within that radius of its centre, so the
//! nearest of them is the exact nearest wall point of `q` (the same answer as a KD-tree). A point
//! of that list that another one is at least as near to at all four corners of the cell is
//! dropped: it is nowhere in the cell strictly nearer, so the lists keep only the points whose
//! Voronoi regions meet the cell (one or two along a straight wall).
//! Cells farther than `reach + r` from every wall hold no list: every query there is more than
//! `reach` from the plan, and the index answers "no wall point within reach". A look-up is one
//! cell address and a scan of a handful of candidates (a few nanoseconds), against 200-300 ns for
//! a KD-tree query.
//!
//! Memory is bounded by the band of cells within `reach` of the walls: cells are grouped in
//! blocks of [`BLOCK`] x [`BLOCK`], and only blocks that reach a wall are stored, at 8 bytes per
//! cell: the one or two plan points whose Voronoi regions meet the cell (nearly every cell), or the
//! offset of a longer list (4 bytes per candidate plus a 4-byte length). The index keeps its own
//! copy of the wall points with the directions they can be seen from and their plan indices
//! (24 bytes per point), so that a look-up touches only the index. [`NearestWallIndex::memory_bytes`] reports
//! the total.
//!
//! A look-up has no data-dependent branch in the common case: an empty block or cell points at a
//! sentinel point infinitely far away, and a single candidate is stored twice. A scan's look-ups
//! ([`NearestWallIndex::find_pairs`]) run in three passes (cells, their slots, their sites), so
//! that the reads of one pass are independent of one another and overlap: 7.4 ns per point against
//! 13.5 ns when each point's three dependent reads ran one after the other (`cargo bench`,
//! `correspondences_1080/wall_index`, 8.0 against 14.5 µs).
//!
//! Build: one KD-tree radius query per block (all points that can matter to any of its cells,
//! sorted by distance to the block centre), then for every cell the exact nearest distance and
//! its list from that short, sorted prefix.

use crate::cancel::{self, Cancel};
use crate::error::{invalid, IcpError, Result};
use crate::maps::kd_tree::Tree2;
use crate::maps::pair::Pair;
use crate::visibility::wall_facing::SEEN_FROM_EVERYWHERE;

/// Cells per block side.
pub const BLOCK: usize = 8;
const BLOCK_CELLS: usize = BLOCK * BLOCK;
/// Marks a block with no wall within reach (before the build ends: then it points at the empty
/// block 0).
const EMPTY: u32 = u32::MAX;
/// Set in a cell's first slot when the second holds the offset of a list.
const LIST: u32 = 1 << 31;
/// How far beyond a cell's nearest wall point its alternative is looked for, metres (the
/// thickest wall whose near face stands in for its far one).
pub const ALTERNATIVE_REACH: f64 = 0.45;
/// Largest plan an index can hold (one index is the sentinel, one bit marks lists).
pub const MAX_INDEX_POINTS: usize = (LIST - 1) as usize;
/// Most cells (stored or not) an index may span: larger plans need a coarser cell
/// (see [`cell_within_budget`]). The block table then takes at most 16 MiB.
pub const MAX_INDEX_CELLS: f64 = (1u64 << 28) as f64;

/// `cell`, or the smallest cell that keeps an index of a plan spanning `extent` (metres, x and y)
/// within [`MAX_INDEX_CELLS`] with `reach`.
pub fn cell_within_budget(cell: f64, extent: [f64; 2], reach: f64) -> f64 {
    let mut cell = cell;
    let cells = |c: f64| {
        let m = 2.0 * (reach + c);
        ((extent[0] + m) / c / BLOCK as f64 + 1.0)
            * ((extent[1] + m) / c / BLOCK as f64 + 1.0)
            * BLOCK_CELLS as f64
    };
    while cells(cell) > MAX_INDEX_CELLS {
        cell *= 1.25;
    }
    cell
}

/// A wall point as the index stores it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Site {
    x: f64,
    y: f64,
    /// Sectors it can be seen from, see [`crate::visibility::wall_facing`].
    seen: u16,
    /// Its index in the plan (a placeholder for the sentinel). In the padding after `seen`: a
    /// pair's target costs no further read.
    plan: u32,
}

/// Exact nearest-wall-point look-ups within a fixed reach, from a precomputed raster.
#[derive(Debug, Clone)]
pub struct NearestWallIndex {
    origin: [f64; 2],
    cell: f64,
    inv_cell: f64,
    reach: f64,
    cols: usize,
    rows: usize,
    block_cols: usize,
    /// Per block (row-major): its number among the stored blocks (0: the empty block).
    blocks: Vec<u32>,
    /// Per stored block, `BLOCK_CELLS` cells (row-major) of two site indices (the sentinel
    /// `sites.len() - 1` when none), or `[LIST | length, offset]` of a list in `lists`; then the
    /// cell's alternative: the site nearest to the cell among those seen from a direction the
    /// nearest one is hidden from (the near face of a wall whose far face is nearest).
    /// (While building: the three slots of every cell; split into `slots` and `alternatives`.)
    building: Vec<[u32; 3]>,
    /// The first two slots of every cell.
    slots: Vec<[u32; 2]>,
    /// The third: read only when the nearest point is hidden.
    alternatives: Vec<u32>,
    lists: Vec<u32>,
    /// The wall points in the order cells first name them (neighbours in the plan are
    /// neighbours in memory), and, last, the sentinel. Slots and lists index into it.
    sites: Vec<Site>,
}

/// Sizes of a built index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IndexStats {
    /// Cells across the plan's extent (columns times rows).
    pub cells: usize,
    /// Blocks stored (those within reach of a wall), of all blocks.
    pub stored_blocks: usize,
    /// All blocks.
    pub blocks: usize,
    /// Candidates over all stored cells.
    pub candidates: usize,
    /// Bytes held by the index.
    pub memory_bytes: usize,
}

impl NearestWallIndex {
    /// Builds the index of `points` (the plan's wall points, metres, map frame; `tree` is their
    /// KD-tree; `seen` their visibility masks ([`crate::visibility::wall_facing`], `None`: seen from
    /// everywhere) with square
    /// cells of `cell` metres, answering exactly for queries up to `reach` metres from the walls.
    ///
    /// `cancel` is polled every [`cancel::POLL_EVERY`] blocks; when it returns true the build stops
    /// with [`IcpError::Interrupted`] (callers that cannot be cancelled pass [`cancel::NEVER`]).
    ///
    /// Errors: `cell` or `reach` not positive and finite, no points, more than
    /// [`MAX_INDEX_POINTS`] points or [`MAX_INDEX_CELLS`] cells, `seen` of another length.
    pub fn new(
        points: &[[f64; 2]],
        tree: &Tree2,
        seen: Option<&[u16]>,
        cell: f64,
        reach: f64,
        cancel: Cancel<'_>,
    ) -> Result<Self> {
        if !(cell.is_finite() && cell > 0.0) {
            return Err(invalid("index cell", cell, "must be a positive finite number of metres"));
        }
        if !(reach.is_finite() && reach > 0.0) {
            return Err(invalid("index reach", reach, "must be a positive finite number of metres"));
        }
        if points.is_empty() {
            return Err(IcpError::Empty { what: "plan" });
        }
        if points.len() > MAX_INDEX_POINTS {
            return Err(IcpError::TooFewPoints {
                what: "plan (too many points for a nearest-wall index)",
                got: points.len(),
                need: MAX_INDEX_POINTS,
            });
        }
        if seen.is_some_and(|o| o.len() != points.len()) {
            return Err(invalid("visibility masks", "length", "must have one per plan point"));
        }
        let mut sites: Vec<Site> = points
            .iter()
            .enumerate()
            .map(|(i, p)| Site {
                x: p[0],
                y: p[1],
                seen: seen.map_or(SEEN_FROM_EVERYWHERE, |o| o[i]),
                plan: i as u32,
            })
            .collect();
        // Never reported (it is never within reach), read without a branch.
        sites.push(Site { x: f64::INFINITY, y: f64::INFINITY, seen: SEEN_FROM_EVERYWHERE, plan: 0 });
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let margin = reach + cell;
        let origin = [lo[0] - margin, lo[1] - margin];
        let cols_f = ((hi[0] + margin - origin[0]) / cell).ceil().max(1.0);
        let rows_f = ((hi[1] + margin - origin[1]) / cell).ceil().max(1.0);
        // Whole blocks, so that every cell of a stored block exists.
        let block_cols_f = (cols_f / BLOCK as f64).ceil();
        let block_rows_f = (rows_f / BLOCK as f64).ceil();
        let cells = block_cols_f * block_rows_f * BLOCK_CELLS as f64;
        if !(cells.is_finite() && cells <= MAX_INDEX_CELLS) {
            return Err(IcpError::RasterTooLarge {
                resolution: cell,
                cells,
                limit: MAX_INDEX_CELLS as usize,
            });
        }
        let (block_cols, block_rows) = (block_cols_f as usize, block_rows_f as usize);
        let mut index = Self {
            origin,
            cell,
            inv_cell: 1.0 / cell,
            reach,
            cols: block_cols * BLOCK,
            rows: block_rows * BLOCK,
            block_cols,
            blocks: vec![EMPTY; block_cols * block_rows],
            building: Vec::new(),
            slots: Vec::new(),
            alternatives: Vec::new(),
            lists: Vec::new(),
            sites,
        };
        index.fill(points, tree, cancel)?;
        Ok(index)
    }

    fn fill(&mut self, points: &[[f64; 2]], tree: &Tree2, cancel: Cancel<'_>) -> Result<()> {
        let cell = self.cell;
        let half_diagonal = cell * std::f64::consts::FRAC_1_SQRT_2;
        let block_size = cell * BLOCK as f64;
        let block_half_diagonal = block_size * std::f64::consts::FRAC_1_SQRT_2;
        // Per cell in a block: (squared distance to the cell's centre, plan index) of the block's
        // points.
        let mut nearby: Vec<(f64, u32)> = Vec::new();
        let mut list: Vec<(f64, u32)> = Vec::new();
        let mut kept: Vec<u32> = Vec::new();
        let block_rows = self.blocks.len() / self.block_cols;
        let sentinel = points.len() as u32;
        // Block 0: every cell empty.
        self.building.resize(BLOCK_CELLS, [sentinel, sentinel, sentinel]);
        // Blocks within reach of some point, found point by point: free space costs nothing.
        let mut near = vec![false; self.blocks.len()];
        let pad = self.reach + half_diagonal + block_half_diagonal;
        for (k, p) in points.iter().enumerate() {
            if k % cancel::POLL_EVERY == 0 {
                cancel::check(cancel)?;
            }
            let span = |v: f64, o: f64, n: usize| {
                let lo = ((v - pad - o) / block_size).floor().max(0.0) as usize;
                let hi = (((v + pad - o) / block_size).floor() as usize).min(n - 1);
                lo..=hi
            };
            for brow in span(p[1], self.origin[1], block_rows) {
                let row = &mut near[brow * self.block_cols..(brow + 1) * self.block_cols];
                for flag in &mut row[span(p[0], self.origin[0], self.block_cols)] {
                    *flag = true;
                }
            }
        }
        let mut visited = 0usize;
        for brow in 0..block_rows {
            for bcol in 0..self.block_cols {
                if !near[brow * self.block_cols + bcol] {
                    continue;
                }
                // A block costs about a KD-tree query and 64 short scans: tens of microseconds.
                visited += 1;
                if visited % (cancel::POLL_EVERY / 64) == 0 {
                    cancel::check(cancel)?;
                }
                let corner =
                    [self.origin[0] + bcol as f64 * block_size, self.origin[1] + brow as f64 * block_size];
                let centre = [corner[0] + 0.5 * block_size, corner[1] + 0.5 * block_size];
                let nn = tree.nearest_one(&centre);
                let d_block = nn.distance.sqrt();
                if d_block > self.reach + half_diagonal + block_half_diagonal {
                    continue;
                }
                // A cell's nearest point is within d(c) <= d_block + R of the cell, so within
                // d_block + 2R of the block centre; its list within d(c) + 2r of the cell.
                let radius = d_block + 2.0 * block_half_diagonal + 2.0 * half_diagonal;
                nearby.clear();
                tree.for_each_within(&centre, radius * radius, |item, d2| nearby.push((d2, item)));
                nearby.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                let stored = (self.building.len() / BLOCK_CELLS) as u32;
                self.blocks[brow * self.block_cols + bcol] = stored;
                for r in 0..BLOCK {
                    for c in 0..BLOCK {
                        let q = [corner[0] + (c as f64 + 0.5) * cell, corner[1] + (r as f64 + 0.5) * cell];
                        let from_centre = ((q[0] - centre[0]).powi(2) + (q[1] - centre[1]).powi(2)).sqrt();
                        let sq = |i: u32| {
                            let p = points[i as usize];
                            (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)
                        };
                        // Exact nearest distance: d(c) <= d_block + |c - centre|, so the nearest
                        // point lies within d_block + 2 |c - centre| of the block centre.
                        let mut best = f64::INFINITY;
                        let limit = (d_block + 2.0 * from_centre).powi(2);
                        for &(dc, i) in &nearby {
                            if dc > limit {
                                break;
                            }
                            best = best.min(sq(i));
                        }
                        let d_cell = best.sqrt();
                        let mut slot = [sentinel, sentinel, sentinel];
                        if d_cell <= self.reach + half_diagonal {
                            let keep = d_cell + 2.0 * half_diagonal;
                            let scan_to = (keep + from_centre).powi(2);
                            list.clear();
                            for &(dc, i) in &nearby {
                                if dc > scan_to {
                                    break;
                                }
                                let d2 = sq(i);
                                if d2 <= keep * keep {
                                    list.push((d2, i));
                                }
                            }
                            // Nearest to the cell centre first: the likeliest answer is met first.
                            list.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                            let half = 0.5 * cell;
                            let corners = [
                                [q[0] - half, q[1] - half],
                                [q[0] + half, q[1] - half],
                                [q[0] - half, q[1] + half],
                                [q[0] + half, q[1] + half],
                            ];
                            kept.clear();
                            for &(_, i) in &list {
                                let p = points[i as usize];
                                // A point no nearer than a kept one at every corner of the cell is
                                // no nearer anywhere in it (the set where it is nearer is a
                                // half-plane): it is never the answer.
                                let dominated = kept.iter().any(|&k| {
                                    let kp = points[k as usize];
                                    corners.iter().all(|c| {
                                        (kp[0] - c[0]).powi(2) + (kp[1] - c[1]).powi(2)
                                            <= (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)
                                    })
                                });
                                if !dominated {
                                    kept.push(i);
                                }
                            }
                            // The alternative, for when the nearest point is hidden from the
                            // sensor: searched up to ALTERNATIVE_REACH beyond the nearest.
                            let hidden_from = !self.sites[list[0].1 as usize].seen;
                            let mut alternative = (sentinel, f64::INFINITY);
                            if hidden_from != 0 {
                                let bound = (d_cell + ALTERNATIVE_REACH + from_centre).powi(2);
                                for &(dc, i) in &nearby {
                                    if dc > bound {
                                        break;
                                    }
                                    if self.sites[i as usize].seen & hidden_from != 0 {
                                        let d2 = sq(i);
                                        if d2 < alternative.1 {
                                            alternative = (i, d2);
                                        }
                                    }
                                }
                            }
                            let alt = alternative.0;
                            slot = match kept[..] {
                                [only] => [only, only, alt],
                                [a, b] => [a, b, alt],
                                _ => {
                                    let offset = self.lists_len()?;
                                    self.lists.extend_from_slice(&kept);
                                    [LIST | kept.len() as u32, offset, alt]
                                }
                            };
                        }
                        self.building.push(slot);
                    }
                }
            }
        }
        for b in &mut self.blocks {
            if *b == EMPTY {
                *b = 0;
            }
        }
        self.renumber();
        self.slots = self.building.iter().map(|&[a, b, _]| [a, b]).collect();
        self.alternatives = self.building.iter().map(|c| c[2]).collect();
        self.building = Vec::new();
        self.lists.shrink_to_fit();
        Ok(())
    }

    /// Renumbers the sites (still in plan order) in the order the cells name them, and drops
    /// those no cell names.
    fn renumber(&mut self) {
        let sentinel = (self.sites.len() - 1) as u32;
        let mut rank = vec![u32::MAX; self.sites.len()];
        let mut order: Vec<u32> = Vec::new();
        let mut visit = |i: &mut u32| {
            if *i != sentinel {
                if rank[*i as usize] == u32::MAX {
                    rank[*i as usize] = order.len() as u32;
                    order.push(*i);
                }
                *i = rank[*i as usize];
            }
        };
        for slot in &mut self.building {
            if slot[0] & LIST != 0 {
                let (len, at) = ((slot[0] & !LIST) as usize, slot[1] as usize);
                for i in &mut self.lists[at..at + len] {
                    visit(i);
                }
            } else {
                let [a, b, _] = slot;
                visit(a);
                visit(b);
            }
        }
        for slot in &mut self.building {
            visit(&mut slot[2]);
        }
        let new_sentinel = order.len() as u32;
        for slot in &mut self.building {
            let singles = if slot[0] & LIST == 0 { 0..3 } else { 2..3 };
            for i in &mut slot[singles] {
                if *i == sentinel {
                    *i = new_sentinel;
                }
            }
        }
        let mut sites: Vec<Site> = order.iter().map(|&i| self.sites[i as usize]).collect();
        sites.push(self.sites[sentinel as usize]);
        self.sites = sites;
    }

    fn lists_len(&self) -> Result<u32> {
        u32::try_from(self.lists.len()).ok().filter(|&n| n < LIST).ok_or(IcpError::RasterTooLarge {
            resolution: self.cell,
            cells: self.lists.len() as f64,
            limit: LIST as usize,
        })
    }
    /// Cell size, metres.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// Largest distance from the walls at which look-ups are answered, metres.
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Sizes and memory of the index.
    pub fn stats(&self) -> IndexStats {
        let stored_blocks = self.slots.len() / BLOCK_CELLS - 1;
        let sentinel = (self.sites.len() - 1) as u32;
        let candidates = self.slots[BLOCK_CELLS..]
            .iter()
            .map(|s| match *s {
                [a, _] if a & LIST != 0 => (a & !LIST) as usize,
                [a, _] if a == sentinel => 0,
                [a, b] => 1 + usize::from(a != b),
            })
            .sum();
        IndexStats {
            cells: self.cols * self.rows,
            stored_blocks,
            blocks: self.blocks.len(),
            candidates,
            memory_bytes: self.memory_bytes(),
        }
    }

    /// Bytes held by the index (tables and candidates).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.blocks.len() * 4
            + self.slots.len() * 8
            + self.alternatives.len() * 4
            + self.lists.len() * 4
            + self.sites.len() * std::mem::size_of::<Site>()
    }

    /// The plan index and squared distance (m^2) of the wall point nearest to `q` (map frame,
    /// metres), or `None` when no wall point lies within [`NearestWallIndex::reach`].
    #[inline]
    pub fn nearest(&self, q: [f64; 2]) -> Option<(u32, f64)> {
        let (i, d2) = self.nearest_in(self.cell_of(q), q);
        (d2 <= self.reach * self.reach).then_some((self.sites[i as usize].plan, d2))
    }

    /// Pairs every point of `transformed` (map frame) with its nearest wall point when nearer
    /// than `max_distance` (at most the reach) and, given a `view`, when that wall point can be
    /// seen from the sensor ([`crate::visibility::wall_facing`]); a hidden one is replaced by its cell's
    /// alternative when that is seen. `out` is cleared first.
    ///
    /// Two passes: the first finds every point's cell (a block-table read each, independent of
    /// one another), the second reads the cells and their sites. Interleaving the two for one
    /// point at a time chains three dependent reads per point and the processor overlaps few
    /// points; split, each pass's reads run side by side.
    pub fn find_pairs(
        &self,
        transformed: &[[f64; 2]],
        max_distance: f64,
        view: Option<SensorView<'_>>,
        out: &mut Vec<Pair>,
    ) {
        let max_sq = max_distance.min(self.reach).powi(2);
        out.clear();
        // The passes keep their findings in `out` until the last one overwrites it: the first
        // puts the cell in `target`, the second the cell's two slots in `sq_dist`.
        out.extend(transformed.iter().map(|q| Pair {
            source: 0,
            target: self.cell_of(*q) as u32,
            sq_dist: 0.0,
        }));
        for p in out.iter_mut() {
            let [a, b] = self.slots[p.target as usize];
            p.sq_dist = f64::from_bits(u64::from(a) | (u64::from(b) << 32));
        }
        let mut kept = 0usize;
        for i in 0..transformed.len() {
            let q = transformed[i];
            let found = out[i];
            let bits = found.sq_dist.to_bits();
            let (mut t, mut d2) = self.nearest_of([bits as u32, (bits >> 32) as u32], q);
            let facing = match view {
                Some(v) => {
                    let bit = 1u16 << v.sector(i);
                    let seen = self.sites[t as usize].seen & bit != 0;
                    // Rare enough for the branch predictor.
                    if !seen {
                        // Hidden: the cell's alternative, when the sensor sees it.
                        let alt = self.alternatives[found.target as usize];
                        let a = &self.sites[alt as usize];
                        if a.seen & bit != 0 {
                            t = alt;
                            d2 = (a.x - q[0]).powi(2) + (a.y - q[1]).powi(2);
                        }
                    }
                    seen || self.sites[t as usize].seen & bit != 0
                }
                None => true,
            };
            // Written always, kept when it counts: no branch to mispredict. (`kept <= i`: the
            // findings still to read lie beyond it.)
            let keep = (d2 <= max_sq) & facing;
            // The sentinel (no wall within reach) is never kept; its plan index is a placeholder.
            out[kept] = Pair { source: i as u32, target: self.sites[t as usize].plan, sq_dist: d2 };
            kept += usize::from(keep);
        }
        out.truncate(kept);
    }

    /// The stored cell holding `q` (map frame, metres); a query outside the raster (or NaN)
    /// gets cell 0 of the empty block, whose slots name the sentinel.
    #[inline(always)]
    fn cell_of(&self, q: [f64; 2]) -> usize {
        let fx = (q[0] - self.origin[0]) * self.inv_cell;
        let fy = (q[1] - self.origin[1]) * self.inv_cell;
        // Also false for NaN.
        let inside = fx >= 0.0 && fy >= 0.0 && fx < self.cols as f64 && fy < self.rows as f64;
        let (fx, fy) = if inside { (fx, fy) } else { (0.0, 0.0) };
        let (col, row) = (cell_index(fx), cell_index(fy));
        let stored = self.blocks[(row / BLOCK) * self.block_cols + col / BLOCK] as usize;
        let cell = stored * BLOCK_CELLS + (row % BLOCK) * BLOCK + col % BLOCK;
        if inside {
            cell
        } else {
            0
        }
    }

    /// The nearest candidate of `cell` to `q` and its squared distance (infinite: none).
    #[inline(always)]
    fn nearest_in(&self, cell: usize, q: [f64; 2]) -> (u32, f64) {
        self.nearest_of(self.slots[cell], q)
    }

    /// The nearest to `q` of the candidates a cell's slots `[a, b]` name (two sites, or a list)
    /// and its squared distance (infinite: none).
    #[inline(always)]
    fn nearest_of(&self, [a, b]: [u32; 2], q: [f64; 2]) -> (u32, f64) {
        let sentinel = (self.sites.len() - 1) as u32;
        let sq = |i: u32| {
            let s = &self.sites[i as usize];
            (s.x - q[0]) * (s.x - q[0]) + (s.y - q[1]) * (s.y - q[1])
        };
        if a & LIST != 0 {
            let list = &self.lists[b as usize..b as usize + (a & !LIST) as usize];
            return list.iter().map(|&i| (i, sq(i))).fold((sentinel, f64::INFINITY), |best, c| {
                if c.1 < best.1 || (c.1 == best.1 && c.0 < best.0) {
                    c
                } else {
                    best
                }
            });
        }
        // Selected without a branch: which of two neighbouring points wins is a coin toss for
        // the branch predictor. (Equidistant points tie to the first; either is exact.)
        let (da, db) = (sq(a), sq(b));
        let take_b = db < da;
        (select(take_b, b, a), if take_b { db } else { da })
    }
}

/// The cell of a raster coordinate `f` (cells) in `[0, 2^31)`: `f - 0.5` rounded to the nearest
/// integer by the float unit itself (adding 1.5 * 2^52 leaves the integer in the low mantissa
/// bits). A point exactly on a cell border lands in either neighbour; both hold it in their closed
/// square, which is all the lists promise. Two instructions, against the dozen of a saturating
/// `as usize` cast.
#[inline]
fn cell_index(f: f64) -> usize {
    const ROUNDING: f64 = 6_755_399_441_055_744.0;
    ((f - 0.5 + ROUNDING).to_bits() & 0xFFFF_FFFF) as usize
}

/// Where the sensor is seen from each scan point: the direction from a scan point to the sensor
/// is its beam reversed, fixed in the robot frame, so the sector of that direction in the map
/// frame is the robot-frame bearing turned by the pose's yaw (no trigonometry per look-up). The
/// sector is that of the direction from the scan point, not from the wall point it is paired with:
/// they are a correspondence distance apart, the sensor metres away.
#[derive(Clone, Copy, Debug)]
pub struct SensorView<'a> {
    /// Per scan point: the robot-frame angle of the direction from it to the sensor, in sectors
    /// ([`crate::visibility::wall_facing::SECTORS`] per turn).
    pub bearings: &'a [f64],
    /// The pose's yaw, in sectors.
    pub yaw: f64,
}

impl<'a> SensorView<'a> {
    /// `bearings` in sectors (see [`SensorView::bearings_of`]) seen from a pose with `yaw` radians.
    pub fn new(bearings: &'a [f64], yaw: f64) -> Self {
        Self { bearings, yaw: yaw * SECTORS_PER_RADIAN }
    }

    /// The bearings of [`SensorView`] for robot-frame scan points seen from the robot's origin.
    pub fn bearings_of(scan: &[[f64; 2]]) -> Vec<f64> {
        scan.iter().map(|p| fast_atan2(-p[1], -p[0]) * SECTORS_PER_RADIAN).collect()
    }

    #[inline]
    fn sector(&self, i: usize) -> u32 {
        (cell_index(self.bearings[i] + self.yaw) & (crate::visibility::wall_facing::SECTORS - 1)) as u32
    }
}

/// `atan2(y, x)` to within 0.0015 rad (0.1 degree; a sector is 22.5), a quarter of libm's cost:
/// a degree-5 odd polynomial on the octant, mirrored.
#[inline]
fn fast_atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    if hi == 0.0 {
        return 0.0;
    }
    let t = lo / hi;
    let t2 = t * t;
    let mut a = t * (0.995_354 + t2 * (-0.288_679 + t2 * 0.079_331));
    if ay > ax {
        a = FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    if y < 0.0 {
        -a
    } else {
        a
    }
}

const SECTORS_PER_RADIAN: f64 = crate::visibility::wall_facing::SECTORS as f64 / std::f64::consts::TAU;

/// `yes` if `pick` else `no`, as arithmetic (a conditional move).
#[inline]
fn select(pick: bool, yes: u32, no: u32) -> u32 {
    let mask = (pick as u32).wrapping_neg();
    (yes & mask) | (no & !mask)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn walls(rng: &mut ChaCha8Rng) -> Vec<[f64; 2]> {
        let mut pts = Vec::new();
        for i in 0..400 {
            let t = i as f64 * 0.05;
            pts.extend([[t, 0.0], [t, 0.2], [t, 6.0], [0.0, t * 0.3], [20.0, t * 0.3], [7.0, 0.2 + t * 0.1]]);
        }
        // Clutter of isolated points, and a wall at an angle.
        pts.extend((0..300).map(|_| [rng.random_range(0.0..20.0), rng.random_range(0.0..6.0)]));
        pts.extend((0..200).map(|i| [2.0 + i as f64 * 0.03, 1.0 + i as f64 * 0.017]));
        pts
    }

    fn brute(points: &[[f64; 2]], q: [f64; 2]) -> f64 {
        points.iter().map(|p| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).fold(f64::INFINITY, f64::min)
    }

    /// The batched passes of `find_pairs` against each query answered on its own, with and
    /// without a view, for queries inside the raster, outside it and NaN.
    #[test]
    fn find_pairs_gives_every_point_its_own_look_up() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let pts = walls(&mut rng);
        let tree = Tree2::new_from_slice(&pts);
        let seen: Vec<u16> = (0..pts.len()).map(|_| rng.random_range(0..=u16::MAX)).collect();
        let index = NearestWallIndex::new(&pts, &tree, Some(&seen), 0.03, 0.5, cancel::NEVER).unwrap();
        let mut queries: Vec<[f64; 2]> =
            (0..5000).map(|_| [rng.random_range(-3.0..23.0), rng.random_range(-3.0..9.0)]).collect();
        queries.extend([[f64::NAN, 1.0], [1.0, f64::NAN], [f64::INFINITY, 0.0], [-1e300, 1e300]]);
        let bearings: Vec<f64> = (0..queries.len()).map(|_| rng.random_range(-20.0..20.0)).collect();
        let view = SensorView::new(&bearings, 0.7);
        let mut pairs = Vec::new();
        for max in [0.1f64, 0.3, 0.5, 2.0] {
            let max_sq = max.min(0.5).powi(2);
            // Without a view: the nearest wall point, exactly, within the distance.
            index.find_pairs(&queries, max, None, &mut pairs);
            let expected: Vec<(u32, u32)> = queries
                .iter()
                .enumerate()
                .filter_map(|(i, q)| {
                    let (t, d2) = index.nearest(*q)?;
                    (d2 <= max_sq).then_some((i as u32, t))
                })
                .collect();
            assert_eq!(pairs.iter().map(|p| (p.source, p.target)).collect::<Vec<_>>(), expected, "{max}");
            for p in &pairs {
                assert!((p.sq_dist - brute(&pts, queries[p.source as usize])).abs() < 1e-12);
            }
            // With a view: the rule applied one query at a time.
            index.find_pairs(&queries, max, Some(view), &mut pairs);
            let mut expected = Vec::new();
            for (i, q) in queries.iter().enumerate() {
                let cell = index.cell_of(*q);
                let (mut t, mut d2) = index.nearest_in(cell, *q);
                let bit = 1u16 << view.sector(i);
                if index.sites[t as usize].seen & bit == 0 {
                    let alt = index.alternatives[cell];
                    let a = index.sites[alt as usize];
                    if a.seen & bit != 0 {
                        (t, d2) = (alt, (a.x - q[0]).powi(2) + (a.y - q[1]).powi(2));
                    }
                }
                if d2 <= max_sq && index.sites[t as usize].seen & bit != 0 {
                    expected.push(Pair {
                        source: i as u32,
                        target: index.sites[t as usize].plan,
                        sq_dist: d2,
                    });
                }
            }
            assert_eq!(pairs, expected, "{max}");
            assert!(expected.len() > 100, "{max}: {}", expected.len());
        }
    }

    #[test]
    fn agrees_with_brute_force_within_reach_and_answers_none_beyond() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let pts = walls(&mut rng);
        let tree = Tree2::new_from_slice(&pts);
        for (cell, reach) in [(0.02, 0.4), (0.05, 0.25), (0.11, 1.0)] {
            let index = NearestWallIndex::new(&pts, &tree, None, cell, reach, cancel::NEVER).unwrap();
            let (mut answered, mut beyond) = (0, 0);
            for _ in 0..20_000 {
                let q = [rng.random_range(-2.0..22.0), rng.random_range(-2.0..8.0)];
                let exact = brute(&pts, q);
                match index.nearest(q) {
                    Some((i, d2)) => {
                        answered += 1;
                        assert!((d2 - exact).abs() < 1e-12, "cell {cell}: {q:?} index {d2} exact {exact}");
                        let p = pts[i as usize];
                        assert_eq!(d2, (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2));
                    }
                    None => {
                        beyond += 1;
                        assert!(
                            exact > reach * reach,
                            "cell {cell}: {q:?} is {} m from a wall",
                            exact.sqrt()
                        );
                    }
                }
            }
            assert!(answered > 1000 && beyond > 1000, "cell {cell}: {answered} answered, {beyond} beyond");
        }
    }

    #[test]
    fn stores_only_blocks_near_walls() {
        // One short wall in a large empty extent: most blocks stay empty.
        let mut pts: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 0.05, 0.0]).collect();
        pts.push([40.0, 40.0]);
        let tree = Tree2::new_from_slice(&pts);
        let index = NearestWallIndex::new(&pts, &tree, None, 0.05, 0.3, cancel::NEVER).unwrap();
        let stats = index.stats();
        assert!(stats.stored_blocks * 50 < stats.blocks, "{stats:?}");
        assert!(stats.memory_bytes < 200_000, "{stats:?}");
        assert!(index.nearest([20.0, 20.0]).is_none());
        assert_eq!(index.nearest([0.51, 0.1]).map(|(i, _)| i), Some(10));
        assert!(index.nearest([f64::NAN, 0.0]).is_none());
        assert!(index.nearest([-1e12, 0.0]).is_none());
    }

    #[test]
    fn cell_index_floors_inside_and_lands_on_either_side_of_a_border() {
        for (f, cell) in [(0.0, 0), (0.25, 0), (0.75, 0), (1.5, 1), (2.999_999, 2), (1e6 + 0.3, 1_000_000)] {
            assert_eq!(cell_index(f), cell, "{f}");
        }
        for border in [1.0, 2.0, 3.0, 1e6] {
            let c = cell_index(border);
            assert!(c == border as usize || c + 1 == border as usize, "{border}: {c}");
        }
    }

    #[test]
    fn fast_atan2_is_within_a_tenth_of_a_degree() {
        for k in 0..3600 {
            let a = -std::f64::consts::PI + 0.001 + k as f64 * 0.001_745;
            for r in [1e-3, 1.0, 40.0] {
                let (y, x) = (r * a.sin(), r * a.cos());
                assert!((fast_atan2(y, x) - y.atan2(x)).abs() < 0.0015, "{a}");
            }
        }
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    }

    #[test]
    fn rejects_bad_parameters() {
        let pts = vec![[0.0, 0.0], [1.0, 0.0]];
        let tree = Tree2::new_from_slice(&pts);
        for (cell, reach) in [(0.0, 0.3), (f64::NAN, 0.3), (0.05, -1.0), (0.05, f64::INFINITY)] {
            assert!(matches!(
                NearestWallIndex::new(&pts, &tree, None, cell, reach, cancel::NEVER),
                Err(IcpError::InvalidParameter { .. })
            ));
        }
        let far = vec![[0.0, 0.0], [1e6, 1e6]];
        let tree = Tree2::new_from_slice(&far);
        assert!(matches!(
            NearestWallIndex::new(&far, &tree, None, 0.01, 0.3, cancel::NEVER),
            Err(IcpError::RasterTooLarge { .. })
        ));
        assert!(matches!(
            NearestWallIndex::new(
                &pts,
                &Tree2::new_from_slice(&pts),
                Some(&[0u16; 3]),
                0.05,
                0.3,
                cancel::NEVER
            ),
            Err(IcpError::InvalidParameter { name: "visibility masks", .. })
        ));
        assert_eq!(
            NearestWallIndex::new(&[], &Tree2::new_from_slice(&[]), None, 0.05, 0.3, cancel::NEVER)
                .unwrap_err(),
            IcpError::Empty { what: "plan" }
        );
    }
}
