"""What one alignment found, and how good it is."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import Pose
from ..se2 import pose_to_matrix


@dataclass(frozen=True, repr=False)
class IcpResult:
    """Outcome of `localize`.

    Attributes:
        pose: (x, y, yaw) of the robot in the map (T_map_base): metres, metres, radians.
        converged: the last stage ended on the tolerances or at a fixed point (the pairs stopped
            changing), not by running out of iterations.
        iterations: ICP iterations run.
        num_inliers: scan points within `max_correspondence_distance` of a (visible) plan point
            at `pose`.
        inlier_ratio: `num_inliers` over all scan points.
        rmse: root mean square distance of the inliers to the plan, metres (NaN without inliers).
        covariance: 3x3 over (x, y, yaw) in the map frame (m^2, m rad, rad^2), from the
            point-to-wall residuals (the Newey-West sandwich over neighbouring beams, which
            counts the error a stretch of wall gives all its returns once) times
            `IcpConfig.covariance_scale`; `inf` on the diagonal when the scan does not fix the
            pose.
        constraint: 3x3 `H = sum J J^T` over the inliers with a wall normal, `J = (n_x, n_y,
            n . perp(p - t))`: how many inliers' worth of wall normal constrain each direction
            (x, y unitless, yaw terms in metres). `translation_constraint()` reads it.
        inlier_mask: (N,) bool over the input scan points.
        num_target_points: plan points the scan was matched against (the visible ones, or all).
    """

    pose: Pose
    converged: bool
    iterations: int
    num_inliers: int
    inlier_ratio: float
    rmse: float
    covariance: NDArray[np.float64]
    constraint: NDArray[np.float64]
    inlier_mask: NDArray[np.bool_]
    num_target_points: int

    @classmethod
    def from_alignment(cls, raw: _core.Alignment, covariance_scale: float) -> IcpResult:
        """The result of a native alignment, its covariance scaled by `covariance_scale`
        (`IcpConfig.covariance_scale`)."""
        mask = raw.inlier_mask
        mask.setflags(write=False)
        return cls(
            pose=raw.pose,
            converged=raw.converged,
            iterations=raw.iterations,
            num_inliers=raw.num_inliers,
            inlier_ratio=raw.inlier_ratio,
            rmse=raw.rmse,
            covariance=raw.covariance * covariance_scale,
            constraint=raw.constraint,
            inlier_mask=np.asarray(mask),
            num_target_points=raw.num_target_points,
        )

    @property
    def T_map_base(self) -> NDArray[np.float64]:  # noqa: N802 (frame-explicit name)
        """3x3 homogeneous transform bringing robot-frame points into the map frame."""
        return pose_to_matrix(self.pose)

    @property
    def std(self) -> tuple[float, float, float]:
        """Standard deviations of (x, y, yaw) from the covariance: metres, metres, radians."""
        d = np.diag(self.covariance)
        return (math.sqrt(d[0]), math.sqrt(d[1]), math.sqrt(d[2]))

    def translation_constraint(self) -> tuple[tuple[float, float], float, float]:
        """How the walls of this fit constrain the position, with the heading estimated too:
        `(weak_axis, weak, strong)`. `weak_axis` is the unit map-frame direction the inliers
        constrain least; `weak` and `strong` count how many inliers' worth of wall normal point
        along it and across it (the eigenvalues of the translation block of `constraint` after
        the heading is marginalised out). In a long featureless corridor `weak_axis` is the
        corridor's axis and `weak` is close to 0."""
        h = self.constraint
        a, b, c = float(h[0, 0]), (float(h[0, 1]) + float(h[1, 0])) / 2.0, float(h[1, 1])
        if h[2, 2] > 0.0:
            hz = float(h[2, 2])
            a -= float(h[0, 2]) * float(h[2, 0]) / hz
            b -= (float(h[0, 2]) * float(h[2, 1]) + float(h[1, 2]) * float(h[2, 0])) / (2.0 * hz)
            c -= float(h[1, 2]) * float(h[2, 1]) / hz
        # Eigen-decomposition of the symmetric 2x2 [[a, b], [b, c]] in closed form.
        mean, radius = (a + c) / 2.0, math.hypot((a - c) / 2.0, b)
        weak, strong = mean - radius, mean + radius
        # The eigenvector of `weak`: the longer of the two forms, for accuracy.
        u, v = (b, weak - a), (weak - c, b)
        x, y = u if u[0] * u[0] + u[1] * u[1] >= v[0] * v[0] + v[1] * v[1] else v
        norm = math.hypot(x, y)
        x, y = (x / norm, y / norm) if norm > 0.0 else ((1.0, 0.0) if a <= c else (0.0, 1.0))
        if x < 0.0 or (x == 0.0 and y < 0.0):
            x, y = -x, -y
        return (x, y), max(weak, 0.0), max(strong, 0.0)

    def __repr__(self) -> str:
        x, y, yaw = self.pose
        sx, sy, syaw = self.std
        return (
            f"IcpResult(pose=(x={x:.4f} m, y={y:.4f} m, yaw={math.degrees(yaw):.3f} deg), "
            f"converged={self.converged}, iterations={self.iterations}, "
            f"inliers={self.num_inliers}/{len(self.inlier_mask)} ({100 * self.inlier_ratio:.1f} %), "
            f"rmse={self.rmse * 100:.2f} cm, "
            f"std=(x {sx * 100:.2f} cm, y {sy * 100:.2f} cm, yaw {math.degrees(syaw):.3f} deg))"
        )
