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
//!
//! This file holds the scan's model, the cast and the noise; the raster is in `occupancy_raster`,
//! and a beam's walk through it in `raster_walk`.

use crate::error::{invalid, Result, MAX_COORDINATE};
use crate::grids::ray_casting::raster_walk::{enter_and_walk, walk};
use crate::pose::Pose2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

mod occupancy_raster;
mod raster_walk;

pub use crate::grids::ray_casting::occupancy_raster::{OccupancyRaster, MAX_CELLS, MIN_RESOLUTION};
pub use crate::grids::ray_casting::raster_walk::CORNER_TIE;

/// Most beams one scan may have.
pub const MAX_BEAMS: usize = 1 << 20;
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
    let res = raster.resolution();
    let [ox, oy] = raster.origin();
    let (rows, cols) = raster.shape();
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
mod tests;
