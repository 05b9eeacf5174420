//! What a range sensor at one pose sees of the plan, and which returns disagree with it.
//!
//! A tracking step asks two questions of the walls seen from the predicted pose: which plan points
//! the alignment may pair with (the visible wall faces, [`crate::visibility::visible_points`]), and how far
//! each direction's first wall is, so that returns far short of it (people, furniture) or far beyond it
//! (a wrong prediction) can be told apart.
//!
//! A [`WallView`] answers both with one visibility cast: its base rays are every other direction,
//! the rays it adds where neighbouring rays stop in cells that are not adjacent give most
//! directions between them, and the wall point nearest a ray in its stop cell gives that
//! direction's range. It may be cast over the arc a scan spans only. The localizer uses a view
//! for the visible points alone: the occlusion rule casts exactly through the plan image
//! ([`classify_exact`]), since the visibility raster's cells lengthen walls at their ends, which
//! cost robustness in crowds.

use crate::error::{invalid, Result};
use crate::grids::ray_casting::{cast_ranges, LidarModel, OccupancyRaster};
use crate::grids::wall_raster::WallRaster;
use crate::pose::Pose2;
use crate::visibility::visible_points::{check_cast, visible_cells, DirectionalReach, RangeOutput, RayFan};
use std::f64::consts::{PI, TAU};

/// How far (radians) a view cast for a scan reaches beyond the directions the scan's returns span:
/// an alignment moves the returns a little, and a return pairs with wall points up to its stage
/// distance to the side (0.25 m subtends 10 degrees at 1.4 m).
pub const ARC_MARGIN: f64 = 10.0 * PI / 180.0;

/// Fewest directions a view may have.
pub const MIN_DIRECTIONS: usize = 8;
/// Most directions a view may have.
pub const MAX_DIRECTIONS: usize = 1 << 20;

/// The plan as seen from one pose: its visible wall points and the range to the first wall in
/// `directions` evenly spaced directions, direction `j` at base-frame angle `-pi + j * TAU /
/// directions` (the first one points backwards).
#[derive(Clone, Debug, PartialEq)]
pub struct WallView {
    /// `T_map_base` the view was cast from.
    pub pose: Pose2,
    /// Plan point indices (ascending, unique) in the wall cells the rays reach first.
    pub visible: Vec<u32>,
    /// Per direction (empty for a view cast without ranges): metres from the pose's position to
    /// the wall where the direction's ray stops:
    /// the along-ray distance of the wall point nearest the ray in the first wall cell; `inf` when
    /// none lies within the cast's range.
    pub ranges: Vec<f64>,
}

/// Which returns of a scan disagree with the walls of a [`WallView`] (see [`WallView::classify`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReturnClasses {
    /// Per return: more than the margin short of the wall in its direction.
    pub in_front: Vec<bool>,
    /// Per return: more than the margin beyond the wall in its direction.
    pub beyond: Vec<bool>,
}

/// The scan a [`WallView`] is cast for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewScan<'a> {
    /// The scan's returns, base frame, metres: the cast covers the arc they span.
    pub returns: &'a [[f64; 2]],
    /// How far from a return a wall point can be paired with it (metres; see
    /// [`crate::icp::largest_pair_distance`]): when given, each direction is cast only as far as
    /// a return could pair with a wall there. `None`: every direction to the cast's range.
    pub pair_distance: Option<f64>,
}

