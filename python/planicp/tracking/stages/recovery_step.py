"""Stage 9 of `Localizer.update`: while lost, one step of the recovery (`recover`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..decisions import Correction, FitDecision, LostDecision, Prediction, RecoveryAction, RecoveryDecision
from ..lost_rule import LostDetector
from ..recovery import Recovery
from .correction import finite_or


def recover(
    recovery: Recovery,
    detector: LostDetector,
    points: NDArray[np.float64],
    prediction: Prediction,
    fit: FitDecision,
    correction: Correction,
    lost: LostDecision,
) -> RecoveryDecision:
    """While lost, one step of the recovery with this scan (when it could be aligned; otherwise
    its places follow the odometry), and the place it adopts, if any: then the lost state ends
    (`detector` is reset). While a place adopted before the whole plan was searched is on trial,
    that search goes on beside the tracked pose (`Recovery.verify`, from the `correction`), and a
    better place it finds is adopted. Otherwise the recovery forgets its places."""
    found = None
    action: RecoveryAction
    if (lost.lost or recovery.on_trial) and not fit.usable:
        recovery.coast(prediction.motion)
        action = "coast"
    elif lost.lost:
        found = recovery.step(points, prediction.motion, prediction.pose)
        action = "step"
    elif recovery.on_trial:
        found = recovery.verify(points, prediction.motion, correction.pose)
        action = "verify"
    else:
        recovery.clear()
        action = "clear"
    covariance = None
    if found is not None:
        covariance = finite_or(found.result.covariance, prediction.covariance)
        detector.reset()
    return RecoveryDecision(action, found, covariance, tuple(h.pose for h in recovery.hypotheses), recovery.on_trial)
