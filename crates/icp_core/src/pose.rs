//! SE(2) poses: a rotation by `yaw` followed by a translation `(x, y)`.
//!
//! `Pose2` of frame B in frame A (written `T_A_B`) maps a point given in B into A:
//! `p_A = R(yaw) p_B + (x, y)`. Metres and radians; yaw counter-clockwise positive (REP-103).

use nalgebra::Matrix3;
use std::f64::consts::PI;

/// A 2D rigid transform / pose: translation in metres, yaw in radians, wrapped to (-pi, pi].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose2 {
    /// Translation along x, metres.
    pub x: f64,
    /// Translation along y, metres.
    pub y: f64,
    /// Rotation, radians.
    pub yaw: f64,
}

/// Wraps an angle to (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI {
        w - 2.0 * PI
    } else {
        w
    }
}

impl Pose2 {
    /// A pose from its parts; yaw is wrapped.
    pub fn new(x: f64, y: f64, yaw: f64) -> Self {
        Self { x, y, yaw: wrap_angle(yaw) }
    }

    /// The identity transform.
    pub fn identity() -> Self {
        Self::new(0.0, 0.0, 0.0)
    }

    /// `(cos yaw, sin yaw)`.
    #[inline]
    pub fn cos_sin(&self) -> (f64, f64) {
        (self.yaw.cos(), self.yaw.sin())
    }

    /// Maps a point from the pose's child frame into its parent frame.
    #[inline]
    pub fn transform_point(&self, p: [f64; 2]) -> [f64; 2] {
        let (c, s) = self.cos_sin();
        [c * p[0] - s * p[1] + self.x, s * p[0] + c * p[1] + self.y]
    }

    /// Maps every point of `src` into `dst` (cleared first).
    pub fn transform_points(&self, src: &[[f64; 2]], dst: &mut Vec<[f64; 2]>) {
        let (c, s) = self.cos_sin();
        dst.clear();
        dst.extend(src.iter().map(|p| [c * p[0] - s * p[1] + self.x, s * p[0] + c * p[1] + self.y]));
    }

    /// `self * other`: first `other`, then `self` (T_A_C = T_A_B * T_B_C).
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let t = self.transform_point([other.x, other.y]);
        Pose2::new(t[0], t[1], self.yaw + other.yaw)
    }

    /// The inverse transform (T_B_A from T_A_B).
    pub fn inverse(&self) -> Pose2 {
        let (c, s) = self.cos_sin();
        Pose2::new(-(c * self.x + s * self.y), s * self.x - c * self.y, -self.yaw)
    }

    /// Euclidean length of the translation, metres.
    pub fn translation_norm(&self) -> f64 {
        self.x.hypot(self.y)
    }

    /// The 3x3 homogeneous matrix.
    pub fn to_matrix(&self) -> Matrix3<f64> {
        let (c, s) = self.cos_sin();
        Matrix3::new(c, -s, self.x, s, c, self.y, 0.0, 0.0, 1.0)
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.yaw.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Pose2, b: &Pose2) -> bool {
        (a.x - b.x).abs() < 1e-12 && (a.y - b.y).abs() < 1e-12 && wrap_angle(a.yaw - b.yaw).abs() < 1e-12
    }

    #[test]
    fn wrap_angle_stays_in_half_open_interval() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(0.5) - 0.5).abs() < 1e-15);
        assert!((wrap_angle(-7.0) - (-7.0 + 2.0 * PI)).abs() < 1e-12);
    }

    #[test]
    fn compose_with_inverse_is_identity() {
        let a = Pose2::new(1.5, -2.0, 0.7);
        assert!(close(&a.compose(&a.inverse()), &Pose2::identity()));
        assert!(close(&a.inverse().compose(&a), &Pose2::identity()));
    }

    #[test]
    fn compose_matches_matrix_product() {
        let a = Pose2::new(1.0, 2.0, 0.3);
        let b = Pose2::new(-0.5, 0.25, -1.1);
        let m = a.to_matrix() * b.to_matrix();
        let c = a.compose(&b);
        assert!((m - c.to_matrix()).abs().max() < 1e-12);
    }

    #[test]
    fn transform_point_rotates_then_translates() {
        let a = Pose2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2);
        let p = a.transform_point([1.0, 0.0]);
        assert!((p[0] - 1.0).abs() < 1e-12 && (p[1] - 1.0).abs() < 1e-12);
    }
}
