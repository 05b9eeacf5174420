//! The plan as a likelihood field for correlative scan matching, with its max-pooled pyramid.
//!
//! Every cell of a raster over the plan holds `exp(-d^2 / (2 sigma^2))`, `d` the distance from the
//! cell's centre to the nearest cell holding a wall point (an exact Euclidean distance transform,
//! Felzenszwalb and Huttenlocher 2012), cut to 0 beyond `3 sigma`. Level `h` of the pyramid holds,
//! at cell `(col, row)`, the largest level-0 value over the `2^h x 2^h` block of cells
//! `[col, col + 2^h) x [row, row + 2^h)`: the bound that branch and bound needs (Olson 2009;
//! Hess et al. 2016, Cartographer's `PrecomputationGrid2D`).
//!
//! Values are stored as bytes (`round(255 * likelihood)`, as Cartographer does), so that the
//! pyramid of a large plan stays in the processor's caches; the levels bound the stored bytes
//! exactly.
//!
//! Cell `(col, row)` covers `x in [origin_x + col*res, origin_x + (col+1)*res)` and likewise `y`
//! with `row`. The raster spans the plan's bounding box plus `3 sigma + res`, padded on every side
//! by the largest block size, so every value outside the stored cells is exactly 0.

use crate::error::{invalid, IcpError, Result};
use crate::grids::bounding_box::bounding_box;

/// Most cells all levels of a pyramid may hold together (one byte each: 64 MiB).
pub const MAX_PYRAMID_CELLS: usize = 64 * 1024 * 1024;

/// Most pyramid levels (blocks up to `2^(MAX_LEVELS-1)` cells wide).
pub const MAX_LEVELS: usize = 12;

/// A likelihood raster of the plan and its max-pooled levels.
#[derive(Debug, Clone)]
pub struct LikelihoodPyramid {
    resolution: f64,
    sigma: f64,
    origin: [f64; 2],
    cols: usize,
    rows: usize,
    /// `levels[h][row * cols + col]`: likelihood times 255.
    levels: Vec<Vec<u8>>,
}

