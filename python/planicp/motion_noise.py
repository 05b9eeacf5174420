"""How uncertain an odometry motion is: the prediction step of the localizer's covariance."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ._validation import Pose, real_number


@dataclass(frozen=True)
class MotionNoise:
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

    translation_fraction: float = 0.05
    translation_floor: float = 0.001
    rotation_fraction: float = 0.05
    rotation_per_metre: float = math.radians(1.0)
    rotation_floor: float = math.radians(0.05)

    def __post_init__(self) -> None:
        for name in ("translation_fraction", "translation_floor", "rotation_fraction", "rotation_per_metre",
                     "rotation_floor"):
            value = real_number(getattr(self, name), name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")

    def propagate(self, covariance: NDArray[np.float64], pose: Pose, motion: Pose) -> NDArray[np.float64]:
        """The covariance (3x3 over map-frame x, y, yaw) of `pose * motion` given that of `pose`:
        first-order propagation through the composition plus this motion's own noise."""
        dx, dy, dyaw = motion
        c, s = math.cos(pose[2]), math.sin(pose[2])
        # d(pose * motion) / d(pose) and / d(motion).
        f = np.array([[1.0, 0.0, -s * dx - c * dy], [0.0, 1.0, c * dx - s * dy], [0.0, 0.0, 1.0]])
        g = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        step = math.hypot(dx, dy)
        sigma_t = self.translation_fraction * step + self.translation_floor
        sigma_r = self.rotation_fraction * abs(dyaw) + self.rotation_per_metre * step + self.rotation_floor
        q = np.diag([sigma_t**2, sigma_t**2, sigma_r**2])
        out: NDArray[np.float64] = f @ covariance @ f.T + g @ q @ g.T
        return (out + out.T) / 2.0
