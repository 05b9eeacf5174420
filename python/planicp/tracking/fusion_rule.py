"""Fusing an accepted fit with the odometry prediction: a Kalman update over (x, y, yaw).

ICP's pose is a measurement of the robot's pose against the plan; the odometry prediction (the last
estimate moved by the odometry motion) carries what the previous scans said. Taking ICP's pose alone
throws that away: when people hide half of the walls, or the walls seen leave a direction weak, one
scan's fit wanders by a centimetre or two that the prediction knew better. `fuse_with_prediction`
weighs the two by their covariances: where the fit is precise it decides, where it is weak (a
degenerate direction, a crowded scan) the prediction does. On the shipped plan with 25 people around
the robot this cut the position error RMS by 13-44 % on four drives, and by 7-12 % on the empty
floor (the scene of `benches/crowd.py`).

Odometry can fault (a wheel slips, a 10-degree step): then the fit and the prediction disagree far
beyond their covariances. An innovation over `FusionRule.max_innovation` (a chi-square over 3
degrees of freedom) takes the fit alone, except along a degenerate direction where nothing else
exists.
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass

from .._settings import SETTINGS, Real, Settings
from .._validation import Pose
from ..se2 import wrap_angle
from .icp_result import IcpResult

CHI2_3_999 = 16.266
"""The 99.9 % quantile of a chi-square with 3 degrees of freedom."""

UNCONSTRAINED_VARIANCE = 1e6
"""Variance (m^2) given to a direction no inlier constrains at all."""


@dataclass(frozen=True, config=SETTINGS)
class FusionRule(Settings):
    """When a fit is fused with the prediction.

    Attributes:
        max_innovation: largest squared Mahalanobis distance between the fit and the prediction
            (over their summed covariances, 3 degrees of freedom) for the two to be fused; above
            it the odometry is taken to have faulted and the fit is used alone. The default is the
            chi-square's 99.9 % quantile. 0 never fuses: the fit alone, as plain ICP trackers do
            (a degenerate direction still keeps the prediction, see `fuse_along_weak_axis`).
    """

    max_innovation: Annotated[float, Real(ge=0.0, finite=False, note="(0 never fuses)")] = CHI2_3_999

    def innovation(self, result: IcpResult, predicted: Pose, predicted_covariance: NDArray[np.float64]) -> float:
        """The squared Mahalanobis distance between `result.pose` and `predicted` (inf when
        their summed covariance is singular)."""
        inverse = _summed_inverse(result, predicted_covariance)
        if inverse is None:
            return math.inf
        innovation = _difference(result.pose, predicted)
        return float(innovation @ inverse @ innovation)

    def fuse(
        self, result: IcpResult, predicted: Pose, predicted_covariance: NDArray[np.float64]
    ) -> tuple[Pose, NDArray[np.float64]] | None:
        """`fuse_with_prediction`, or None when the innovation exceeds `max_innovation` (the
        odometry faulted) or the summed covariance is singular."""
        inverse = _summed_inverse(result, predicted_covariance)
        if inverse is None:
            return None
        innovation = _difference(result.pose, predicted)
        if not float(innovation @ inverse @ innovation) <= self.max_innovation:
            return None
        return _update(predicted, predicted_covariance, finite_covariance(result), innovation, inverse)


def fuse_with_prediction(
    result: IcpResult, predicted: Pose, predicted_covariance: NDArray[np.float64]
) -> tuple[Pose, NDArray[np.float64]]:
    """The Kalman update of the prediction (covariance `predicted_covariance`, 3x3 over map-frame
    x, y, yaw in m and rad) by the fit's pose (covariance `result.covariance`, with a direction the
    fit does not constrain at all given `UNCONSTRAINED_VARIANCE`). Returns the fused pose and its
    covariance.

    Raises:
        numpy.linalg.LinAlgError: the summed covariance is singular.
    """
    inverse = np.asarray(np.linalg.inv(predicted_covariance + finite_covariance(result)), dtype=np.float64)
    return _update(
        predicted, predicted_covariance, finite_covariance(result), _difference(result.pose, predicted), inverse
    )


def _summed_inverse(result: IcpResult, predicted_covariance: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """The inverse of the prediction's covariance plus the fit's, None when singular."""
    try:
        inverse = np.asarray(np.linalg.inv(predicted_covariance + finite_covariance(result)), dtype=np.float64)
    except np.linalg.LinAlgError:
        return None
    return inverse


def _update(
    predicted: Pose,
    predicted_covariance: NDArray[np.float64],
    fit_covariance: NDArray[np.float64],
    innovation: NDArray[np.float64],
    summed_inverse: NDArray[np.float64],
) -> tuple[Pose, NDArray[np.float64]]:
    """The Kalman update: gain K = P S^-1, pose = predicted + K innovation, covariance in Joseph
    form (I - K) P (I - K)^T + K R K^T, symmetric and positive semi-definite however far apart P
    and R are (the short form (I - K) P, with a start prior of 1e12 m^2 against a fit's 1e-5,
    cancelled to an x variance of exactly 0 and a negative eigenvalue)."""
    gain = predicted_covariance @ summed_inverse
    x = np.array(predicted) + gain @ innovation
    keep = np.eye(3) - gain
    covariance = keep @ predicted_covariance @ keep.T + gain @ fit_covariance @ gain.T
    pose: Pose = (float(x[0]), float(x[1]), wrap_angle(float(x[2])))
    return pose, (covariance + covariance.T) / 2.0


def finite_covariance(result: IcpResult) -> NDArray[np.float64]:
    """`result.covariance`, or, where the fit left a direction with no constraint at all (an
    infinite covariance), one rebuilt from its constraint with `UNCONSTRAINED_VARIANCE` there."""
    cov = np.asarray(result.covariance, dtype=np.float64)
    if np.isfinite(cov).all():
        return cov
    sigma2 = result.rmse**2 if math.isfinite(result.rmse) and result.rmse > 0.0 else 1e-4
    information = np.asarray(result.constraint, dtype=np.float64) / sigma2 + np.eye(3) / UNCONSTRAINED_VARIANCE
    inverse = np.asarray(np.linalg.inv(information), dtype=np.float64)
    symmetric: NDArray[np.float64] = (inverse + inverse.T) / 2.0
    return symmetric


def _difference(pose: Pose, reference: Pose) -> NDArray[np.float64]:
    """`pose - reference` over (x, y, yaw), the yaw wrapped to (-pi, pi]."""
    return np.array([pose[0] - reference[0], pose[1] - reference[1], wrap_angle(pose[2] - reference[2])])
