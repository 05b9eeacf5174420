"""Stage 4 of `Localizer.update`: the plan searched around a prediction the gate cannot vouch for
(`search_near_prediction`)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
from ..decisions import FitDecision, PendingDecision, PendingPlace, Prediction, SearchCause, SearchDecision
from ..fusion_rule import CHI2_3_999
from ..icp_result import IcpResult
from ..motion_noise import largest_position_std
from ..odometry_fault import CostHistory, fault_cost, holds_as_fault, sweep_for_fault, with_held_mode, within_fault
from ..posterior_refinement import refine_pose
from ..recovery import SearchBudget
from ..relocalize import SearchRegion
from .fit import aligned_from
from .rules import Rules


def search_near_prediction(
    points: NDArray[np.float64],
    prediction: Prediction,
    fit: FitDecision,
    pending: PendingDecision,
    rules: Rules,
    lost: bool,
    budget: SearchBudget,
    history: CostHistory,
) -> SearchDecision:
    """The fit the update goes on with after a search around the prediction, when the gate cannot
    vouch for it (`search_cause`; not while `lost`, nor after a confirmed pending place, which the
    update goes on with).

    A place found for an uncertain prediction agrees with it and is taken at once (so is one
    found within its bound for a fit rejected for a jump, `search_cause`). After a fit
    rejected for its jump, odometry may have faulted and the prediction says nothing; but a
    corrupted scan (turned, shifted) fits some place beyond the gate too. So the place (the
    search's, or the sound fit's where the search finds none) is taken at once only where the
    fault component of the motion model explains it (`_a_fault_explains`), with the prediction
    left behind for the next scans to weigh; otherwise it is left pending for the next scan
    (`confirm_pending`), which after a fault fits that place again and after a corrupted scan
    fits the prediction better. The search draws on the update's `budget` of search nodes.

    Where neither search leaves a place, a scan the update's pose explains far worse than the
    track's recent scans (their costs in the plan's likelihood field, `history`) is swept for an
    odometry fault (`_fault_search`), whose place is taken at once."""
    if pending.confirmed is not None:
        return SearchDecision(None, None, pending.confirmed, "", True)
    result, reason = fit.result, fit.reason
    cause = None if result is None or lost else search_cause(result, reason, prediction, rules)
    if result is None or cause is None:
        return _fault_search(
            points, prediction, SearchDecision(None, None, result, reason, False), rules, lost, history
        )
    predicted = prediction.pose
    found = _search_near(
        points,
        predicted,
        result if reason == "" else None,
        prediction.covariance if cause == "uncertain" else None,
        rules,
        budget,
    )
    if cause == "uncertain":
        if found is not None:
            return SearchDecision(cause, found, found, "", True)
        if _only_jump(result, reason, rules):
            # A jump that no place within the prediction's bound confirms: searched as any jump is
            # (after fhw's 24-degree heading fault, the fit 0.58 m off explained 48 % of the scan,
            # the place the fault put the robot lay beyond the bound).
            found = _search_near(points, predicted, None, None, rules, budget)
            return _jump(points, prediction, result, reason, found, rules, history, "jump")
        return _fault_search(
            points, prediction, SearchDecision(cause, None, result, reason, False), rules, lost, history
        )
    return _jump(points, prediction, result, reason, found, rules, history, cause)


def _jump(
    points: NDArray[np.float64],
    prediction: Prediction,
    result: IcpResult,
    reason: str,
    found: IcpResult | None,
    rules: Rules,
    history: CostHistory,
    cause: SearchCause,
) -> SearchDecision:
    """A fit rejected for its jump (`result`, refused for `reason`), and the place the search
    around the prediction `found` (or None): the place (the search's, else the fit's) taken at
    once where the fault component explains it, with the prediction left behind; otherwise left
    pending for the next scan."""
    place = found if found is not None else result
    if _a_fault_explains(points, prediction, place, rules, history):
        # The odometry strayed, as the fault component has it: the place is the posterior's mode.
        return SearchDecision(cause, found, place, "", True, left=prediction.pose)
    source = "a search found" if found is not None else "the fit puts the robot at"
    away = _distance(prediction.pose, place.pose)
    reason = f"{reason}; {source} a place {away:.2f} m away, taken if the next scan confirms it"
    return SearchDecision(cause, found, result, reason, False, pending=PendingPlace(place.pose, prediction.odom))


def _a_fault_explains(
    points: NDArray[np.float64], prediction: Prediction, place: IcpResult, rules: Rules, history: CostHistory
) -> bool:
    """Whether the place of a rejected jump (`place`, the search's or the fit's) is one the fault
    component of the max-mixture motion model covers and prefers to its Gaussian component, as
    `correction._fault_or_prediction` weighs a fit beyond the prediction. It lies within the fault
    model (`within_fault`: the motion since the last accepted pose), and so does the mode of the
    scan's likelihood (no prior) a climb from it reaches; that mode's cost, plus the fault cost
    `F`, is below the cost of the mode a climb from the prediction reaches under the prediction's
    Gaussian; that mode explains the scan worse than the track's typical cost by `F` (the
    evidence of a fault the sweep asks of the update's own pose; on freiburg-campus, odometry
    seed 5, single scans fitted walls the map drew twice 0.8 m from a sound prediction whose mode
    explained them within `F` of the typical cost); and the place's cost is within `F` of the
    typical one (it explains the scan as the track's scans are). Such a place is taken at once,
    as the fault sweep's is (on fhw two jumps after long pauses, odometry heading faults of 23
    and 33 degrees, waited a scan each, 0.47 and 0.42 m off meanwhile). The prediction's raw cost
    is no measure: 0.5 m of drift leaves it far up any wall's slope. A corrupted scan's jump
    (shifted 3 m) lies beyond the fault model and waits for the next scan. False without the
    refinement's field and its fault component, or before a typical cost is known."""
    refinement = rules.refinement
    typical = history.typical()
    if not refinement.weighs_faults or typical is None:
        return False
    motion = history.motion_since(prediction.odom, prediction.motion)
    if not within_fault(place.pose, prediction.pose, motion, refinement, rules.gate.max_translation_jump):
        return False
    faulted = refine_pose(points, place.pose, rules.plan, None, refinement)
    bound = typical + fault_cost(refinement.fault_probability)
    if faulted.cost > bound or not within_fault(
        faulted.pose, prediction.pose, motion, refinement, rules.gate.max_translation_jump
    ):
        return False  # the held mode's climb is not needed
    modes = with_held_mode(faulted, points, prediction.pose, prediction.covariance, rules.plan, refinement)
    return modes.held.cost > bound and modes.fault_preferred


