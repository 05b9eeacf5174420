//! Building a [`NearestWallIndex`]: the blocks within reach of a wall found point by point, then
//! per block one KD-tree radius query and, per cell, the exact nearest distance, the points whose
//! Voronoi regions meet the cell and the alternative for a hidden nearest point.

use crate::cancel::{self, Cancel};
use crate::error::{invalid, IcpError, Result};
use crate::grids::bounding_box::bounding_box;
use crate::maps::kd_tree::Tree2;
use crate::maps::nearest_wall_index::{
    NearestWallIndex, Site, ALTERNATIVE_REACH, BLOCK, BLOCK_CELLS, EMPTY, LIST, MAX_INDEX_CELLS,
    MAX_INDEX_POINTS,
};
use crate::parallel;
use crate::visibility::wall_facing::SEEN_FROM_EVERYWHERE;
use std::ops::Range;

/// Block rows per chunk of work (the chunks run on every core, see [`crate::parallel`]).
const ROWS_PER_BAND: usize = 4;

/// What [`NearestWallIndex::fill_band`] made of a band of block rows.
#[derive(Default)]
struct Band {
    /// Block indices of the stored blocks, row-major.
    stored: Vec<usize>,
    /// Their cells, [`BLOCK_CELLS`] per block, as the index's `building` holds them.
    cells: Vec<[u32; 3]>,
    /// The cells' lists; a cell's offset counts from the band's first.
    lists: Vec<u32>,
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
        let (lo, hi) = bounding_box(points);
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
                what: "nearest-wall index",
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
        // Bands of block rows on every core, each with its own lists; stitched in row order, so
        // the index is the same whatever the number of threads.
        let bands = block_rows.div_ceil(ROWS_PER_BAND);
        let filled = parallel::map_chunks(bands, cancel, |band| {
            let rows = band * ROWS_PER_BAND..((band + 1) * ROWS_PER_BAND).min(block_rows);
            Ok(self.fill_band(points, tree, &near, rows))
        })?;
        for band in filled {
            let first_block = (self.building.len() / BLOCK_CELLS) as u32;
            let list_offset = self.lists_len()?;
            for (j, &b) in band.stored.iter().enumerate() {
                self.blocks[b] = first_block + j as u32;
            }
            self.building.extend(band.cells.iter().map(|&[a, b, alt]| {
                if a & LIST != 0 {
                    [a, b + list_offset, alt]
                } else {
                    [a, b, alt]
                }
            }));
            self.lists.extend_from_slice(&band.lists);
        }
        self.lists_len()?;
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

    /// The cells of the blocks in block `rows` that are `near` a wall (row-major), with their
    /// lists (offsets into the band's own `lists`).
    fn fill_band(&self, points: &[[f64; 2]], tree: &Tree2, near: &[bool], rows: Range<usize>) -> Band {
        let cell = self.cell;
        let half_diagonal = cell * std::f64::consts::FRAC_1_SQRT_2;
        let block_size = cell * BLOCK as f64;
        let block_half_diagonal = block_size * std::f64::consts::FRAC_1_SQRT_2;
        let sentinel = points.len() as u32;
        let mut band = Band::default();
        // Per cell in a block: (squared distance to the cell's centre, plan index) of the block's
        // points.
        let mut nearby: Vec<(f64, u32)> = Vec::new();
        let mut list: Vec<(f64, u32)> = Vec::new();
        let mut kept: Vec<u32> = Vec::new();
        for brow in rows {
            for bcol in 0..self.block_cols {
                if !near[brow * self.block_cols + bcol] {
                    continue;
                }
                // A block costs about a KD-tree query and 64 short scans: tens of microseconds.
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
                band.stored.push(brow * self.block_cols + bcol);
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
                                    // Checked against LIST when the bands are stitched.
                                    let offset = band.lists.len() as u32;
                                    band.lists.extend_from_slice(&kept);
                                    [LIST | kept.len() as u32, offset, alt]
                                }
                            };
                        }
                        band.cells.push(slot);
                    }
                }
            }
        }
        band
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
            what: "nearest-wall index",
            resolution: self.cell,
            cells: self.lists.len() as f64,
            limit: LIST as usize,
        })
    }
}
