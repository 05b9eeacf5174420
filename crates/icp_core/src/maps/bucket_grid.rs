//! A uniform bucket grid for exact fixed-radius range queries over a small point set.
//!
//! The candidate cache fetches, for every scan point, all plan points within a radius. A KD-tree
//! radius query descends the tree at every call (kiddo's, used before, ran a general n-nearest
//! search: a few thousand instructions per call here); a
//! grid whose cells are as large as the radius answers the same query by scanning the 3 x 3
//! cells around the query, exactly. It is built per alignment over the visible subset (a few
//! thousand points), in linear time.

/// Points bucketed into square cells of a fixed size.
#[derive(Debug, Clone)]
pub struct BucketGrid {
    origin: [f64; 2],
    cell: f64,
    cols: usize,
    rows: usize,
    /// `offsets[c]..offsets[c + 1]` indexes the entries of cell `c`.
    offsets: Vec<u32>,
    entries: Vec<([f64; 2], u32)>,
}

/// Most cells a grid may have; a set spread wider uses larger cells (queries stay exact).
const MAX_CELLS: usize = 1 << 22;

impl BucketGrid {
    /// Buckets `points` (each with the index reported for it) into cells of at least `cell`
    /// metres. `cell` must be positive and finite.
    pub fn new(points: impl Iterator<Item = ([f64; 2], u32)> + Clone, cell: f64) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let mut n = 0usize;
        for (p, _) in points.clone() {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            n += 1;
        }
        if n == 0 {
            return Self {
                origin: [0.0, 0.0],
                cell,
                cols: 1,
                rows: 1,
                offsets: vec![0, 0],
                entries: Vec::new(),
            };
        }
        // Count cells in floating point (a tiny cell over a wide set must not overflow), and
        // coarsen until the grid fits.
        let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
        let mut cell = if cell.is_finite() && cell > 0.0 { cell } else { w.max(h).max(1.0) };
        let span = |c: f64| ((w / c).floor() + 1.0, (h / c).floor() + 1.0);
        let (mut cols_f, mut rows_f) = span(cell);
        while cols_f * rows_f > MAX_CELLS as f64 {
            cell *= 2.0;
            (cols_f, rows_f) = span(cell);
        }
        let (cols, rows) = (cols_f as usize, rows_f as usize);
        let mut grid = Self {
            origin: lo,
            cell,
            cols,
            rows,
            offsets: vec![0; cols * rows + 1],
            entries: Vec::with_capacity(n),
        };
        for (p, _) in points.clone() {
            let c = grid.cell_index(p);
            grid.offsets[c + 1] += 1;
        }
        for c in 0..cols * rows {
            grid.offsets[c + 1] += grid.offsets[c];
        }
        let mut fill: Vec<u32> = grid.offsets[..cols * rows].to_vec();
        grid.entries.resize(n, ([0.0, 0.0], 0));
        for (p, idx) in points {
            let c = grid.cell_index(p);
            grid.entries[fill[c] as usize] = (p, idx);
            fill[c] += 1;
        }
        grid
    }

    /// Cell size actually used, metres.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    #[inline]
    fn coords(&self, p: [f64; 2]) -> (i64, i64) {
        (
            ((p[0] - self.origin[0]) / self.cell).floor() as i64,
            ((p[1] - self.origin[1]) / self.cell).floor() as i64,
        )
    }

    #[inline]
    fn cell_index(&self, p: [f64; 2]) -> usize {
        let (c, r) = self.coords(p);
        r.clamp(0, self.rows as i64 - 1) as usize * self.cols + c.clamp(0, self.cols as i64 - 1) as usize
    }

    /// Calls `f(point, index, squared distance)` for every point within `radius` of `q`.
    /// Exact for `radius <= self.cell()`.
    #[inline]
    pub fn for_each_within(&self, q: [f64; 2], radius: f64, mut f: impl FnMut([f64; 2], u32, f64)) {
        debug_assert!(radius <= self.cell * (1.0 + 1e-12));
        let r2 = radius * radius;
        let (c, r) = self.coords(q);
        // Saturating: a query far outside a grid of tiny cells has coordinates at the i64 limits.
        let (c0, c1) = (c.saturating_sub(1).max(0), c.saturating_add(1).min(self.cols as i64 - 1));
        let (r0, r1) = (r.saturating_sub(1).max(0), r.saturating_add(1).min(self.rows as i64 - 1));
        if c0 > c1 || r0 > r1 {
            return;
        }
        for row in r0..=r1 {
            let base = row as usize * self.cols;
            let (lo, hi) =
                (self.offsets[base + c0 as usize] as usize, self.offsets[base + c1 as usize + 1] as usize);
            for &(p, idx) in &self.entries[lo..hi] {
                let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                if d2 <= r2 {
                    f(p, idx, d2);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn a_query_far_outside_a_grid_of_tiny_cells_finds_nothing() {
        // Found by the core fuzz target `correspondences`: coincident points keep a tiny cell, so
        // a query a metre away sits at cell i64::MIN/MAX and the neighbour range overflowed.
        let grid = BucketGrid::new([([1.0, 1.0], 0u32), ([1.0, 1.0], 1)].into_iter(), 2e-300);
        for q in [[0.0, 0.0], [2.0, 2.0], [-1e300, 1e300], [f64::NAN, 1.0]] {
            let mut n = 0;
            grid.for_each_within(q, 1e-300, |_, _, _| n += 1);
            assert_eq!(n, 0, "{q:?}");
        }
        let mut n = 0;
        grid.for_each_within([1.0, 1.0], 1e-300, |_, _, _| n += 1);
        assert_eq!(n, 2);
    }

    #[test]
    fn range_query_matches_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let pts: Vec<[f64; 2]> =
            (0..3000).map(|_| [rng.random_range(-20.0..20.0), rng.random_range(-5.0..15.0)]).collect();
        let grid = BucketGrid::new(pts.iter().enumerate().map(|(i, p)| (*p, i as u32)), 0.8);
        for _ in 0..500 {
            let q = [rng.random_range(-22.0..22.0), rng.random_range(-7.0..17.0)];
            let r = rng.random_range(0.05..0.8);
            let mut got = Vec::new();
            grid.for_each_within(q, r, |_, i, _| got.push(i));
            got.sort_unstable();
            let want: Vec<u32> = (0..pts.len() as u32)
                .filter(|&i| {
                    let p = pts[i as usize];
                    (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) <= r * r
                })
                .collect();
            assert_eq!(got, want);
        }
    }

    #[test]
    fn a_tiny_cell_over_a_wide_set_is_coarsened_not_overflowed() {
        let grid = BucketGrid::new([([0.0, 0.0], 0u32), ([1e9, -1e9], 1)].into_iter(), 1e-198);
        let mut got = Vec::new();
        grid.for_each_within([1e9, -1e9], 1e-198, |_, i, _| got.push(i));
        assert_eq!(got, vec![1]);
    }

    #[test]
    fn a_far_spread_set_coarsens_its_cells() {
        let grid = BucketGrid::new([([0.0, 0.0], 0u32), ([1e6, 1e6], 1)].into_iter(), 0.5);
        assert!(grid.cell() > 0.5);
        let mut got = Vec::new();
        grid.for_each_within([1e6, 1e6], 0.5, |_, i, _| got.push(i));
        assert_eq!(got, vec![1]);
        let empty = BucketGrid::new(std::iter::empty(), 0.5);
        empty.for_each_within([0.0, 0.0], 0.5, |_, _, _| panic!("no points"));
    }
}
