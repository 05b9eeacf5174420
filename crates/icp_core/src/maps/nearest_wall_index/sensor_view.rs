//! The direction from which the sensor sees each scan point, in the sectors of the wall points'
//! visibility masks, without trigonometry per look-up.

use crate::maps::nearest_wall_index::cell_index;
use crate::visibility::wall_facing::SECTORS;

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
    pub(super) fn sector(&self, i: usize) -> u32 {
        (cell_index(self.bearings[i] + self.yaw) & (SECTORS - 1)) as u32
    }
}

/// `atan2(y, x)` to within 0.0015 rad (0.1 degree; a sector is 22.5), a quarter of libm's cost:
/// a degree-5 odd polynomial on the octant, mirrored.
#[inline]
pub(super) fn fast_atan2(y: f64, x: f64) -> f64 {
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

const SECTORS_PER_RADIAN: f64 = SECTORS as f64 / std::f64::consts::TAU;
