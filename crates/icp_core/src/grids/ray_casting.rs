//! A simulated 2D LIDAR: exact ranges from a sensor pose through an occupancy raster and past moving
//! discs (people, robots), with Gaussian range noise and dropouts.
//!
//! Each beam walks the raster cell by cell (Amanatides-Woo) and stops at the boundary of the first
//! occupied cell; the distance is exact up to rounding. Beams cross empty space in jumps: every free
//! cell knows its Chebyshev distance to the nearest occupied cell, and a beam that stands in a cell
//! with clearance `d` cannot enter an occupied cell within the next `d - 1` cells of travel, so it
//! moves `d - 2` cells at once (one cell is kept as a guard against rounding) without changing the
//! result.
//!
//! The walk reproduces the numpy reference caster, `simulate_ranges` in `tests/numpy_ray_caster.py`
//! (with `range_sigma=0, dropout=0`; `planicp.sim` casts with this one), operation for operation:
//! the same beam angles `(yaw + angle_min) + angle_increment * i`, the same crossing
//! parameters `(f + k) / |d|` in cells, and the same corner rule: two grid-line crossings less than
//! [`CORNER_TIE`] cells apart are one crossing of the corner, so the beam enters the diagonal cell and
//! does not hit the two cells it only grazes there. What can still differ is the last bit of `sin`
//! and `cos` (numpy may use its own vectorised versions), which moves a distance by ~1e-16 relative
//! and, on a beam that passes within ~1e-9 cells of a cell corner, can flip that corner's decision.
//!
//! Ranges follow ROS REP-117: `+inf` when nothing is hit within `range_max` (and for dropouts),
//! `-inf` for a return closer than `range_min`.

use crate::error::{invalid, Result, MAX_COORDINATE};
use crate::grids::clearance::{chebyshev_clearance, BeamAxis, SKIP_MIN_CLEARANCE};
use crate::pose::Pose2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Grid-line crossings closer than this along a beam (in cells) are one crossing of a cell corner.
pub const CORNER_TIE: f64 = 1e-9;
/// Finest raster resolution accepted, metres per cell (keeps cell indices exact in an `f64`).
pub const MIN_RESOLUTION: f64 = 1e-6;
/// Most cells an [`OccupancyRaster`] may have.
pub const MAX_CELLS: usize = crate::grids::wall_raster::MAX_RASTER_CELLS;
/// Most beams one scan may have.
pub const MAX_BEAMS: usize = 1 << 20;

/// An occupancy grid to cast beams through.
///
/// Cells are row-major and the ROW INDEX GROWS WITH +y: row 0 is the lowest y (the convention of
/// `planicp.sim.Floor`, not image order). Cell `(row, col)` covers
/// `x in [origin_x + col * res, origin_x + (col + 1) * res)` and the same for `y` with `row`.
/// Everything outside the raster is free.
#[derive(Debug, Clone)]
pub struct OccupancyRaster {
    rows: usize,
    cols: usize,
    resolution: f64,
    origin: [f64; 2],
    /// Per cell: 0 when occupied, else the Chebyshev distance in cells to the nearest occupied cell
    /// (1 next to one), capped at 255. Every cell within `clearance - 1` cells is free.
    clearance: Vec<u8>,
}

impl OccupancyRaster {
    /// A raster of `rows x cols` cells (`cells[row * cols + col]`, true = occupied) with square
    /// cells of `resolution` metres and `origin` the map-frame (x, y) of the lower-left CORNER of
    /// cell (0, 0).
    ///
    /// Errors: an empty shape, more than [`MAX_CELLS`] cells, `cells.len() != rows * cols`, a
    /// resolution that is not finite or below [`MIN_RESOLUTION`], an origin or extent that is not
    /// finite or reaches beyond [`MAX_COORDINATE`].
    pub fn new(
        cells: Vec<bool>,
        rows: usize,
        cols: usize,
        resolution: f64,
        origin: [f64; 2],
    ) -> Result<Self> {
        if rows == 0 || cols == 0 {
            return Err(invalid(
                "raster shape",
                format!("({rows} rows, {cols} cols)"),
                "needs at least one row and one column",
            ));
        }
        let n = rows.checked_mul(cols).filter(|&n| n <= MAX_CELLS).ok_or_else(|| {
            invalid("raster shape", format!("({rows} rows, {cols} cols)"), "may have at most 2^28 cells")
        })?;
        if cells.len() != n {
            return Err(invalid(
                "raster cells",
                format!("{} values for {rows} rows x {cols} cols", cells.len()),
                "must hold exactly rows * cols values, row-major",
            ));
        }
        if !(resolution.is_finite() && resolution >= MIN_RESOLUTION) {
            return Err(invalid(
                "raster resolution",
                resolution,
                "must be a finite number of metres >= 1e-6",
            ));
        }
        let far = [origin[0] + cols as f64 * resolution, origin[1] + rows as f64 * resolution];
        let within = |v: f64| v.is_finite() && v.abs() <= MAX_COORDINATE;
        if !(within(origin[0]) && within(origin[1])) {
            return Err(invalid("raster origin", format!("{origin:?}"), "must be finite, within +-1e9 m"));
        }
        if !(within(far[0]) && within(far[1])) {
            return Err(invalid(
                "raster extent",
                format!("{origin:?} to {far:?}"),
                "must lie within +-1e9 m",
            ));
        }
        let clearance = chebyshev_clearance(&cells, rows, cols);
        Ok(Self { rows, cols, resolution, origin, clearance })
    }