def _fault_search(
    points: NDArray[np.float64],
    prediction: Prediction,
    decision: SearchDecision,
    rules: Rules,
    lost: bool,
    history: CostHistory,
) -> SearchDecision:
    """`decision`, or, where the heading sweep for an odometry fault
    (`planicp.tracking.odometry_fault.sweep_for_fault`) finds a place of higher posterior than
    the update's pose (`decision`'s fit when accepted, else the prediction) within the fault
    model and ICP from it fits soundly, that fit taken at once (cause "fault", `searched`: not
    fused with the prediction, which says nothing after a fault), with the prediction left
    behind (`SearchDecision.left`) for the next scans to weigh (stage 7): one scan does not tell
    a fault from a scan turned within the fault window. Not while `lost` (the recovery searches
    then), for a scan that could not be aligned, nor without the posterior refinement (whose
    likelihood field the sweep climbs)."""
    if lost or decision.result is None:
        return decision
    current = decision.result.pose if decision.reason == "" else prediction.pose
    # The steps since the last accepted pose: the updates after it held their predictions, so a
    # fault in any of them is in the prediction (on fhw a 31-degree fault one update before).
    motion = history.motion_since(prediction.odom, prediction.motion)
    tolerance = rules.gate.max_translation_jump
    sweep = sweep_for_fault(points, prediction.pose, current, rules.plan, rules.refinement, history, motion, tolerance)
    if sweep is None:
        return decision
    if not sweep.more_probable:
        return replace(decision, fault=sweep)
    place = aligned_from(points, sweep.pose, rules)
    if not holds_as_fault(place, prediction.pose, motion, rules.refinement, rules.gate):
        return replace(decision, fault=sweep)
    # The scan prefers a place within the fault model to the fit by the fault cost: the posterior's
    # mode, with the odometry's fault component as its prior. A corrupted scan (turned within the
    # window) fits such a place too, and then says nothing: the robot is where the odometry puts
    # it, so the prediction stays a hypothesis (stage 7 weighs it against the next scans).
    return SearchDecision("fault", place, place, "", True, fault=sweep, left=prediction.pose)


def search_cause(result: IcpResult, reason: str, prediction: Prediction, rules: Rules) -> SearchCause | None:
    """Why the gate cannot vouch for this update, if it cannot: "uncertain", a prediction whose
    3-sigma position uncertainty exceeds the gate's translation limit, or whose 3-sigma heading
    uncertainty exceeds its rotation limit (the true correction may lie beyond what the gate
    accepts, and ICP from a heading that far off can settle in a wrong basin: on freiburg-101,
    after a 34-degree turn of the odometry, a fit 0.3 m off explained 79 % of the scan against
    95 % at the truth and held for 8 scans); "jump", a good fit rejected only for its jump,
    unless the prediction is uncertain: the places within its chi-square bound (`CHI2_3_999`)
    are searched first, wherever the fit lies. A correction the odometry's own uncertainty allows
    is no jump (on seattle with every third scan tracked, a 5.1 m step turning 50 degrees, 7.6
    degrees uncertain, was corrected by 10.3 degrees), and a fit that slid beyond the bound says
    nothing of the places inside it (seattle, a 5.2 m step: ICP from a heading 9 degrees off went
    to a place 1.1 m away; the robot lay 0.33 m from the prediction). None: no search (or the
    recovery searches no neighbourhood)."""
    if rules.recovery.local_radius <= 0.0:
        return None
    covariance = prediction.covariance
    uncertain = 3.0 * largest_position_std(covariance) > rules.gate.max_translation_jump or (
        3.0 * math.sqrt(max(float(covariance[2, 2]), 0.0)) > rules.gate.max_rotation_jump
    )
    if _only_jump(result, reason, rules):
        return "uncertain" if uncertain else "jump"
    return "uncertain" if uncertain else None


