//! Clearance: how far a beam can travel through a raster without looking at every cell.
//!
//! Every free cell knows its Chebyshev distance to the nearest occupied cell. A beam standing in a
//! cell with clearance `d` cannot enter an occupied cell within the next `d - 1` cells of travel, so
//! it may move `d - 2` cells at once (one cell is kept as a guard against rounding) to just after the
//! last grid-line crossing before that point, and go on cell by cell from there. The crossings are
//! counted with [`BeamAxis`], whose parameters are exact, so a jump lands in the cell the cell-by-cell
//! walk would have reached. Used by the simulated LIDAR ([`crate::grids::ray_casting`]) and by the
//! visibility casts ([`crate::visibility::visible_points`]).

/// Clearance (cells) from which a beam jumps instead of stepping: a jump costs a few stepping
/// iterations, so it only pays across wider empty space.
pub const SKIP_MIN_CLEARANCE: u8 = 6;

/// Chebyshev distance of every cell to the nearest occupied cell, capped at 255 (0 when occupied):
/// the exact two-pass chessboard distance transform. Each pass takes a row at a time: the three
/// cells of the row before (after, going back) for every cell at once, then the one dependency
/// along the row, the cell before it.
pub fn chebyshev_clearance(cells: &[bool], rows: usize, cols: usize) -> Vec<u8> {
    let mut d: Vec<u8> = cells.iter().map(|&o| if o { 0 } else { u8::MAX }).collect();
    if rows == 0 || cols == 0 {
        return d;
    }
    let mut across = vec![u8::MAX; cols];
    // Forward: from the cell to the left and the three cells of the row below.
    for r in 0..rows {
        let (done, rest) = d.split_at_mut(r * cols);
        let row = &mut rest[..cols];
        if r > 0 {
            neighbours_plus_one(&done[(r - 1) * cols..], &mut across);
        }
        let mut before = u8::MAX;
        for (v, &a) in row.iter_mut().zip(&across) {
            *v = (*v).min(a).min(before.saturating_add(1));
            before = *v;
        }
    }
    // Backward: from the cell to the right and the three cells of the row above.
    across.fill(u8::MAX);
    for r in (0..rows).rev() {
        let (head, done) = d.split_at_mut((r + 1) * cols);
        let row = &mut head[r * cols..];
        if r + 1 < rows {
            neighbours_plus_one(&done[..cols], &mut across);
        }
        let mut after = u8::MAX;
        for (v, &a) in row.iter_mut().zip(&across).rev() {
            *v = (*v).min(a).min(after.saturating_add(1));
            after = *v;
        }
    }
    d
}

/// `out[c]` = 1 + the least of `row[c - 1]`, `row[c]` and `row[c + 1]` (those that exist),
/// saturating at 255.
fn neighbours_plus_one(row: &[u8], out: &mut [u8]) {
    let n = out.len();
    if n == 1 {
        out[0] = row[0].saturating_add(1);
        return;
    }
    out[0] = row[0].min(row[1]).saturating_add(1);
    out[n - 1] = row[n - 2].min(row[n - 1]).saturating_add(1);
    for (o, w) in out[1..n - 1].iter_mut().zip(row[..n].windows(3)) {
        *o = w[0].min(w[1]).min(w[2]).saturating_add(1);
    }
}

/// The crossings of one axis's grid lines along a beam, in cells: crossing `k` (0-based) is at
/// parameter `(f + k) * inv` and moves the beam `step` cells along the axis.
#[derive(Clone, Copy)]
pub struct BeamAxis {
    f: f64,
    inv: f64,
    abs_dir: f64,
    /// +1 or -1: the cells each crossing moves the beam along the axis.
    pub step: i64,
}

impl BeamAxis {
    /// The crossings from `g` (cell units) in start cell `c` along the direction component `d`.
    #[inline]
    pub fn new(g: f64, c: i64, d: f64) -> Self {
        let abs_dir = d.abs();
        if abs_dir > 0.0 {
            let f = if d > 0.0 { (c + 1) as f64 - g } else { g - c as f64 };
            Self { f, inv: 1.0 / abs_dir, abs_dir, step: if d > 0.0 { 1 } else { -1 } }
        } else {
            Self { f: 1.0, inv: f64::INFINITY, abs_dir, step: -1 }
        }
    }

    /// Parameter of crossing `k`.
    #[inline]
    pub fn t(&self, k: i64) -> f64 {
        (self.f + k as f64) * self.inv
    }

    /// How many crossings lie before parameter `t` (`t(k) < t`), computed with [`BeamAxis::t`] itself so
    /// that the count agrees with the parameters the walk compares.
    #[inline]
    pub fn crossings_before(&self, t: f64) -> i64 {
        if self.abs_dir == 0.0 {
            return 0;
        }
        // A first guess within one of the count (a truncating cast, not `ceil`, which is a library
        // call on baseline x86-64); the loops below make it exact.
        let mut k = ((t * self.abs_dir - self.f) as i64).saturating_add(1).max(0);
        while k > 0 && self.t(k - 1) >= t {
            k -= 1;
        }
        while self.t(k) < t {
            k += 1;
        }
        k
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn clearance_is_the_chebyshev_distance() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        // Rows and columns of one cell take the passes' edge cases.
        for (rows, cols) in [(37, 53), (1, 1), (1, 9), (9, 1), (2, 2), (5, 300)] {
            let cells: Vec<bool> = (0..rows * cols).map(|_| rng.random_bool(0.01)).collect();
            let d = chebyshev_clearance(&cells, rows, cols);
            for r in 0..rows {
                for c in 0..cols {
                    let mut best = 255usize;
                    for rr in 0..rows {
                        for cc in 0..cols {
                            if cells[rr * cols + cc] {
                                best = best.min(r.abs_diff(rr).max(c.abs_diff(cc)));
                            }
                        }
                    }
                    assert_eq!(d[r * cols + c] as usize, best.min(255), "({rows}, {cols}) at ({r}, {c})");
                }
            }
        }
        assert!(chebyshev_clearance(&[false; 6], 2, 3).iter().all(|&v| v == 255));
        assert_eq!(chebyshev_clearance(&[true], 1, 1), vec![0]);
    }
}