    /// `(rows, cols)`.
    pub fn shape(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    /// Metres per cell.
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Map-frame (x, y) of the lower-left corner of cell (0, 0), metres.
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }

    /// Whether cell `(row, col)` is occupied; outside the raster is free.
    pub fn is_occupied(&self, row: i64, col: i64) -> bool {
        self.index(col, row).is_some_and(|k| self.clearance[k] == 0)
    }

    /// Number of occupied cells.
    pub fn occupied_cells(&self) -> usize {
        self.clearance.iter().filter(|&&c| c == 0).count()
    }

    /// Linear index of cell (col, row), `None` outside.
    #[inline]
    fn index(&self, col: i64, row: i64) -> Option<usize> {
        let (c, r) = (usize::try_from(col).ok()?, usize::try_from(row).ok()?);
        (c < self.cols && r < self.rows).then_some(r * self.cols + c)
    }
}

/// A moving round obstacle (a person, a robot), map frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// Centre x, metres.
    pub x: f64,
    /// Centre y, metres.
    pub y: f64,
    /// Radius, metres (> 0).
    pub radius: f64,
}

/// The beams of a scan, like a ROS `LaserScan`: beam `i` points along
/// `angle_min + i * angle_increment` (radians, counter-clockwise from the sensor's +x axis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LidarModel {
    /// Angle of the first beam in the sensor frame, radians.
    pub angle_min: f64,
    /// Angle between consecutive beams, radians (any sign).
    pub angle_increment: f64,
    /// Number of beams, 1 to [`MAX_BEAMS`].
    pub beams: usize,
    /// Shortest valid range, metres (>= 0); closer returns read `-inf`.
    pub range_min: f64,
    /// Longest range, metres (finite, > `range_min`); nothing within it reads `+inf`.
    pub range_max: f64,
}

impl LidarModel {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        if !self.angle_min.is_finite() {
            return Err(invalid("angle_min", self.angle_min, "must be a finite number of radians"));
        }
        if !self.angle_increment.is_finite() {
            return Err(invalid(
                "angle_increment",
                self.angle_increment,
                "must be a finite number of radians",
            ));
        }
        if self.beams == 0 || self.beams > MAX_BEAMS {
            return Err(invalid("beams", self.beams, "must be between 1 and 2^20"));
        }
        if !(self.range_min.is_finite() && self.range_min >= 0.0) {
            return Err(invalid("range_min", self.range_min, "must be a finite number of metres >= 0"));
        }
        if !(self.range_max.is_finite() && self.range_max > self.range_min) {
            return Err(invalid(
                "range_max",
                format!("{} (range_min {})", self.range_max, self.range_min),
                "must be finite and greater than range_min",
            ));
        }
        Ok(())
    }
}

/// Checks that every disc is finite, within [`MAX_COORDINATE`], with a positive radius.
fn validate_discs(discs: &[Disc]) -> Result<()> {
    for (k, d) in discs.iter().enumerate() {
        let ok = d.x.is_finite()
            && d.y.is_finite()
            && d.x.abs() <= MAX_COORDINATE
            && d.y.abs() <= MAX_COORDINATE
            && d.radius.is_finite()
            && d.radius > 0.0;
        if !ok {
            return Err(invalid(
                "disc",
                format!("#{k} (x {}, y {}, radius {})", d.x, d.y, d.radius),
                "needs a finite centre within +-1e9 m and a finite radius > 0",
            ));
        }
    }
    Ok(())
}

