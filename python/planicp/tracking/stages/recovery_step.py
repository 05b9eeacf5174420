"""Stage 9 of `Localizer.update`: while lost, one step of the recovery (`recover`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
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
    lost_at: Pose | None = None,
) -> RecoveryDecision:
    """While lost, one step of the recovery with this scan (when it could be aligned; otherwise
    its places follow the odometry), and the place it adopts, if any: then the lost state ends
    (`detector` is reset). While a place adopted before the whole plan was searched is on trial,
    that search goes on beside the tracked pose (`Recovery.verify`, from the `correction`), and a
    better place it finds is adopted; so it does, begun with this scan, while the track is kept
    only because the lost rule's bar is relaxed (`LostDecision.doubted`, `Recovery.doubt`). A
    track its own fit regained (`LostDecision.regained`) is a place near where it was lost, and
    is judged as one the recovery finds there (`Recovery.regain`): on trial while the search of
    the whole plan goes on. Otherwise the recovery forgets its places.

    `lost_at`: where the localizer lost track when that is not the prediction (the place an
    adopted jump left behind, which the scans preferred to the track: `RecoveryDecision.lost_at`);
    the search near the last pose is then centred there, and otherwise on the last pose a scan
    vouched for (`Recovery.step`)."""
    found = None
    action: RecoveryAction
    if (lost.lost or recovery.on_trial) and not fit.usable:
        recovery.coast(prediction.motion)
        action = "coast"
    elif lost.lost:
        found = recovery.step(points, prediction.motion, prediction.pose, likelier=lost_at)
        action = "step"
    else:
        if lost.regained:
            recovery.regain()
        if recovery.on_trial or lost.doubted:
            begin = not recovery.on_trial
            if begin:
                recovery.doubt()
            found = recovery.verify(points, prediction.motion, correction.pose, begin=begin)
            action = "verify"
        else:
            recovery.clear()
            action = "clear"
    covariance = None
    if found is not None:
        covariance = finite_or(found.result.covariance, prediction.covariance)
        detector.reset()
    hypotheses = tuple(h.pose for h in recovery.hypotheses)
    at = lost_at if action == "step" and found is None else None
    return RecoveryDecision(action, found, covariance, hypotheses, recovery.on_trial, at)