def _only_jump(result: IcpResult, reason: str, rules: Rules) -> bool:
    """Whether the gate refused `result` (for `reason`) only for the size of its correction."""
    return reason != "" and rules.gate.fit_rejection(result) == ""


def _search_near(
    points: NDArray[np.float64],
    predicted: Pose,
    accepted: IcpResult | None,
    consistent_with: NDArray[np.float64] | None,
    rules: Rules,
    budget: SearchBudget,
) -> IcpResult | None:
    """The fit at the unambiguous best place around `predicted`, when it explains at least the
    recovery's `min_inlier_ratio` of the scan, (if the fit from the prediction was acceptable,
    `accepted`) more of it than that fit by the recovery's `margin` and with a higher posterior
    than it (`_more_probable`), and (given the prediction's covariance, `consistent_with`) lies
    within the chi-square bound of the fusion (`CHI2_3_999`, 99.9 %) of the prediction; else None.

    With `consistent_with`, only the places that can pass that bound are searched: positions
    within `sqrt(CHI2_3_999)` standard deviations of the prediction along its widest axis and
    headings within as many of its heading's, each widened by the reach of the refinement from
    a lattice pose (the ICP's correspondence distance, two heading steps), inside the
    recovery's `local_radius`. A search of every heading around the prediction took 35-120 ms
    on a real log whose scans were 2 m apart, and then refused every place outside that region.

    The search scores at most what is left of the update's `budget` (`RecoveryConfig.search_nodes`);
    one that would need more finds nothing (the fit's own place then waits for the next scan)."""
    config = rules.recovery
    radius, yaw_tolerance = config.local_radius, math.pi
    if consistent_with is not None:
        k = math.sqrt(CHI2_3_999)
        reach = rules.config.max_correspondence_distance
        radius = min(radius, k * largest_position_std(consistent_with) + reach)
        yaw_std = math.sqrt(max(float(consistent_with[2, 2]), 0.0))
        yaw_tolerance = min(math.pi, k * yaw_std + 2.0 * config.search.heading_step)
    found = budget.search(
        points, rules.plan, SearchRegion(predicted, radius, yaw_tolerance), config.search, config.max_hypotheses
    )
    best = None if found is None else found.best
    if found is None or best is None or found.ambiguous or best.inlier_ratio < config.min_inlier_ratio:
        return None
    refined = aligned_from(points, best.pose, rules, rules.config)
    if rules.gate.rejection(refined, best.pose) or refined.inlier_ratio < config.min_inlier_ratio:
        return None
    if accepted is not None and refined.inlier_ratio <= accepted.inlier_ratio + config.margin:
        return None
    if accepted is not None and consistent_with is not None:
        if not _more_probable(points, refined.pose, accepted.pose, predicted, consistent_with, rules):
            return None
    if consistent_with is not None and not rules.fusion.innovation(refined, predicted, consistent_with) <= CHI2_3_999:
        # A place the prediction's own uncertainty rules out: with a short-range scanner a
        # wrong place can explain more of a scan than the right one.
        return None
    return refined


def _more_probable(
    points: NDArray[np.float64], place: Pose, fit: Pose, predicted: Pose, covariance: NDArray[np.float64], rules: Rules
) -> bool:
    """Whether the search's `place` has a higher posterior than the fit from the prediction:
    a lower cost in the plan's likelihood field with the prediction as the prior (the cost the
    refinement climbs, `planicp.tracking.posterior_refinement`).

    The inlier ratio alone counts the returns within ICP's last correspondence distance of some
    wall, and along a corridor a place a metre off can count more of them than the true one: on
    the orebro log tracked from its even-numbered scans, after an odometry step of 4.9 m, a place
    0.93 m along the corridor explained 74 % of the scan against 67 % for the fit from the
    prediction, 2 cm from the reference, while the scan's cost in the field was higher there
    (35.2 against 32.3) and the prediction, 0.25 m uncertain, all but ruled it out (posterior
    cost 52.4 against 32.8)."""
    field = rules.plan.likelihood_field()
    prior = np.asarray(covariance, dtype=np.float64).tolist()
    weight = rules.refinement.return_weight
    return bool(field.cost(points, place, predicted, prior, weight) < field.cost(points, fit, predicted, prior, weight))


def _distance(a: Pose, b: Pose) -> float:
    """Metres between the positions of two poses."""
    return math.hypot(a[0] - b[0], a[1] - b[1])
