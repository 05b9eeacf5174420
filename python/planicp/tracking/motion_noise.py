"""How uncertain an odometry motion is: the prediction step of the localizer's covariance."""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass

from .._settings import SETTINGS, Real, Settings
from .._validation import Pose, as_pose


@dataclass(frozen=True, config=SETTINGS)
class MotionNoise(Settings):
    """Standard deviations of an odometry motion `(dx, dy, dyaw)` (base frame at its start).

    x and y each get `translation_fraction * hypot(dx, dy) + translation_floor` metres; the heading
    gets `rotation_fraction * |dyaw| + rotation_per_metre * hypot(dx, dy) + rotation_floor` radians.
    The defaults are generous for wheel odometry (5 % of the motion, 1 degree per metre), so that
    the localizer's covariance is not overconfident where ICP cannot help.

    Attributes:
        translation_fraction: dimensionless, >= 0.
        translation_floor: metres per update, >= 0.
        rotation_fraction: dimensionless, >= 0.
        rotation_per_metre: radians per metre driven, >= 0.
        rotation_floor: radians per update, >= 0.
    """

    translation_fraction: Annotated[float, Real(ge=0.0)] = 0.05
    translation_floor: Annotated[float, Real(ge=0.0)] = 0.001
    rotation_fraction: Annotated[float, Real(ge=0.0)] = 0.05
    rotation_per_metre: Annotated[float, Real(ge=0.0)] = math.radians(1.0)
    rotation_floor: Annotated[float, Real(ge=0.0)] = math.radians(0.05)

    def propagate(self, covariance: NDArray[np.float64], pose: Pose, motion: Pose) -> NDArray[np.float64]:
        """The covariance (3x3 over map-frame x, y, yaw) of `pose * motion` given that of `pose`:
        first-order propagation through the composition plus this motion's own noise.

        Raises:
            TypeError, ValueError: a malformed pose, motion or covariance, or a motion so large
                that the covariance overflows.
        """
        covariance = np.asarray(covariance, dtype=np.float64)
        if covariance.shape != (3, 3):
            raise ValueError(f"covariance must be 3x3, got shape {covariance.shape}")
        return self.propagate_checked(covariance, as_pose(pose, "pose"), as_pose(motion, "motion"))

    def propagate_checked(self, covariance: NDArray[np.float64], pose: Pose, motion: Pose) -> NDArray[np.float64]:
        """`propagate` for arguments already known well formed (the `Localizer`'s own state):
        a 3x3 float covariance and finite poses. Raises ValueError when the result is not finite."""
        dx, dy, dyaw = motion
        c, s = math.cos(pose[2]), math.sin(pose[2])
        # d(pose * motion) / d(pose) and / d(motion).
        f = np.array([[1.0, 0.0, -s * dx - c * dy], [0.0, 1.0, c * dx - s * dy], [0.0, 0.0, 1.0]])
        g = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        step = math.hypot(dx, dy)
        sigma_t = self.translation_fraction * step + self.translation_floor
        sigma_r = self.rotation_fraction * abs(dyaw) + self.rotation_per_metre * step + self.rotation_floor
        with np.errstate(over="ignore", invalid="ignore"):
            q = np.diag(np.square([sigma_t, sigma_t, sigma_r]))
            out: NDArray[np.float64] = f @ covariance @ f.T + g @ q @ g.T
        if not np.isfinite(out).all():
            raise ValueError(
                f"the covariance propagated over motion {(dx, dy, dyaw)} from {pose} is not finite "
                f"(motion or covariance too large, or not finite)"
            )
        return (out + out.T) / 2.0


def largest_position_std(covariance: NDArray[np.float64]) -> float:
    """Square root of the largest eigenvalue of the position block of a 3x3 covariance, metres
    (closed form for a symmetric 2x2): the standard deviation along the widest axis of the position
    uncertainty (0 when that eigenvalue is not positive)."""
    a, b, c = float(covariance[0, 0]), float(covariance[0, 1]), float(covariance[1, 1])
    largest = (a + c) / 2.0 + math.hypot((a - c) / 2.0, b)
    return math.sqrt(largest) if largest > 0.0 else 0.0
