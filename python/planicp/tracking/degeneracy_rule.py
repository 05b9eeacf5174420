"""Degenerate alignments: a direction no wall of the scan faces (a long featureless corridor).

Point-to-point ICP in a corridor slides along it on noise, furniture and people; its covariance
grows along the axis but its pose is still moved. `DegeneracyRule` detects the case from the fit's
wall-normal constraint (`IcpResult.translation_constraint`). The `Localizer` fuses every accepted
fit with the odometry prediction (`fusion_rule`), which keeps the prediction along a
direction the fit does not constrain; when odometry faulted and the two are not fused,
`fuse_along_weak_axis` still takes ICP's correction in full only across the weak axis: along it the
odometry prediction is kept, corrected by ICP only as much as their variances say.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass as pydantic_dataclass

from .._settings import SETTINGS, Real, Settings
from .._validation import Pose
from ..se2 import wrap_angle
from .fusion_rule import finite_covariance
from .icp_result import IcpResult


@dataclass(frozen=True)
class Degeneracy:
    """A fit that does not fix the position along `axis`.

    Attributes:
        axis: unit map-frame direction (x, y) the walls constrain least.
        weak: inliers' worth of wall normal along `axis`.
        strong: the same across it.
    """

    axis: tuple[float, float]
    weak: float
    strong: float


@pydantic_dataclass(frozen=True, config=SETTINGS)
class DegeneracyRule(Settings):
    """When a fit counts as degenerate.

    Attributes:
        min_constraint: a direction along which fewer than this many inliers' worth of wall normal
            point is unconstrained. In the default demo, fits with 5-20 along their weakest axis
            erred 17 mm along it (1.8 mm above 100); 20 marks those and spares the rest.
    """

    min_constraint: Annotated[float, Real(ge=0.0, note="(0 disables it)")] = 20.0

    def check(self, result: IcpResult) -> Degeneracy | None:
        """The degeneracy of `result`, or None when every direction is constrained."""
        axis, weak, strong = result.translation_constraint()
        return Degeneracy(axis, weak, strong) if weak < self.min_constraint else None


def fuse_along_weak_axis(
    degeneracy: Degeneracy, result: IcpResult, predicted: Pose, predicted_covariance: NDArray[np.float64]
) -> tuple[Pose, NDArray[np.float64]]:
    """ICP's pose and heading across the weak axis; along it, the odometry prediction corrected by
    ICP only in proportion to their variances (a one-dimensional Kalman update): with no wall
    normal along the axis ICP's variance there is unbounded and the prediction is kept exactly;
    with a few it moves the pose as far as it deserves. The covariance is ICP's across the axis
    and the fused variance along it."""
    u = np.array(degeneracy.axis)
    across = np.eye(2) - np.outer(u, u)
    icp_cov = finite_covariance(result)
    var_pred = float(u @ predicted_covariance[:2, :2] @ u)
    var_icp = float(u @ icp_cov[:2, :2] @ u)
    gain = var_pred / (var_pred + var_icp) if var_pred + var_icp > 0.0 else 0.0
    correction = np.array(result.pose[:2]) - np.array(predicted[:2])
    x, y = np.array(predicted[:2]) + across @ correction + gain * float(u @ correction) * u
    pose: Pose = (float(x), float(y), wrap_angle(result.pose[2]))
    t = across @ icp_cov[:2, :2] @ across + (1.0 - gain) * var_pred * np.outer(u, u)
    cross = across @ icp_cov[:2, 2]
    cov = np.array([[t[0, 0], t[0, 1], cross[0]], [t[1, 0], t[1, 1], cross[1]], [cross[0], cross[1], icp_cov[2, 2]]])
    return pose, (cov + cov.T) / 2.0
