//! Look-ups in a [`NearestWallIndex`]: one point's nearest wall point, and a scan's pairs in
//! passes whose reads are independent of one another.

use crate::maps::nearest_wall_index::{cell_index, NearestWallIndex, SensorView, BLOCK, BLOCK_CELLS, LIST};
use crate::maps::pair::Pair;

impl NearestWallIndex {
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
    pub(super) fn cell_of(&self, q: [f64; 2]) -> usize {
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
    pub(super) fn nearest_in(&self, cell: usize, q: [f64; 2]) -> (u32, f64) {
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

/// `yes` if `pick` else `no`, as arithmetic (a conditional move).
#[inline]
fn select(pick: bool, yes: u32, no: u32) -> u32 {
    let mask = (pick as u32).wrapping_neg();
    (yes & mask) | (no & !mask)
}