impl WallView {
    /// Casts the view from `pose` (`T_map_base`) through `raster`, built from the wall `points`,
    /// within `max_range` metres. With `scan`, only the directions its returns span, widened by
    /// [`ARC_MARGIN`] on either side, are cast: the visible points are those seen in that arc, and
    /// the other directions' ranges are NaN (a return there is neither in front nor beyond). A
    /// 270-degree scan casts 80 % of the circle. With the scan's `pair_distance` too (only for a
    /// cast without ranges), each direction is cast only as far as a return could pair with a
    /// wall point there (see `directional_reach`): a wall no return can reach is no alignment's
    /// partner, and on a plan seen out to 80 m, past trees and posts, most of the rays' length
    /// and refinement is spared. Without `with_ranges` only the visible points are cast (the base
    /// rays and their refinement): `ranges` is empty.
    ///
    /// Errors: a pose that is not finite, a range that is not positive and finite, a number of
    /// directions outside [[`MIN_DIRECTIONS`], [`MAX_DIRECTIONS`]], a pair distance that is not
    /// positive and finite, or one given for a cast with ranges (its ranges would stop short of
    /// the walls).
    pub fn cast(
        raster: &WallRaster,
        points: &[[f64; 2]],
        pose: Pose2,
        max_range: f64,
        directions: usize,
        scan: Option<ViewScan<'_>>,
        with_ranges: bool,
    ) -> Result<Self> {
        check_cast([pose.x, pose.y], max_range)?;
        if !pose.yaw.is_finite() {
            return Err(invalid("pose yaw", pose.yaw, "must be finite"));
        }
        if !(MIN_DIRECTIONS..=MAX_DIRECTIONS).contains(&directions) {
            return Err(invalid("directions", directions, "must be between 8 and 2^20"));
        }
        let pair_distance = scan.and_then(|s| s.pair_distance);
        if let Some(d) = pair_distance {
            if !(d.is_finite() && d > 0.0) {
                return Err(invalid("pair_distance", d, "must be a positive finite number of metres"));
            }
            if with_ranges {
                return Err(invalid(
                    "pair_distance",
                    d,
                    "limits a cast without ranges only: cast the ranges without it",
                ));
            }
        }
        let returns = scan.map(|s| s.returns);
        let ScanFan { fan, every, first_direction, arc } = ScanFan::new(pose, directions, returns);
        let (n, span) = (directions, fan.span);
        let mut cells = Vec::new();
        if !with_ranges {
            let reach = returns.zip(pair_distance).map(|(r, d)| directional_reach(r, pose, max_range, d));
            visible_cells(raster, [pose.x, pose.y], max_range, fan, &mut cells, None, reach.as_ref());
            return Ok(Self { pose, visible: raster.points_in_cells(&cells), ranges: Vec::new() });
        }
        let mut cast = Vec::with_capacity(2 * span + 1);
        let output = RangeOutput { ranges: &mut cast, points };
        visible_cells(raster, [pose.x, pose.y], max_range, fan, &mut cells, Some(output), None);
        let ranges = if !arc {
            cast.into_iter().step_by(every).collect()
        } else {
            let mut ranges = vec![f64::NAN; n];
            for (j, r) in cast.into_iter().step_by(every).enumerate() {
                ranges[(first_direction + j) % n] = r;
            }
            ranges
        };
        Ok(Self { pose, visible: raster.points_in_cells(&cells), ranges })
    }

    /// Which of `points` (base frame, metres) lie more than `margin` metres short of the wall in
    /// their direction (something the plan does not show stands in front of it), and which lie more
    /// than `margin` beyond it (a beam from this pose could not have returned them). Directions are
    /// measured from the base origin: a return on a wall lies on it whatever the ray's origin, so
    /// the laser's mount does not matter. At a wall's edge a return may belong to either
    /// neighbouring direction, so it is in front only of the farthest of the three nearest
    /// directions' walls, and beyond only the nearest. A direction with no wall in range reads
    /// `inf`: every return near it is in front, none beyond.
    pub fn classify(&self, points: &[[f64; 2]], margin: f64) -> ReturnClasses {
        classify_returns(&self.ranges, points, margin)
    }
}

/// `y.atan2(x)` to within 1e-7 rad (a return's direction only picks the nearest of directions
/// thousandths of a radian apart), three times faster than the library's: Abramowitz and Stegun's
/// 4.4.49 polynomial on the octant, mirrored. 0 for (0, 0); NaN for a NaN coordinate.
#[inline]
fn bearing(y: f64, x: f64) -> f64 {
    const A: [f64; 8] = [
        0.999_999_332_9,
        -0.333_298_560_5,
        0.199_465_359_9,
        -0.139_085_335_1,
        0.096_420_044_1,
        -0.055_909_886_1,
        0.021_861_228_8,
        -0.004_054_058_0,
    ];
    let (ax, ay) = (x.abs(), y.abs());
    let (small, large) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if large == 0.0 {
        return 0.0;
    }
    let z = small / large;
    let z2 = z * z;
    let mut a = A[7];
    for c in A[..7].iter().rev() {
        a = a * z2 + c;
    }
    let mut angle = a * z;
    if ay > ax {
        angle = std::f64::consts::FRAC_PI_2 - angle;
    }
    if x < 0.0 {
        angle = PI - angle;
    }
    if y < 0.0 {
        -angle
    } else {
        angle
    }
}

/// The base rays of a cast in `directions` directions from a pose, over the arc a scan spans.
struct ScanFan {
    fan: RayFan,
    /// 1: the cast's ranges are every direction (base rays and halfway); 2: every other one.
    every: usize,
    /// The direction of the fan's first base ray.
    first_direction: usize,
    /// Whether the fan covers an arc, not the full circle.
    arc: bool,
}