impl LikelihoodPyramid {
    /// Builds the field of `points` (wall points, metres, map frame) at `resolution` metres per
    /// cell with a Gaussian of `sigma` metres, and `levels` pyramid levels (1 = the field alone).
    pub fn new(points: &[[f64; 2]], resolution: f64, sigma: f64, levels: usize) -> Result<Self> {
        for (name, v) in [("resolution", resolution), ("sigma", sigma)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(name, v, "must be a positive finite number of metres"));
            }
        }
        if !(1..=MAX_LEVELS).contains(&levels) {
            return Err(invalid("levels", levels, "must be between 1 and 12"));
        }
        if points.is_empty() {
            return Err(IcpError::Empty { what: "plan" });
        }
        crate::error::check_finite("plan", points)?;
        let (lo, hi) = bounding_box(points);
        let pad = (1usize << (levels - 1)) as f64;
        let margin = 3.0 * sigma + resolution + pad * resolution;
        let origin = [lo[0] - margin, lo[1] - margin];
        let cols_f = ((hi[0] + margin - origin[0]) / resolution).ceil() + 1.0;
        let rows_f = ((hi[1] + margin - origin[1]) / resolution).ceil() + 1.0;
        let cells = cols_f * rows_f * levels as f64;
        if !(cells.is_finite() && cells <= MAX_PYRAMID_CELLS as f64) {
            return Err(invalid(
                "resolution",
                format!("{resolution} m ({cells:.3e} cells over {levels} levels)"),
                "the likelihood pyramid over the plan would exceed 2^26 cells; give a coarser \
                 resolution or fewer levels",
            ));
        }
        let (cols, rows) = (cols_f as usize, rows_f as usize);
        let mut wall = vec![false; cols * rows];
        for p in points {
            let c = ((p[0] - origin[0]) / resolution).floor() as usize;
            let r = ((p[1] - origin[1]) / resolution).floor() as usize;
            wall[r * cols + c] = true;
        }
        let d2 = squared_distance_transform(&wall, cols, rows);
        let cutoff2 = (3.0 * sigma / resolution).powi(2);
        let scale = -(resolution * resolution) / (2.0 * sigma * sigma);
        let base: Vec<u8> = d2
            .iter()
            .map(|&d| if d <= cutoff2 { (255.0 * (d * scale).exp()).round() as u8 } else { 0 })
            .collect();
        let mut pyramid = Self { resolution, sigma, origin, cols, rows, levels: vec![base] };
        for h in 1..levels {
            let next = pyramid.max_pool(h);
            pyramid.levels.push(next);
        }
        Ok(pyramid)
    }

    /// Level `h` from level `h - 1`: the max over `[c, c + 2^h)` is the max of two halves.
    fn max_pool(&self, h: usize) -> Vec<u8> {
        let prev = &self.levels[h - 1];
        let s = 1usize << (h - 1);
        let (cols, rows) = (self.cols, self.rows);
        let at = |c: usize, r: usize| if c < cols && r < rows { prev[r * cols + c] } else { 0 };
        let mut out = vec![0u8; cols * rows];
        for r in 0..rows {
            for c in 0..cols {
                out[r * cols + c] = at(c, r).max(at(c + s, r)).max(at(c, r + s)).max(at(c + s, r + s));
            }
        }
        out
    }

    /// Metres per cell.
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Width of the Gaussian, metres.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// Map-frame corner of cell (0, 0), metres.
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }

    /// (cols, rows) of every level.
    pub fn shape(&self) -> (usize, usize) {
        (self.cols, self.rows)
    }

    /// Number of levels.
    pub fn num_levels(&self) -> usize {
        self.levels.len()
    }

    /// Value of level `h` at cell `(col, row)` times 255; 0 outside the raster (exact: the field
    /// is 0 there).
    #[inline]
    pub fn get(&self, h: usize, col: i64, row: i64) -> u8 {
        if col < 0 || row < 0 || col >= self.cols as i64 || row >= self.rows as i64 {
            return 0;
        }
        self.levels[h][row as usize * self.cols + col as usize]
    }

    /// The cell holding map-frame point `p` (may lie outside the raster).
    #[inline]
    pub fn cell_of(&self, p: [f64; 2]) -> [i64; 2] {
        [
            ((p[0] - self.origin[0]) / self.resolution).floor() as i64,
            ((p[1] - self.origin[1]) / self.resolution).floor() as i64,
        ]
    }

    /// The level-0 likelihood (0..1) at map-frame point `p`.
    pub fn value_at(&self, p: [f64; 2]) -> f64 {
        let [c, r] = self.cell_of(p);
        self.get(0, c, r) as f64 / 255.0
    }
}

/// Squared Euclidean distance, in cells, from every cell to the nearest `true` cell
/// (`f64::INFINITY` when there is none). Row-major `cols x rows`.
pub fn squared_distance_transform(wall: &[bool], cols: usize, rows: usize) -> Vec<f64> {
    let mut out: Vec<f64> = wall.iter().map(|&w| if w { 0.0 } else { f64::INFINITY }).collect();
    let mut env = Envelope::default();
    let mut line = Vec::new();
    let mut result = Vec::new();
    // Along columns (fixed c, varying r), then along rows.
    for c in 0..cols {
        line.clear();
        line.extend((0..rows).map(|r| out[r * cols + c]));
        env.transform(&line, &mut result);
        for (r, v) in result.iter().enumerate() {
            out[r * cols + c] = *v;
        }
    }
    for r in 0..rows {
        line.clear();
        line.extend_from_slice(&out[r * cols..(r + 1) * cols]);
        env.transform(&line, &mut result);
        out[r * cols..(r + 1) * cols].copy_from_slice(&result);
    }
    out
}

/// Scratch space of the 1-D transform: the lower envelope of parabolas `(q - v)^2 + f(v)`.
#[derive(Default)]
struct Envelope {
    /// Apex positions of the parabolas in the envelope.
    v: Vec<usize>,
    /// `z[k]`: where parabola `k` starts being the lowest.
    z: Vec<f64>,
}