/// Exact ranges of the beams of `model` from `sensor_pose` (the sensor in the map frame) through
/// `raster` and past `discs`, into `out` (cleared first, `model.beams` values).
///
/// A range is the distance to the first occupied cell boundary or disc along the beam; `+inf` when
/// nothing is within `range_max`, `-inf` when the return is closer than `range_min` (REP-117). A
/// sensor inside an occupied cell or a disc measures 0. The sensor may be outside the raster: the
/// beams then start where they enter it. Agrees with the numpy reference in
/// `tests/numpy_ray_caster.py` (noise-free) as the module documentation describes. The yaw is used
/// as given (not wrapped), so the beam angles round exactly as the Python reference's do.
///
/// Errors: an invalid `model`, a pose that is not finite or beyond [`MAX_COORDINATE`], a bad disc.
pub fn cast_ranges(
    raster: &OccupancyRaster,
    sensor_pose: Pose2,
    model: &LidarModel,
    discs: &[Disc],
    out: &mut Vec<f64>,
) -> Result<()> {
    model.validate()?;
    let Pose2 { x, y, yaw } = sensor_pose;
    if !(sensor_pose.is_finite() && x.abs() <= MAX_COORDINATE && y.abs() <= MAX_COORDINATE) {
        return Err(invalid("sensor pose", format!("{sensor_pose:?}"), "must be finite, within +-1e9 m"));
    }
    validate_discs(discs)?;
    out.clear();
    out.reserve(model.beams);
    let res = raster.resolution;
    let [ox, oy] = raster.origin;
    let (rows, cols) = (raster.rows, raster.cols);
    let t_max = model.range_max / res;
    let inside = x >= ox && x < ox + cols as f64 * res && y >= oy && y < oy + rows as f64 * res;
    let g = ((x - ox) / res, (y - oy) / res);
    let start =
        ((g.0.floor() as i64).clamp(0, cols as i64 - 1), (g.1.floor() as i64).clamp(0, rows as i64 - 1));
    let start_occupied = inside && raster.is_occupied(start.1, start.0);
    let base = yaw + model.angle_min;
    for k in 0..model.beams {
        let angle = base + model.angle_increment * k as f64;
        let (dy, dx) = angle.sin_cos();
        // Parameter of the hit in cells, then metres (as the reference computes them).
        let mut dist = if start_occupied {
            0.0
        } else if inside {
            walk(raster, g, start, (dx, dy), t_max) * res
        } else {
            enter_and_walk(raster, g, (dx, dy), t_max) * res
        };
        let t_disc = discs.iter().map(|d| disc_distance((x, y), (dx, dy), d)).fold(f64::INFINITY, f64::min);
        if t_disc <= model.range_max && t_disc < dist {
            dist = t_disc;
        }
        out.push(if dist > model.range_max {
            f64::INFINITY
        } else if dist < model.range_min {
            f64::NEG_INFINITY
        } else {
            dist
        });
    }
    Ok(())
}

/// Distance (metres) along the unit direction `(dx, dy)` from `p` to the disc; 0 when `p` is inside
/// it, `inf` when the beam misses it or it lies behind. Written as the Python reference's formula.
#[inline]
fn disc_distance((x, y): (f64, f64), (dx, dy): (f64, f64), d: &Disc) -> f64 {
    let (wx, wy) = (x - d.x, y - d.y);
    let b = dx * wx + dy * wy;
    let c = wx * wx + wy * wy - d.radius * d.radius;
    if c <= 0.0 {
        return 0.0;
    }
    let disc = b * b - c;
    if disc < 0.0 {
        return f64::INFINITY;
    }
    let t = -b - disc.sqrt();
    if t >= 0.0 {
        t
    } else {
        f64::INFINITY
    }
}

