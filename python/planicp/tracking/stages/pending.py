"""Stage 3 of `Localizer.update`: the places rejected jumps left pending, confirmed or not by this
scan (`confirm_pending`), and what they leave open of the pose an update reports
(`spread_over_pending`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
from ...se2 import between, compose, wrap_angle
from ..decisions import FitDecision, PendingDecision, PendingPlace, Prediction
from ..icp_result import IcpResult
from ..odometry_fault import CostHistory, fault_cost, scan_cost
from .fit import aligned_from
from .rules import Rules


def confirm_pending(
    points: NDArray[np.float64],
    prediction: Prediction,
    pending: tuple[PendingPlace, ...],
    fit: FitDecision,
    rules: Rules,
    history: CostHistory | None = None,
) -> PendingDecision:
    """The places earlier scans put the robot at after rejected jumps (`pending`), each followed
    with the odometry, and the fit at the one this scan confirms: a sound fit there that the
    scan's likelihood prefers to the prediction's fit by the fault cost (`_fault_confirmed`), or
    that explains the scan better than the prediction's fit by the recovery's `margin` (or the
    prediction's was rejected) where the place also explains the scan as the track's scans are
    (`_usual_cost`). Of several confirmed, the one whose fit explains the most of the
    scan.

    A scan that says nothing either way keeps a place pending for the next scan
    (`PendingDecision.kept`): it could not be aligned, or it explains neither the place nor the
    prediction: the gate rejects the fits at both (a poor scan, such as the one after an odometry
    fault on fhw, whose true place explained 12 % of it), or its cost in the plan's likelihood
    field (`history`: the track's typical cost) exceeds the typical one by the fault cost at both,
    the measure by which the fault sweep finds that a place explains a scan as the track's scans
    are (where the refinement's field is used with its fault component: a SLAM map's cells by
    default). Such a scan is corrupted, or shows what the plan does not: it weighs the place
    against the prediction no more than a scan too small to align. A place is kept over at most
    the lost rule's `max_rejections` such scans, the span the rule gives a track without an
    accepted fit.
    Several places may be pending at once: the place a search found on a scan that said nothing
    of an earlier one joins it, since one scan's word does not choose between them (on
    freiburg-campus a corrupted-looking scan's place replaced the right one, which the next scan
    would have confirmed, and the localizer lost track)."""
    if not pending:
        return PendingDecision(None, None)
    cost = _field_costs(points, rules)
    usual = _usual_cost(rules, history)
    best: tuple[float, PendingDecision] | None = None
    kept: list[PendingPlace] = []
    first = None
    for waiting in pending:
        there = compose(waiting.pose, between(waiting.odom, prediction.odom))
        first = there if first is None else first
        later = PendingPlace(there, prediction.odom, waiting.silent + 1)
        if fit.result is None:
            kept.append(later)
            continue
        follow = aligned_from(points, there, rules)
        verdict = _verdict(follow, there, fit, rules, usual, cost)
        if verdict == "confirmed" and (best is None or follow.inlier_ratio > best[0]):
            best = (follow.inlier_ratio, PendingDecision(there, follow, (), len(pending)))
        elif verdict == "silent":
            kept.append(later)
    if best is not None:
        return best[1]
    keep = tuple(p for p in kept if p.silent <= rules.lost.max_rejections)
    return PendingDecision(first, None, keep, len(pending))


def _field_costs(points: NDArray[np.float64], rules: Rules) -> Callable[[Pose], float]:
    """The scan's cost in the plan's likelihood field (no prior) at a pose, each pose's computed
    once (the fit from the prediction is weighed against every pending place)."""
    costs: dict[Pose, float] = {}

    def cost(pose: Pose) -> float:
        if pose not in costs:
            costs[pose] = scan_cost(points, pose, rules.plan, rules.refinement)
        return costs[pose]

    return cost


def _verdict(
    follow: IcpResult,
    there: Pose,
    fit: FitDecision,
    rules: Rules,
    usual: float | None,
    cost: Callable[[Pose], float],
) -> str:
    """What this scan says of the pending place `there`, whose fit is `follow`, against the fit
    from the prediction (`fit`, aligned), `cost` the scan's cost in the likelihood field at a
    pose, `usual` the most it costs where a place explains it as the track's scans are
    (`_usual_cost`): "confirmed", "refuted" or "silent"."""
    assert fit.result is not None
    place, other = follow.pose, fit.result.pose
    if rules.gate.rejection(follow, there):
        neither = fit.reason != "" or _explains_neither(place, other, usual, cost)
        return "silent" if neither else "refuted"
    if _fault_confirmed_by(place, other, rules, cost):
        return "confirmed"
    preferred = fit.reason != "" or follow.inlier_ratio > fit.result.inlier_ratio + rules.recovery.margin
    if preferred and (usual is None or cost(place) <= usual):
        return "confirmed"
    return "silent" if _explains_neither(place, other, usual, cost) else "refuted"


def _usual_cost(rules: Rules, history: CostHistory | None) -> float | None:
    """The most the scan may cost in the plan's likelihood field at a place that explains it as
    the track's scans are: the track's typical cost (`history`) plus the fault cost, what the fault
    sweep asks of a place it finds (`FaultSweep.more_probable`). None without the refinement's
    field, its fault component, or a typical cost yet.

    A place the share test or a rejected fit from the prediction would confirm must explain the
    scan so: a place merely less bad than that fit is no evidence of where the robot is. On
    freiburg-campus (every third scan, odometry seed 8) a search's place 2.6 m off, left pending
    after a rejected jump, was confirmed by the next scan because that scan's fit from the
    prediction was rejected too, though the scan cost 49.3 there against a typical 23.7 (the
    fault cost 13.8), and the track stayed 2.8-3.0 m off for six updates. A place the scan's
    likelihood prefers to the prediction's fit by the fault cost needs no more: where the map drew
    walls twice every place costs far above the typical, and on freiburg-campus with tripled
    odometry noise the true place, at 39.5 against a rejected fit's 69.6, was kept waiting until
    it was lost."""
    refinement = rules.refinement
    typical = None if history is None else history.typical()
    if typical is None or not refinement.weighs_faults:
        return None
    return typical + fault_cost(refinement.fault_probability)


def _explains_neither(place: Pose, fit: Pose, usual: float | None, cost: Callable[[Pose], float]) -> bool:
    """Whether the scan's cost in the plan's likelihood field (`cost`) exceeds `usual`
    (`_usual_cost`) both at `place` and at `fit` (the prediction's fit): neither explains it as
    the track's scans are explained. False where `usual` is None."""
    return usual is not None and min(cost(place), cost(fit)) > usual


def _fault_confirmed(points: NDArray[np.float64], place: Pose, fit: Pose, rules: Rules) -> bool:
    """Whether this scan, too, prefers the pending place to the fit from the prediction as an
    odometry fault would have it (`planicp.tracking.odometry_fault`): its cost in the plan's
    likelihood field is lower at the place by the fault cost. A place an inlier ratio cannot tell
    from the fit (on fhw, after a 15-degree fault, the fit 20 cm and 13 degrees off explained 48 %
    of the aligned returns) is then taken on the scan's likelihood, as it was found. Only where
    the refinement's field is used and the fault component is on."""
    return _fault_confirmed_by(place, fit, rules, _field_costs(points, rules))


def _fault_confirmed_by(place: Pose, fit: Pose, rules: Rules, cost: Callable[[Pose], float]) -> bool:
    """`_fault_confirmed` with the scan's costs from `cost`."""
    refinement = rules.refinement
    if not refinement.weighs_faults:
        return False
    return cost(place) + fault_cost(refinement.fault_probability) < cost(fit)


def spread_over_pending(
    pose: Pose, covariance: NDArray[np.float64], places: tuple[PendingPlace, ...]
) -> NDArray[np.float64]:
    """The covariance an update reports about `pose` (T_map_base) while `places` are open: the
    track's own `covariance` (3x3 over x, y, yaw: m^2, m rad, rad^2) plus, for each place, its
    offset from `pose` (x, y in metres, yaw wrapped, in radians) times its outer product,
    weighted 1 / (number of places + 1). An open place is one the scans have not ruled out (a
    rejected jump's place until the next scan confirms or refutes it; the place an adopted
    odometry fault left behind, until a scan prefers the track to it by the fault cost): the
    robot is there or on the track, as far as the localizer can tell, and the second moment about
    the reported pose of that mixture, each hypothesis weighed alike and spread as the track, is
    this. On fhw the update holding the prediction after a 19-degree fault reported a 2 cm
    deviation 33 cm from the robot. Only what is reported: the track goes on with its own
    covariance."""
    if not places:
        return covariance
    weight = 1.0 / (len(places) + 1)
    spread = np.array(covariance, dtype=float, copy=True)
    for place in places:
        d = np.array([place.pose[0] - pose[0], place.pose[1] - pose[1], wrap_angle(place.pose[2] - pose[2])])
        spread += weight * np.outer(d, d)
    return spread