impl ScanFan {
    /// Direction `j` (of `directions`) at base angle `-pi + j * TAU / directions` from `pose`; with
    /// `scan`, over the arc its returns span widened by [`ARC_MARGIN`] on either side. An even
    /// number of directions: the even ones are base rays and the cast gives the range halfway
    /// between neighbours too (see `visible_cells`). An odd number: every direction is a base ray
    /// and the halfway ranges are dropped.
    fn new(pose: Pose2, directions: usize, scan: Option<&[[f64; 2]]>) -> Self {
        let n = directions;
        let margin = (ARC_MARGIN / (TAU / n as f64)).ceil() as usize;
        let arc = scan.and_then(|s| spanned_arc(s, n, margin));
        let (rays, every) = if n % 2 == 0 { (n / 2, 1) } else { (n, 2) };
        // The arc in base rays: from the one at or before its first direction to the one at or
        // after its last.
        let (first_ray, span) = match arc {
            None => (0, rays),
            Some((first, count)) if every == 1 => (first / 2, (first + count - 1).div_ceil(2) - first / 2),
            Some((first, count)) => (first, count - 1),
        };
        let step = TAU / rays as f64;
        let fan = RayFan { first_angle: pose.yaw - PI + first_ray as f64 * step, rays, span };
        let first_direction = if every == 1 { 2 * first_ray } else { first_ray };
        Self { fan, every, first_direction, arc: arc.is_some() }
    }
}

/// Which of `points` (base frame, metres) lie more than `margin` metres short of, or beyond, the
/// wall in their direction, given the range to the first wall in each of `ranges.len()` directions
/// (direction `j` at base angle `-pi + j * TAU / n`; NaN: not cast, ignored). See
/// [`WallView::classify`].
pub fn classify_returns(ranges: &[f64], points: &[[f64; 2]], margin: f64) -> ReturnClasses {
    let n = ranges.len();
    let mut classes = ReturnClasses {
        in_front: Vec::with_capacity(points.len()),
        beyond: Vec::with_capacity(points.len()),
    };
    if n == 0 {
        classes.in_front.resize(points.len(), false);
        classes.beyond.resize(points.len(), false);
        return classes;
    }
    for p in points {
        let range = (p[0] * p[0] + p[1] * p[1]).sqrt();
        let k = direction_of(*p, n);
        let around = [ranges[(k + n - 1) % n], ranges[k], ranges[(k + 1) % n]];
        // `max` and `min` skip NaN: a direction not cast says nothing.
        let farthest = around.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let nearest = around.iter().copied().fold(f64::INFINITY, f64::min);
        classes.in_front.push(range < farthest - margin);
        classes.beyond.push(range > nearest + margin);
    }
    classes
}

/// The occlusion rule's classes of `points` (base frame, metres) against exact ranges: beams cast
/// from `pose` (`T_map_base`) through the plan image `raster` ([`crate::grids::ray_casting`]) in
/// `directions` directions, over the arc the returns span and one direction either side. The
/// image's wall faces are exact to a pixel; a [`WallView`]'s ranges come from the coarser
/// visibility raster, whose cells lengthen walls at their ends.
///
/// Errors: a pose that is not finite or beyond the coordinate limit, a number of directions
/// outside [[`MIN_DIRECTIONS`], [`MAX_DIRECTIONS`]].
pub fn classify_exact(
    raster: &OccupancyRaster,
    pose: Pose2,
    points: &[[f64; 2]],
    margin: f64,
    directions: usize,
) -> Result<ReturnClasses> {
    if !(MIN_DIRECTIONS..=MAX_DIRECTIONS).contains(&directions) {
        return Err(invalid("directions", directions, "must be between 8 and 2^20"));
    }
    let n = directions;
    let step = TAU / n as f64;
    let (first, count) = spanned_arc(points, n, 1).unwrap_or((0, n));
    let model = LidarModel {
        angle_min: -PI + first as f64 * step,
        angle_increment: step,
        beams: count,
        range_min: 0.0,
        range_max: 1e6,
    };
    let mut cast = Vec::with_capacity(count);
    cast_ranges(raster, pose, &model, &[], &mut cast)?;
    let mut ranges = vec![f64::NAN; n];
    for (j, r) in cast.into_iter().enumerate() {
        ranges[(first + j) % n] = r;
    }
    Ok(classify_returns(&ranges, points, margin))
}