/// Parameter (cells along the beam) where the beam from `g` (cell units, inside the raster, in the
/// free cell `start`) along the unit direction `(dx, dy)` enters its first occupied cell, or `inf`
/// when it leaves the raster or passes `t_max` first.
#[inline]
fn walk(raster: &OccupancyRaster, g: (f64, f64), start: (i64, i64), (dx, dy): (f64, f64), t_max: f64) -> f64 {
    let ax = BeamAxis::new(g.0, start.0, dx);
    let ay = BeamAxis::new(g.1, start.1, dy);
    let (cols, rows) = (raster.cols, raster.rows);
    let (mut i, mut j) = (0i64, 0i64);
    let (mut tx, mut ty) = (ax.t(0), ay.t(0));
    let (mut cx, mut cy) = start;
    let mut t_cur = 0.0;
    let mut clearance = raster.clearance[start.1 as usize * cols + start.0 as usize];
    // Every iteration moves the beam into the next cell; it crosses at most cols + rows grid lines
    // inside the raster. A hard bound on the loop, whatever rounding does.
    for _ in 0..cols + rows + 4 {
        if clearance >= SKIP_MIN_CLEARANCE {
            // Every cell within clearance - 1 of this one is free, so the beam cannot enter an
            // occupied cell before t_cur + clearance - 1; jump to one cell short of that, to just
            // after the last crossing before it.
            let t_jump = t_cur + f64::from(clearance - 2);
            if t_jump > t_max {
                return f64::INFINITY;
            }
            i = ax.crossings_before(t_jump).max(i);
            j = ay.crossings_before(t_jump).max(j);
            (tx, ty) = (ax.t(i), ay.t(j));
            (cx, cy) = (start.0 + ax.step * i, start.1 + ay.step * j);
            if cx < 0 || cy < 0 || cx as usize >= cols || cy as usize >= rows {
                return f64::INFINITY;
            }
        }
        // The next crossing; a crossing of the other axis within CORNER_TIE after it is the same
        // corner, so the beam moves diagonally and the two grazed cells are not entered. (A
        // branch-free version of this step measured slower: it puts the int-to-float conversion
        // of both counters on the loop's critical path.)
        let t = if tx <= ty {
            let corner = ty <= tx + CORNER_TIE;
            let t = tx;
            i += 1;
            cx += ax.step;
            tx = ax.t(i);
            if corner {
                j += 1;
                cy += ay.step;
                ty = ay.t(j);
            }
            t
        } else {
            let corner = tx <= ty + CORNER_TIE;
            let t = ty;
            j += 1;
            cy += ay.step;
            ty = ay.t(j);
            if corner {
                i += 1;
                cx += ax.step;
                tx = ax.t(i);
            }
            t
        };
        if t > t_max || cx < 0 || cy < 0 || cx as usize >= cols || cy as usize >= rows {
            return f64::INFINITY;
        }
        clearance = raster.clearance[cy as usize * cols + cx as usize];
        if clearance == 0 {
            return t;
        }
        t_cur = t;
    }
    f64::INFINITY
}

/// [`walk`] for a sensor at `g` (cell units) outside the raster: clips the beam to the raster's box
/// (slab method) and walks on from where it enters; the parameter returned counts from `g`.
fn enter_and_walk(raster: &OccupancyRaster, g: (f64, f64), (dx, dy): (f64, f64), t_max: f64) -> f64 {
    let (mut t_in, mut t_out) = (0.0f64, t_max);
    for (o, d, size) in [(g.0, dx, raster.cols as f64), (g.1, dy, raster.rows as f64)] {
        if d == 0.0 {
            if !(0.0..size).contains(&o) {
                return f64::INFINITY;
            }
        } else {
            let (a, b) = ((0.0 - o) / d, (size - o) / d);
            t_in = t_in.max(a.min(b));
            t_out = t_out.min(a.max(b));
        }
    }
    if t_in > t_out {
        return f64::INFINITY;
    }
    let entry = (g.0 + dx * t_in, g.1 + dy * t_in);
    let cell = (
        (entry.0.floor() as i64).clamp(0, raster.cols as i64 - 1),
        (entry.1.floor() as i64).clamp(0, raster.rows as i64 - 1),
    );
    if raster.is_occupied(cell.1, cell.0) {
        return t_in;
    }
    t_in + walk(raster, entry, cell, (dx, dy), t_max - t_in)
}

/// Adds Gaussian range noise of standard deviation `sigma` (metres) to the finite `ranges` and drops
/// each beam with probability `dropout` (its range becomes `+inf`).
///
/// A noisy range beyond `model.range_max` becomes `+inf`, one below `model.range_min` `-inf`;
/// infinite ranges keep their value (a `-inf` return has no distance left to perturb, so unlike the
/// Python reference, which perturbs the true distance before the `range_min` test, a return just
/// below `range_min` never comes back noisy above it). Random draws, in beam order: one standard
/// normal per finite range when `sigma > 0`, then one dropout draw per beam when `dropout > 0`.
///
/// Errors: `sigma` not finite or negative, `dropout` outside [0, 1].
pub fn add_noise<R: Rng + ?Sized>(
    ranges: &mut [f64],
    model: &LidarModel,
    sigma: f64,
    dropout: f64,
    rng: &mut R,
) -> Result<()> {
    if !(sigma.is_finite() && sigma >= 0.0) {
        return Err(invalid("range_sigma", sigma, "must be a finite number of metres >= 0"));
    }
    if !(0.0..=1.0).contains(&dropout) {
        return Err(invalid("dropout", dropout, "must be a probability in [0, 1]"));
    }
    for r in ranges.iter_mut() {
        if sigma > 0.0 && r.is_finite() {
            let z: f64 = rng.sample(StandardNormal);
            let noisy = *r + sigma * z;
            *r = if noisy > model.range_max {
                f64::INFINITY
            } else if noisy < model.range_min {
                f64::NEG_INFINITY
            } else {
                noisy
            };
        }
        if dropout > 0.0 && rng.random_bool(dropout) {
            *r = f64::INFINITY;
        }
    }
    Ok(())
}