impl Envelope {
    /// `out[q] = min_p (q - p)^2 + f[p]` over the finite `f[p]`; infinite where none is finite.
    fn transform(&mut self, f: &[f64], out: &mut Vec<f64>) {
        self.v.clear();
        self.z.clear();
        out.clear();
        for (q, &fq) in f.iter().enumerate() {
            if !fq.is_finite() {
                continue;
            }
            let mut start = f64::NEG_INFINITY;
            while let Some(&p) = self.v.last() {
                let (qf, pf) = (q as f64, p as f64);
                let s = ((fq + qf * qf) - (f[p] + pf * pf)) / (2.0 * (qf - pf));
                if s <= *self.z.last().expect("z and v have equal lengths") {
                    self.v.pop();
                    self.z.pop();
                } else {
                    start = s;
                    break;
                }
            }
            self.v.push(q);
            self.z.push(start);
        }
        if self.v.is_empty() {
            out.resize(f.len(), f64::INFINITY);
            return;
        }
        let mut k = 0;
        for q in 0..f.len() {
            let qf = q as f64;
            while k + 1 < self.v.len() && self.z[k + 1] < qf {
                k += 1;
            }
            let p = self.v[k];
            out.push((qf - p as f64).powi(2) + f[p]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn distance_transform_matches_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (cols, rows) = (37, 23);
        let wall: Vec<bool> = (0..cols * rows).map(|_| rng.random_bool(0.03)).collect();
        let d2 = squared_distance_transform(&wall, cols, rows);
        for r in 0..rows {
            for c in 0..cols {
                let mut best = f64::INFINITY;
                for (i, _) in wall.iter().enumerate().filter(|(_, w)| **w) {
                    let (wr, wc) = (i / cols, i % cols);
                    let d = (wr as f64 - r as f64).powi(2) + (wc as f64 - c as f64).powi(2);
                    best = best.min(d);
                }
                assert_eq!(d2[r * cols + c], best, "cell ({c}, {r})");
            }
        }
        assert!(squared_distance_transform(&[false; 6], 3, 2).iter().all(|d| d.is_infinite()));
    }

    #[test]
    fn levels_bound_every_block() {
        let pts: Vec<[f64; 2]> = (0..200).map(|i| [i as f64 * 0.05, (i as f64 * 0.1).sin()]).collect();
        let pyr = LikelihoodPyramid::new(&pts, 0.1, 0.1, 4).unwrap();
        let (cols, rows) = pyr.shape();
        for h in 1..4 {
            let w = 1i64 << h;
            for r in (0..rows as i64).step_by(3) {
                for c in (0..cols as i64).step_by(3) {
                    let mut m = 0u8;
                    for dr in 0..w {
                        for dc in 0..w {
                            m = m.max(pyr.get(0, c + dc, r + dr));
                        }
                    }
                    assert_eq!(pyr.get(h, c, r), m);
                }
            }
        }
        // On a wall the likelihood is 1, far away 0.
        assert_eq!(pyr.value_at([0.0, 0.0]), 1.0);
        assert_eq!(pyr.value_at([5.0, 5.0]), 0.0);
        assert_eq!(pyr.get(0, -1, 0), 0);
    }

    #[test]
    fn rejects_bad_input_and_oversized_rasters() {
        let pts = [[0.0, 0.0], [1.0, 1.0]];
        assert!(matches!(LikelihoodPyramid::new(&[], 0.1, 0.1, 3), Err(IcpError::Empty { .. })));
        assert!(matches!(
            LikelihoodPyramid::new(&pts, 0.0, 0.1, 3),
            Err(IcpError::InvalidParameter { name: "resolution", .. })
        ));
        assert!(matches!(
            LikelihoodPyramid::new(&pts, 0.1, f64::NAN, 3),
            Err(IcpError::InvalidParameter { name: "sigma", .. })
        ));
        assert!(matches!(
            LikelihoodPyramid::new(&pts, 0.1, 0.1, 0),
            Err(IcpError::InvalidParameter { name: "levels", .. })
        ));
        assert!(matches!(
            LikelihoodPyramid::new(&[[0.0, 0.0], [1e6, 1e6]], 0.05, 0.1, 3),
            Err(IcpError::InvalidParameter { name: "resolution", .. })
        ));
    }
}