/// The direction (of `n`, direction `j` at base angle `-pi + j * TAU / n`) nearest the bearing of
/// the base-frame point `p`.
#[inline]
fn direction_of(p: [f64; 2], n: usize) -> usize {
    // The bearing lies in [-pi, pi]: k in [0, n], where n is direction 0 again. Rounded by
    // truncating k + 0.5, which is not negative (`round` is a library call on baseline x86-64);
    // a NaN bearing converts to 0.
    let k = (bearing(p[1], p[0]) + PI) / (TAU / n as f64) + 0.5;
    (k as usize) % n
}

/// (first direction, count): the shortest run of directions (of `n`, wrapping) holding every
/// direction of `scan`'s returns, widened by `margin` on either side; None when that is the whole
/// circle or the scan is empty.
fn spanned_arc(scan: &[[f64; 2]], n: usize, margin: usize) -> Option<(usize, usize)> {
    let mut used = vec![false; n];
    for p in scan {
        used[direction_of(*p, n)] = true;
    }
    let first_used = used.iter().position(|&u| u)?;
    // The widest run of unused directions, going round from the first used one.
    let (mut widest, mut widest_end, mut run) = (0usize, first_used, 0usize);
    for j in 1..=n {
        let d = (first_used + j) % n;
        if used[d] {
            if run > widest {
                (widest, widest_end) = (run, d);
            }
            run = 0;
        } else {
            run += 1;
        }
    }
    let count = (n - widest) + 2 * margin;
    if count >= n {
        return None;
    }
    // The arc starts at the used direction after the widest gap, less the margin.
    Some(((widest_end + n - margin % n) % n, count))
}

/// Bins of a cast's reach over the full circle (a quarter of a degree each).
const REACH_BINS: usize = 1440;

/// How far a cast for `scan` (base frame, metres) from `pose` reaches in each direction: the
/// farthest range plus `pair_distance` of the returns that could pair with a wall point in that
/// direction, within `max_range`. A return at range `rho` pairs with wall points up to
/// `pair_distance` from it, which lie within `asin(pair_distance / rho)` of its bearing (any
/// bearing when `rho <= pair_distance`), and the alignment may still turn it by [`ARC_MARGIN`]
/// (the margin the arc of the cast takes for the same reason). A direction no return can pair in
/// reaches nowhere.
fn directional_reach(scan: &[[f64; 2]], pose: Pose2, max_range: f64, pair_distance: f64) -> DirectionalReach {
    let n = REACH_BINS;
    let bin = TAU / n as f64;
    // Each return's window of bins (bin j holds base bearings [-pi + j bin, -pi + (j + 1) bin)),
    // farthest first: each bin then takes the first window that covers it, its largest reach,
    // and is never visited again (the next bin not yet set is found through `next`).
    let mut windows: Vec<(f64, i64, i64)> = Vec::with_capacity(scan.len());
    for p in scan {
        let rho = p[0].hypot(p[1]);
        if !rho.is_finite() {
            continue;
        }
        let far = (rho + pair_distance).min(max_range);
        let half = if rho <= pair_distance { PI } else { (pair_distance / rho).asin() } + ARC_MARGIN;
        let centre = (bearing(p[1], p[0]) + PI) / bin;
        let (lo, hi) = if half >= PI {
            (0, n as i64 - 1)
        } else {
            ((centre - half / bin).floor() as i64, (centre + half / bin).floor() as i64)
        };
        windows.push((far, lo, hi.min(lo + n as i64 - 1)));
    }
    windows.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    let mut reach = vec![0.0f64; n];
    // next[k]: the first bin at or after k not yet set (n: none).
    let mut next: Vec<usize> = (0..=n).collect();
    fn find(next: &mut [usize], mut k: usize) -> usize {
        while next[k] != k {
            next[k] = next[next[k]];
            k = next[k];
        }
        k
    }
    let mut unset = n;
    for (far, lo, hi) in windows {
        if unset == 0 {
            break;
        }
        let (a, b) = (lo.rem_euclid(n as i64) as usize, hi.rem_euclid(n as i64) as usize);
        let spans = if hi - lo + 1 >= n as i64 {
            [(0, n - 1), (1, 0)]
        } else if a <= b {
            [(a, b), (1, 0)]
        } else {
            [(a, n - 1), (0, b)]
        };
        for (first, last) in spans {
            let mut k = find(&mut next, first);
            while k <= last {
                reach[k] = far;
                unset -= 1;
                next[k] = k + 1;
                k = find(&mut next, k + 1);
            }
        }
    }
    DirectionalReach { first_angle: pose.yaw - PI, reach }
}

#[cfg(test)]
mod tests;