/// The generator for [`add_noise`]: ChaCha8 seeded from `seed` (reproducible on every platform), or
/// from the operating system's entropy when `seed` is `None`.
pub fn noise_rng(seed: Option<u64>) -> ChaCha8Rng {
    match seed {
        Some(s) => ChaCha8Rng::seed_from_u64(s),
        None => ChaCha8Rng::from_rng(&mut rand::rng()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::IcpError;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    const RES: f64 = 0.05;

    /// A box room: free inside [0, 4] x [0, 3] m, walls 0.25 m thick around it, a 1 m raster margin
    /// outside. Returns the raster and the (row, col) of the cell at (x, y).
    fn box_room(door: bool) -> OccupancyRaster {
        let origin = [-1.25, -1.25];
        let (cols, rows) = (((4.0 + 2.5) / RES) as usize, ((3.0 + 2.5) / RES) as usize);
        let mut cells = vec![false; rows * cols];
        for r in 0..rows {
            for c in 0..cols {
                let x = origin[0] + (c as f64 + 0.5) * RES;
                let y = origin[1] + (r as f64 + 0.5) * RES;
                let in_outer = (-0.25..4.25).contains(&x) && (-0.25..3.25).contains(&y);
                let in_inner = (0.0..4.0).contains(&x) && (0.0..3.0).contains(&y);
                // A doorway in the right wall at y in [1, 2].
                let in_door = door && x > 3.9 && (1.0..2.0).contains(&y);
                cells[r * cols + c] = in_outer && !in_inner && !in_door;
            }
        }
        OccupancyRaster::new(cells, rows, cols, RES, origin).unwrap()
    }

    fn model(angle_min: f64, angle_increment: f64, beams: usize) -> LidarModel {
        LidarModel { angle_min, angle_increment, beams, range_min: 0.05, range_max: 30.0 }
    }

    fn cast(raster: &OccupancyRaster, pose: Pose2, m: &LidarModel, discs: &[Disc]) -> Vec<f64> {
        let mut out = Vec::new();
        cast_ranges(raster, pose, m, discs, &mut out).unwrap();
        out
    }

    fn single(raster: &OccupancyRaster, x: f64, y: f64, angle: f64) -> f64 {
        cast(raster, Pose2 { x, y, yaw: angle }, &model(0.0, 0.0, 1), &[])[0]
    }

    #[test]
    fn axis_aligned_beams_in_a_box() {
        let room = box_room(false);
        let (x, y) = (1.3, 1.1);
        assert!((single(&room, x, y, 0.0) - (4.0 - x)).abs() < 1e-9);
        assert!((single(&room, x, y, PI) - x).abs() < 1e-9);
        assert!((single(&room, x, y, FRAC_PI_2) - (3.0 - y)).abs() < 1e-9);
        assert!((single(&room, x, y, -FRAC_PI_2) - y).abs() < 1e-9);
        // Exactly along a grid line (y = 1.0 is a cell border): still the right wall.
        assert!((single(&room, 0.7, 1.0, 0.0) - 3.3).abs() < 1e-9);
    }

    #[test]
    fn diagonal_and_oblique_beams_in_a_box() {
        let room = box_room(false);
        // From (1, 1) at 45 deg: hits the top wall y = 3 at x = 3, distance 2 sqrt 2.
        assert!((single(&room, 1.0, 1.0, FRAC_PI_4) - 2.0 * 2f64.sqrt()).abs() < 1e-9);
        // Exactly through the inner corner (4, 3) from (1, 0.75) is a grid-corner beam.
        let a = (2.25f64).atan2(3.0);
        let d = single(&room, 1.0, 0.75, a);
        assert!((d - 3.75).abs() < 1e-9, "{d}");
        // An oblique beam: from (0.5, 2.5) at -20 deg hits y = 0 or x = 4, whichever comes first.
        let (x, y, a) = (0.5, 2.5, -20f64.to_radians());
        let expected = ((4.0 - x) / a.cos()).min(y / -a.sin());
        assert!((single(&room, x, y, a) - expected).abs() < 1e-9);
    }

    #[test]
    fn every_beam_of_a_scan_is_exact() {
        let room = box_room(false);
        let m = model(-PI, 2.0 * PI / 3600.0, 3600);
        let (x, y, yaw) = (1.37, 2.21, 0.4);
        let out = cast(&room, Pose2 { x, y, yaw }, &m, &[]);
        for (k, r) in out.iter().enumerate() {
            let a = yaw + m.angle_min + m.angle_increment * k as f64;
            let (s, c) = a.sin_cos();
            let tx = if c > 0.0 { (4.0 - x) / c } else { -x / c };
            let ty = if s > 0.0 { (3.0 - y) / s } else { -y / s };
            assert!((r - tx.min(ty)).abs() < 1e-9, "beam {k}: {r} vs {}", tx.min(ty));
        }
    }

    #[test]
    fn a_beam_through_a_doorway_reads_inf() {
        let room = box_room(true);
        assert_eq!(single(&room, 1.0, 1.5, 0.0), f64::INFINITY);
        // Outside the door the raster ends after a metre of free margin: nothing to hit.
        assert!((single(&room, 1.0, 0.5, 0.0) - 3.0).abs() < 1e-9);
    }

    #[test]
    fn range_limits() {
        let room = box_room(false);
        let mut m = model(0.0, 0.0, 1);
        m.range_max = 2.0;
        assert_eq!(cast(&room, Pose2 { x: 1.0, y: 1.0, yaw: 0.0 }, &m, &[])[0], f64::INFINITY);
        m.range_max = 3.0; // exactly the distance: still a return
        assert!((cast(&room, Pose2 { x: 1.0, y: 1.0, yaw: 0.0 }, &m, &[])[0] - 3.0).abs() < 1e-12);
        m.range_min = 0.5;
        assert_eq!(cast(&room, Pose2 { x: 3.7, y: 1.0, yaw: 0.0 }, &m, &[])[0], f64::NEG_INFINITY);
        // Inside a wall: 0, below any positive range_min.
        assert_eq!(cast(&room, Pose2 { x: -0.1, y: 1.0, yaw: 0.0 }, &m, &[])[0], f64::NEG_INFINITY);
        m.range_min = 0.0;
        assert_eq!(cast(&room, Pose2 { x: -0.1, y: 1.0, yaw: 0.0 }, &m, &[])[0], 0.0);
    }

    #[test]
    fn discs_occlude() {
        let room = box_room(false);
        let disc = Disc { x: 2.5, y: 1.0, radius: 0.3 };
        let m = model(0.0, 0.0, 1);
        let pose = Pose2 { x: 1.0, y: 1.0, yaw: 0.0 };
        assert!((cast(&room, pose, &m, &[disc])[0] - 1.2).abs() < 1e-12);
        // Tangent-ish beam above the disc misses it.
        let above = Pose2 { x: 1.0, y: 1.31, yaw: 0.0 };
        assert!((cast(&room, above, &m, &[disc])[0] - 3.0).abs() < 1e-9);
        // A disc behind the sensor is not seen; a sensor inside a disc reads 0.
        let behind = Disc { x: 0.5, y: 1.0, radius: 0.2 };
        assert!((cast(&room, pose, &m, &[behind])[0] - 3.0).abs() < 1e-9);
        let around = Disc { x: 1.0, y: 1.0, radius: 0.2 };
        let mut m0 = m;
        m0.range_min = 0.0;
        assert_eq!(cast(&room, pose, &m0, &[around])[0], 0.0);
        // The nearest of several; a disc beyond the wall changes nothing.
        let far = Disc { x: 5.0, y: 1.0, radius: 0.5 };
        let near = Disc { x: 2.0, y: 1.0, radius: 0.1 };
        assert!((cast(&room, pose, &m, &[far, disc, near])[0] - 0.9).abs() < 1e-12);
    }

    #[test]
    fn a_sensor_outside_the_raster_sees_the_outer_faces() {
        let room = box_room(false);
        // 2 m right of the outer face x = 4.25, looking back (-x): hits it 2 m away.
        let d = single(&room, 6.25, 1.5, PI);
        assert!((d - 2.0).abs() < 1e-9, "{d}");
        // Below the raster, looking up through the margin: the outer face y = -0.25.
        let d = single(&room, 2.0, -5.0, FRAC_PI_2);
        assert!((d - 4.75).abs() < 1e-9, "{d}");
        // Looking away, or past the raster, or with a short range: nothing.
        assert_eq!(single(&room, 6.25, 1.5, 0.0), f64::INFINITY);
        assert_eq!(single(&room, 6.25, 10.0, PI), f64::INFINITY);
        let m = LidarModel { range_max: 1.5, ..model(0.0, 0.0, 1) };
        assert_eq!(cast(&room, Pose2 { x: 6.25, y: 1.5, yaw: PI }, &m, &[])[0], f64::INFINITY);
        // Far away with a long range: terminates and hits.
        let m = LidarModel { range_max: 1e9, ..model(0.0, 0.0, 1) };
        let d = cast(&room, Pose2 { x: 1e8, y: 1.5, yaw: PI }, &m, &[])[0];
        assert!((d - (1e8 - 4.25)).abs() < 1e-5, "{d}");
    }

    #[test]
    fn a_beam_into_the_raster_edge_and_a_wall_at_the_edge() {
        // A single occupied column at the raster's right edge, sensor outside at the left.
        let (rows, cols) = (4, 10);
        let mut cells = vec![false; rows * cols];
        for r in 0..rows {
            cells[r * cols + cols - 1] = true;
        }
        let raster = OccupancyRaster::new(cells, rows, cols, 1.0, [0.0, 0.0]).unwrap();
        assert!((single(&raster, -3.0, 1.5, 0.0) - 12.0).abs() < 1e-12);
        assert!((single(&raster, 0.5, 1.5, 0.0) - 8.5).abs() < 1e-12);
        assert!((single(&raster, 20.0, 1.5, PI) - 10.0).abs() < 1e-12);
        assert_eq!(raster.occupied_cells(), 4);
        assert!(raster.is_occupied(0, 9) && !raster.is_occupied(0, 8) && !raster.is_occupied(-1, 9));
    }

    #[test]
    fn jumps_do_not_change_ranges() {
        // A large empty raster with scattered single occupied cells: compare against a walk
        // without jumps (clearance capped to 1).
        let (rows, cols) = (300, 400);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let cells: Vec<bool> = (0..rows * cols).map(|_| rng.random_bool(0.0005)).collect();
        let raster = OccupancyRaster::new(cells, rows, cols, 0.05, [-3.0, 2.0]).unwrap();
        let mut plain = raster.clone();
        for c in plain.clearance.iter_mut() {
            *c = (*c).min(1);
        }
        let m = LidarModel { range_max: 40.0, ..model(-PI, 2.0 * PI / 2000.0, 2000) };
        for _ in 0..20 {
            let pose = Pose2 {
                x: rng.random_range(-3.0..17.0),
                y: rng.random_range(2.0..17.0),
                yaw: rng.random_range(-PI..PI),
            };
            assert_eq!(cast(&raster, pose, &m, &[]), cast(&plain, pose, &m, &[]));
        }
    }

    #[test]
    fn validation_errors() {
        let bad = |r: Result<OccupancyRaster>| assert!(matches!(r, Err(IcpError::InvalidParameter { .. })));
        bad(OccupancyRaster::new(vec![], 0, 3, 0.05, [0.0, 0.0]));
        bad(OccupancyRaster::new(vec![false; 5], 2, 3, 0.05, [0.0, 0.0]));
        bad(OccupancyRaster::new(vec![false; 6], 2, 3, 0.0, [0.0, 0.0]));
        bad(OccupancyRaster::new(vec![false; 6], 2, 3, -0.05, [0.0, 0.0]));
        bad(OccupancyRaster::new(vec![false; 6], 2, 3, f64::NAN, [0.0, 0.0]));
        bad(OccupancyRaster::new(vec![false; 6], 2, 3, 0.05, [f64::INFINITY, 0.0]));
        bad(OccupancyRaster::new(vec![false; 6], 2, 3, 1e9, [0.0, 0.0]));
        bad(OccupancyRaster::new(vec![], usize::MAX, 2, 0.05, [0.0, 0.0]));

        let room = box_room(false);
        let ok = model(0.0, 0.01, 10);
        let pose = Pose2 { x: 1.0, y: 1.0, yaw: 0.0 };
        let mut out = Vec::new();
        let mut expect_err = |m: LidarModel, pose: Pose2, discs: &[Disc], name: &str| {
            let err = cast_ranges(&room, pose, &m, discs, &mut out).unwrap_err();
            assert!(err.to_string().contains(name), "{err}");
        };
        expect_err(LidarModel { beams: 0, ..ok }, pose, &[], "beams");
        expect_err(LidarModel { beams: MAX_BEAMS + 1, ..ok }, pose, &[], "beams");
        expect_err(LidarModel { angle_min: f64::NAN, ..ok }, pose, &[], "angle_min");
        expect_err(LidarModel { angle_increment: f64::INFINITY, ..ok }, pose, &[], "angle_increment");
        expect_err(LidarModel { range_min: -0.1, ..ok }, pose, &[], "range_min");
        expect_err(LidarModel { range_max: 0.05, ..ok }, pose, &[], "range_max");
        expect_err(LidarModel { range_max: f64::INFINITY, ..ok }, pose, &[], "range_max");
        expect_err(ok, Pose2 { yaw: f64::NAN, ..pose }, &[], "sensor pose");
        expect_err(ok, Pose2 { x: 2e9, ..pose }, &[], "sensor pose");
        expect_err(ok, pose, &[Disc { x: 1.0, y: 1.0, radius: 0.0 }], "disc");
        expect_err(ok, pose, &[Disc { x: f64::NAN, y: 1.0, radius: 1.0 }], "disc");

        let mut rng = noise_rng(Some(1));
        let mut r = [1.0, 2.0];
        assert!(add_noise(&mut r, &ok, -0.1, 0.0, &mut rng).is_err());
        assert!(add_noise(&mut r, &ok, f64::NAN, 0.0, &mut rng).is_err());
        assert!(add_noise(&mut r, &ok, 0.0, 1.5, &mut rng).is_err());
        assert!(add_noise(&mut r, &ok, 0.0, f64::NAN, &mut rng).is_err());
        assert_eq!(r, [1.0, 2.0]);
    }

    #[test]
    fn noise_statistics() {
        let n = 100_000;
        let m = LidarModel { range_min: 0.0, range_max: 100.0, ..model(0.0, 0.0, n) };
        let mut r = vec![10.0; n];
        r[0] = f64::INFINITY;
        r[1] = f64::NEG_INFINITY;
        let sigma = 0.03;
        add_noise(&mut r, &m, sigma, 0.0, &mut noise_rng(Some(5))).unwrap();
        assert_eq!((r[0], r[1]), (f64::INFINITY, f64::NEG_INFINITY));
        let e: Vec<f64> = r[2..].iter().map(|v| v - 10.0).collect();
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        let std = (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (e.len() - 1) as f64).sqrt();
        assert!(mean.abs() < 0.01 * sigma * 3.0, "mean {mean}");
        assert!((std / sigma - 1.0).abs() < 0.02, "std {std}");

        // Noise crossing the limits: beyond range_max -> +inf, below range_min -> -inf.
        let m = LidarModel { range_min: 9.99, range_max: 10.01, ..m };
        let mut r = vec![10.0; n];
        add_noise(&mut r, &m, sigma, 0.0, &mut noise_rng(Some(6))).unwrap();
        let above = r.iter().filter(|v| **v == f64::INFINITY).count() as f64 / n as f64;
        let below = r.iter().filter(|v| **v == f64::NEG_INFINITY).count() as f64 / n as f64;
        // P(|z| > 1/3) / 2 = 0.3694 each side.
        assert!((above - 0.3694).abs() < 0.01 && (below - 0.3694).abs() < 0.01, "{above} {below}");
        assert!(r.iter().all(|v| v.is_infinite() || (9.99..=10.01).contains(v)));
    }

    #[test]
    fn dropout_rate_and_determinism() {
        let n = 100_000;
        let m = model(0.0, 0.0, n);
        for p in [0.0, 0.1, 0.5, 1.0] {
            let mut r = vec![5.0; n];
            add_noise(&mut r, &m, 0.0, p, &mut noise_rng(Some(9))).unwrap();
            let rate = r.iter().filter(|v| **v == f64::INFINITY).count() as f64 / n as f64;
            assert!((rate - p).abs() < 0.005, "{p}: {rate}");
            assert!(r.iter().all(|v| *v == 5.0 || *v == f64::INFINITY));
        }
        let run = |seed| {
            let mut r = vec![5.0; 1000];
            add_noise(&mut r, &m, 0.02, 0.1, &mut noise_rng(Some(seed))).unwrap();
            r
        };
        assert_eq!(run(42), run(42));
        assert_ne!(run(42), run(43));
        // Unseeded generators differ (with overwhelming probability).
        let mut a = vec![5.0; 100];
        let mut b = a.clone();
        add_noise(&mut a, &m, 0.02, 0.0, &mut noise_rng(None)).unwrap();
        add_noise(&mut b, &m, 0.02, 0.0, &mut noise_rng(None)).unwrap();
        assert_ne!(a, b);
    }
}
