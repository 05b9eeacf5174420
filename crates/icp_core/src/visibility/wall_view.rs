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
use crate::visibility::visible_points::{check_cast, visible_cells, RangeOutput, RayFan};
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

impl WallView {
    /// Casts the view from `pose` (`T_map_base`) through `raster`, built from the wall `points`,
    /// within `max_range` metres. With `scan` (base-frame returns), only the directions the
    /// returns span, widened by [`ARC_MARGIN`] on either side, are cast: the visible points are
    /// those seen in that arc, and the other directions' ranges are NaN (a return there is neither
    /// in front nor beyond). A 270-degree scan casts 80 % of the circle. Without `with_ranges`
    /// only the visible points are cast (the base rays and their refinement): `ranges` is empty.
    ///
    /// Errors: a pose that is not finite, a range that is not positive and finite, a number of
    /// directions outside [[`MIN_DIRECTIONS`], [`MAX_DIRECTIONS`]].
    pub fn cast(
        raster: &WallRaster,
        points: &[[f64; 2]],
        pose: Pose2,
        max_range: f64,
        directions: usize,
        scan: Option<&[[f64; 2]]>,
        with_ranges: bool,
    ) -> Result<Self> {
        check_cast([pose.x, pose.y], max_range)?;
        if !pose.yaw.is_finite() {
            return Err(invalid("pose yaw", pose.yaw, "must be finite"));
        }
        if !(MIN_DIRECTIONS..=MAX_DIRECTIONS).contains(&directions) {
            return Err(invalid("directions", directions, "must be between 8 and 2^20"));
        }
        let ScanFan { fan, every, first_direction, arc } = ScanFan::new(pose, directions, scan);
        let (n, span) = (directions, fan.span);
        let mut cells = Vec::new();
        if !with_ranges {
            visible_cells(raster, [pose.x, pose.y], max_range, fan, &mut cells, None);
            return Ok(Self { pose, visible: raster.points_in_cells(&cells), ranges: Vec::new() });
        }
        let mut cast = Vec::with_capacity(2 * span + 1);
        let output = RangeOutput { ranges: &mut cast, points };
        visible_cells(raster, [pose.x, pose.y], max_range, fan, &mut cells, Some(output));
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::visibility::visible_points::{visible_points, BASE_RAYS};

    /// A 4 x 4 m room with 0.2 m walls, points every 5 cm on both faces, and a 1 m doorway in the
    /// east wall (x = 4) at y in [1.5, 2.5].
    fn room() -> (Vec<[f64; 2]>, WallRaster) {
        let mut pts = Vec::new();
        for i in 0..=80 {
            let t = i as f64 * 0.05;
            pts.extend([[t, 0.0], [t, 4.0], [0.0, t]]);
            if !(1.5..=2.5).contains(&t) {
                pts.push([4.0, t]);
            }
        }
        for i in 0..=88 {
            let t = -0.2 + i as f64 * 0.05;
            pts.extend([[t, -0.2], [t, 4.2], [-0.2, t]]);
            if !(1.3..=2.7).contains(&t) {
                pts.push([4.2, t]);
            }
        }
        let raster = WallRaster::new(&pts, 0.075).unwrap();
        (pts, raster)
    }

    #[test]
    fn ranges_are_the_distances_to_the_first_walls() {
        let (pts, raster) = room();
        // Facing +y from (1, 1.2): direction j looks along base angle -pi + j * 2 pi / 16.
        let view =
            WallView::cast(&raster, &pts, Pose2::new(1.0, 1.2, PI / 2.0), 10.0, 16, None, true).unwrap();
        assert_eq!(view.ranges.len(), 16);
        let cell = 0.075;
        // Base angle 0 (j = 8) is map +y: the north wall at y = 4, 2.8 m away.
        assert!((view.ranges[8] - 2.8).abs() <= cell, "{}", view.ranges[8]);
        // Base angle -pi/2 (j = 4) is map +x: the east wall at x = 4, 3 m away.
        assert!((view.ranges[4] - 3.0).abs() <= cell, "{}", view.ranges[4]);
        // Base angle pi/2 (j = 12) is map -x: the west wall at x = 0, 1 m away.
        assert!((view.ranges[12] - 1.0).abs() <= cell, "{}", view.ranges[12]);
        // Backwards (j = 0) is map -y: the south wall at y = 0.
        assert!((view.ranges[0] - 1.2).abs() <= cell, "{}", view.ranges[0]);
        assert!(!view.visible.is_empty());
    }

    /// Points that are not the raster's (none here) leave a ray's stop cell empty: the range is then
    /// the stop cell's centre, projected on the ray, still within a cell of the wall.
    #[test]
    fn without_the_rasters_points_a_range_is_the_stop_cells_centre() {
        let (pts, raster) = room();
        let pose = Pose2::new(1.0, 1.2, PI / 2.0);
        let exact = WallView::cast(&raster, &pts, pose, 10.0, 16, None, true).unwrap();
        let centres = WallView::cast(&raster, &[], pose, 10.0, 16, None, true).unwrap();
        let cell = 0.075;
        let mut differ = 0;
        for (j, (a, b)) in exact.ranges.iter().zip(&centres.ranges).enumerate() {
            if a.is_finite() {
                assert!((a - b).abs() <= cell, "direction {j}: {a} against the centre's {b}");
                differ += usize::from(a != b);
            } else {
                assert_eq!(a, b, "direction {j}");
            }
        }
        // With the points, the ranges are the walls' own (a wall point can lie at a centre's
        // projection, so not every direction differs).
        assert!(differ >= 10, "{differ} of 16 directions differ");
        assert!((centres.ranges[12] - 1.0).abs() <= cell, "{}", centres.ranges[12]);
    }

    #[test]
    fn the_visible_points_are_the_visibility_casts() {
        let (pts, raster) = room();
        // Facing pi, the first direction is map angle 0, as the visibility cast's first ray.
        let pose = Pose2 { x: 2.3, y: 1.7, yaw: PI };
        let view = WallView::cast(&raster, &pts, pose, 8.0, 2 * BASE_RAYS, None, true).unwrap();
        let seen = visible_points(&raster, [2.3, 1.7], 8.0).unwrap();
        assert_eq!(view.visible, seen);
    }

    #[test]
    fn a_doorway_reads_inf_within_range_and_returns_are_classified() {
        let (pts, raster) = room();
        // At (2, 2) facing +x: base angle 0 (direction 360 of 720) looks through the doorway.
        let view = WallView::cast(&raster, &pts, Pose2::new(2.0, 2.0, 0.0), 3.0, 720, None, true).unwrap();
        assert_eq!(view.ranges[360], f64::INFINITY);
        let ahead_left = view.ranges[540]; // base angle pi/2: the north wall, 2 m
        assert!((ahead_left - 2.0).abs() <= 0.075, "{ahead_left}");
        let margin = 0.2;
        let classes = view.classify(
            &[
                [0.0, 2.0],  // on the north wall
                [0.0, 1.0],  // a person 1 m short of it
                [0.0, 2.5],  // 0.5 m beyond it: through the wall
                [1.0, 0.0],  // through the doorway, where the plan shows nothing in range
                [-2.0, 0.0], // on the west wall
            ],
            margin,
        );
        assert_eq!(classes.in_front, vec![false, true, false, true, false]);
        assert_eq!(classes.beyond, vec![false, false, true, false, false]);
    }

    #[test]
    fn halfway_ranges_match_casting_every_direction() {
        let (pts, raster) = room();
        for (x, y, yaw) in [(1.0, 1.2, 0.3), (2.0, 2.0, 0.0), (3.7, 0.4, -2.0), (6.0, 2.0, 1.0)] {
            let pose = Pose2::new(x, y, yaw);
            // 1441 directions: every one a base ray. 1440: every other one, the rest halfway.
            let exact = WallView::cast(&raster, &pts, pose, 12.0, 1441, None, true).unwrap();
            let halved = WallView::cast(&raster, &pts, pose, 12.0, 1440, None, true).unwrap();
            assert_eq!((exact.ranges.len(), halved.ranges.len()), (1441, 1440));
            let reference = WallView::cast(&raster, &pts, pose, 12.0, 2881, None, true).unwrap();
            // Direction j of 1440 is direction 2j of 2880; the 2881-direction cast is within
            // 1/2881 of a turn of it, compare with the nearer of its neighbours.
            for (j, r) in halved.ranges.iter().enumerate() {
                let near = [reference.ranges[(2 * j) % 2881], reference.ranges[(2 * j + 1) % 2881]];
                let off =
                    near.iter().map(|e| if e.is_infinite() && r.is_infinite() { 0.0 } else { (e - r).abs() });
                assert!(off.fold(f64::INFINITY, f64::min) <= 0.11, "{pose:?} direction {j}: {r} vs {near:?}");
            }
        }
    }

    #[test]
    fn bearings_agree_with_atan2() {
        let mut worst = 0.0f64;
        for i in 0..200_000 {
            let angle = -PI + TAU * i as f64 / 200_000.0;
            for r in [1e-3, 1.0, 37.0] {
                let (y, x) = (r * angle.sin(), r * angle.cos());
                worst = worst.max((bearing(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 1e-7, "{worst}");
        for (y, x) in [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (2.0, 2.0), (-3.0, -3.0)] {
            assert!((bearing(y, x) - f64::atan2(y, x)).abs() < 1e-7, "({y}, {x})");
        }
        assert_eq!(bearing(0.0, 0.0), 0.0);
        assert!(bearing(f64::NAN, 1.0).is_nan());
    }

    #[test]
    fn the_arc_is_the_scan_span_widened_by_the_margin() {
        let n = 1440;
        let at = |deg: f64| [deg.to_radians().cos(), deg.to_radians().sin()];
        // A 270-degree scan: directions 180 (-135 deg) to 1260 (+135 deg).
        let scan: Vec<[f64; 2]> = (0..1081).map(|i| at(-135.0 + 0.25 * i as f64)).collect();
        assert_eq!(spanned_arc(&scan, n, 40), Some((140, 1081 + 80)));
        // Across +-pi: returns between 170 and 190 degrees (directions 1400 to 1440 = 0 to 40).
        let back: Vec<[f64; 2]> = (0..=80).map(|i| at(170.0 + 0.25 * i as f64)).collect();
        assert_eq!(spanned_arc(&back, n, 10), Some((1390, 81 + 20)));
        // Nearly all round, an empty scan: the full circle.
        let round: Vec<[f64; 2]> = (0..1400).map(|i| at(-180.0 + 0.25 * i as f64)).collect();
        assert_eq!(spanned_arc(&round, n, 40), None);
        assert_eq!(spanned_arc(&[], n, 40), None);
        assert_eq!(spanned_arc(&[[1.0, 0.0]], n, 3), Some((717, 7)));
    }

    #[test]
    fn a_view_over_the_scan_arc_classifies_as_the_full_circle() {
        let (pts, raster) = room();
        let pose = Pose2::new(1.3, 2.2, 0.7);
        let full = WallView::cast(&raster, &pts, pose, 10.0, 1440, None, true).unwrap();
        // A 180-degree scan ahead: returns at 0.5-5 m.
        let scan: Vec<[f64; 2]> = (0..721)
            .map(|i| {
                let a = (-90.0 + 0.25 * i as f64).to_radians();
                let r = 0.5 + 4.5 * ((i * 37) % 100) as f64 / 100.0;
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        let arc = WallView::cast(&raster, &pts, pose, 10.0, 1440, Some(&scan), true).unwrap();
        assert_eq!(arc.ranges.len(), 1440);
        let cast = arc.ranges.iter().filter(|r| !r.is_nan()).count();
        assert!(cast < 1440 * 6 / 10, "{cast} directions cast for a half circle");
        for (a, f) in arc.ranges.iter().zip(&full.ranges) {
            assert!(a.is_nan() || a == f || (a - f).abs() < 1e-9, "{a} vs {f}");
        }
        assert_eq!(arc.classify(&scan, 0.2), full.classify(&scan, 0.2));
        // The points seen over the arc are points seen over the full circle, most of them.
        let in_full = arc.visible.iter().filter(|i| full.visible.binary_search(i).is_ok()).count();
        assert!(in_full as f64 >= 0.98 * arc.visible.len() as f64 && arc.visible.len() < full.visible.len());
    }

    #[test]
    fn the_exact_classification_refuses_bad_directions() {
        let raster = OccupancyRaster::new(vec![false; 100], 10, 10, 0.1, [0.0, 0.0]).unwrap();
        let pose = Pose2::new(0.5, 0.5, 0.0);
        assert!(classify_exact(&raster, pose, &[[1.0, 0.0]], 0.2, 7).is_err());
        assert!(classify_exact(&raster, pose, &[[1.0, 0.0]], 0.2, MAX_DIRECTIONS + 1).is_err());
        // Nothing but free cells: every return is in front of "no wall" (inf), none beyond.
        let classes = classify_exact(&raster, pose, &[[1.0, 0.0], [0.0, -0.3]], 0.2, 720).unwrap();
        assert_eq!(classes, ReturnClasses { in_front: vec![true, true], beyond: vec![false, false] });
    }

    #[test]
    fn bad_casts_are_refused() {
        let (pts, raster) = room();
        let ok = Pose2::new(1.0, 1.0, 0.0);
        assert!(WallView::cast(&raster, &pts, ok, 0.0, 16, None, true).is_err());
        assert!(WallView::cast(&raster, &pts, ok, f64::NAN, 16, None, true).is_err());
        assert!(WallView::cast(&raster, &pts, ok, 5.0, 7, None, true).is_err());
        assert!(WallView::cast(&raster, &pts, ok, 5.0, MAX_DIRECTIONS + 1, None, true).is_err());
        assert!(WallView::cast(&raster, &pts, Pose2 { x: f64::NAN, y: 1.0, yaw: 0.0 }, 5.0, 16, None, true)
            .is_err());
        assert!(WallView::cast(
            &raster,
            &pts,
            Pose2 { x: 1.0, y: 1.0, yaw: f64::INFINITY },
            5.0,
            16,
            None,
            true
        )
        .is_err());
    }
}
