"""Stage 1 of `Localizer.update`: the odometry predicts (`predict`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
from ...se2 import between, compose
from ..decisions import Prediction
from ..motion_noise import MotionNoise


def predict(
    pose: Pose, covariance: NDArray[np.float64], last_odom: Pose | None, odom: Pose, motion_noise: MotionNoise
) -> Prediction:
    """The last `pose` moved by the odometry motion from `last_odom` to `odom` (none at the first
    update), and its `covariance` propagated through that motion.

    Raises:
        ValueError: the propagated covariance is not finite.
    """
    motion = (0.0, 0.0, 0.0) if last_odom is None else between(last_odom, odom)
    predicted = compose(pose, motion)
    predicted_covariance = motion_noise.propagate_checked(covariance, pose, motion)
    return Prediction(odom, motion, predicted, predicted_covariance, last_odom is None)
