"""Stage 3 of `Localizer.update`: a place a rejected jump left pending, confirmed or not by this
scan (`confirm_pending`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
from ...se2 import between, compose
from ..decisions import FitDecision, PendingDecision, Prediction
from ..odometry_fault import fault_cost, scan_cost
from .fit import aligned_from
from .rules import Rules


def confirm_pending(
    points: NDArray[np.float64],
    prediction: Prediction,
    pending: tuple[Pose, Pose] | None,
    fit: FitDecision,
    rules: Rules,
) -> PendingDecision:
    """The place an earlier scan put the robot at after a rejected jump (`pending`: the place and
    that scan's odometry pose), followed with the odometry, and the fit there when this scan
    confirms it: a sound fit there that explains the scan better than the prediction's fit by the
    recovery's `margin` (or the prediction's was rejected), or that the scan's likelihood prefers
    to it by the fault cost (`_fault_confirmed`). A scan that says nothing either way
    (it could not be aligned, or the gate rejects the fits at both places: a poor scan, such as the
    one after an odometry fault on fhw, whose true place explained 12 % of it) keeps the place
    pending for the next scan (`PendingDecision.kept`); the lost rule bounds how long."""
    if pending is None:
        return PendingDecision(None, None)
    there = compose(pending[0], between(pending[1], prediction.odom))
    if fit.result is None:
        return PendingDecision(None, None, kept=(there, prediction.odom))
    follow = aligned_from(points, there, rules)
    if rules.gate.rejection(follow, there):
        return PendingDecision(there, None, kept=(there, prediction.odom) if fit.reason != "" else None)
    if (
        fit.reason == ""
        and follow.inlier_ratio <= fit.result.inlier_ratio + rules.recovery.margin
        and not _fault_confirmed(points, follow.pose, fit.result.pose, rules)
    ):
        return PendingDecision(there, None)
    return PendingDecision(there, follow)


def _fault_confirmed(points: NDArray[np.float64], place: Pose, fit: Pose, rules: Rules) -> bool:
    """Whether this scan, too, prefers the pending place to the fit from the prediction as an
    odometry fault would have it (`planicp.tracking.odometry_fault`): its cost in the plan's
    likelihood field is lower at the place by the fault cost. A place an inlier ratio cannot tell
    from the fit (on fhw, after a 15-degree fault, the fit 20 cm and 13 degrees off explained 48 %
    of the aligned returns) is then taken on the scan's likelihood, as it was found. Only where
    the refinement's field is used and the fault component is on."""
    refinement = rules.refinement
    if not refinement.weighs_faults:
        return False
    threshold = fault_cost(refinement.fault_probability)
    return scan_cost(points, place, rules.plan, refinement) + threshold < scan_cost(points, fit, rules.plan, refinement)
