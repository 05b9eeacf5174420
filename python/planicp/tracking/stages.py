"""The stages of one `Localizer.update`, in the order it runs them.

Each stage is a function that takes the scan, the decisions of the stages before it and the
`Rules` of this update, and returns its own decision (`planicp.tracking.decisions`):

1. `predict` -> `Prediction`
2. `fit_from_prediction` -> `FitDecision`
3. `confirm_pending` -> `PendingDecision`
4. `search_near_prediction` -> `SearchDecision`
5. `judge_score` -> `ScoreDecision`
6. `correct` -> `Correction`
7. `judge_lost` -> `LostDecision`
8. `recover` -> `RecoveryDecision`
9. `keep_records` -> `Bookkeeping`

The stages change no state of the `Localizer` itself (pose, covariance, last odometry, anchor,
pending place: `update` writes those from the decisions); the lost stage updates the
`LostDetector` and the recovery and bookkeeping stages the `Recovery` they are given, which
hold the running state of their rules. The `Localizer` documentation explains the rules; the
helpers here say what each step does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import Pose
from ..plans.plan_map import PlanMap
from ..se2 import between, compose
from .acceptance_gate import AcceptanceGate
from .continuity_rule import ContinuityRule
from .decisions import (
    Bookkeeping,
    Correction,
    FitDecision,
    LostDecision,
    PendingDecision,
    Prediction,
    RecoveryAction,
    RecoveryDecision,
    ScoreDecision,
    SearchCause,
    SearchDecision,
)
from .degeneracy_rule import DegeneracyRule, fuse_along_weak_axis
from .fusion_rule import CHI2_3_999, FusionRule
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .localize import localize
from .lost_rule import LostDetector, LostRule
from .motion_noise import MotionNoise, largest_position_std
from .occlusion_rule import OcclusionFilter
from .recovery import Recovery, RecoveryConfig, SearchBudget
from .relocalize import SearchRegion


@dataclass(frozen=True)
class Rules:
    """The `Localizer`'s plan and rules as one update reads them.

    Attributes:
        plan: the plan.
        config: ICP settings.
        wide_config: `config` with the KD-tree search: the retry of a poor fit with the index,
            and the fits at pending places.
        gate, motion_noise, degeneracy, continuity, fusion: the rules of those names.
        occlusion: the occlusion filter; None: every return is aligned.
        lost: the lost rule.
        recovery: the recovery's settings (its `local_radius`, `margin`, `min_inlier_ratio` and
            search serve the searches around the prediction too).
    """

    plan: PlanMap
    config: IcpConfig
    wide_config: IcpConfig
    gate: AcceptanceGate
    motion_noise: MotionNoise
    degeneracy: DegeneracyRule
    continuity: ContinuityRule
    fusion: FusionRule
    occlusion: OcclusionFilter | None
    lost: LostRule
    recovery: RecoveryConfig


# 1. Prediction


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


# 2. Fit from the prediction


def fit_from_prediction(points: NDArray[np.float64], prediction: Prediction, rules: Rules, lost: bool) -> FitDecision:
    """The scan aligned from the prediction (see `_aligned`; the occlusion rule applies while not
    `lost`) and judged by the gate; with the index, a fit that explains little of the scan is
    tried again with the KD-tree. A scan with too few usable points, or whose points fall in fewer
    search cells than a search needs (`_core.MIN_SEARCH_POINTS`), is not aligned: the same scans
    are refused by every stage, never accepted on one update and refused by a search on another."""
    usable = -(-len(points) // rules.config.subsample)
    if usable < _core.MIN_SCAN_POINTS:
        return FitDecision(
            None, None, None, False, f"scan has {usable} usable points (need {_core.MIN_SCAN_POINTS})", usable=False
        )
    resolution = rules.recovery.search.resolution
    cells = occupied_cells(points, resolution)
    if cells < _core.MIN_SEARCH_POINTS:
        # A thousand returns at one spot are one: ICP would "align" them, and the searches refuse them.
        return FitDecision(
            None,
            None,
            None,
            False,
            f"scan covers {cells} cells of {resolution:g} m (need "
            f"{_core.MIN_SEARCH_POINTS}): too little of the scene to place the robot",
            usable=False,
        )
    predicted = prediction.pose
    result, kept, beyond, occluded, realigned = _aligned(points, prediction, rules, lost)
    reason = rules.gate.rejection(result, predicted)
    retried = False
    # A fit that explains little of the whole scan may have started outside the index's
    # narrower basin (a bad odometry step also misleads the occlusion rule): the KD-tree
    # tries again.
    if (
        poor_fit(result.num_inliers / len(points), reason, result, rules)
        and rules.config.correspondence_search == "wall_index"
    ):
        used = points if kept is None else points[kept]
        wide = localize(used, rules.plan, predicted, rules.wide_config)
        if wide.num_inliers > result.num_inliers:
            result, reason, retried = wide, rules.gate.rejection(wide, predicted), True
    return FitDecision(result, kept, beyond, occluded, reason, usable=True, realigned=realigned, retried=retried)


def occupied_cells(points: NDArray[np.float64], resolution: float) -> int:
    """How many square cells of `resolution` metres the base-frame `points` fall in (the global
    search keeps one point per such cell)."""
    cells = np.floor(points / resolution).astype(np.int64)
    keys = (cells[:, 0] << 32) ^ (cells[:, 1] & 0xFFFFFFFF)
    return int(np.unique(keys).size)


def _aligned(
    points: NDArray[np.float64], prediction: Prediction, rules: Rules, lost: bool
) -> tuple[IcpResult, NDArray[np.bool_] | None, NDArray[np.bool_] | None, bool, bool]:
    """The fit of the scan from the prediction, with the occlusion rule's (kept, beyond,
    occluded) (see `_unoccluded`) and whether every return was aligned again. The rule judges the
    returns from the prediction. When the fit lands more than a quarter of the rule's margin
    away, the prediction was off by a good part of the margin, which makes returns on the plan's
    walls look short of them: every return is aligned again from the prediction, and none counts
    as left out. (In
    `tests/test_localizer.py::test_gate_rejects_a_correction_beyond_max_translation_jump`, a
    prediction 25 cm off left 400 of 1080 returns out and the fit of the rest stopped 15 cm
    from the truth; judging the returns again from that fit and aligning from there stayed
    there too, while all returns from the prediction reach the truth.)"""
    predicted = prediction.pose
    kept, beyond, occluded, view = _unoccluded(points, prediction, rules, lost)
    result = localize(points if kept is None else points[kept], rules.plan, predicted, rules.config, view=view)
    if beyond is not None and rules.occlusion is not None:
        shift = math.hypot(result.pose[0] - predicted[0], result.pose[1] - predicted[1])
        if shift > rules.occlusion.rule.margin / 4.0:
            result = localize(points, rules.plan, predicted, rules.config, view=view)
            return result, None, beyond, False, True
    return result, kept, beyond, occluded, False


def _unoccluded(
    points: NDArray[np.float64], prediction: Prediction, rules: Rules, lost: bool
) -> tuple[NDArray[np.bool_] | None, NDArray[np.bool_] | None, bool, _core.WallView | None]:
    """(kept, beyond, occluded, view) when the occlusion rule applies (a trusted prediction,
    not lost): the points not in front of the plan's walls (None when too few would remain, or
    all: align them all), the points beyond the walls seen from the prediction, whether fewer
    than the rule's `min_points` remain, and, for the KD-tree search, the view from the
    prediction over the arc the whole scan spans, whose visible points it matches against.
    (None, None, False, view) otherwise."""
    occlusion = rules.occlusion
    config = rules.config
    uses_view = occlusion is not None and config.correspondence_search == "kd_tree" and config.use_visibility
    # Cast over the scan's arc even where the rule does not apply: the alignment's own cast covers
    # every direction (on freiburg-campus, 80 m ranges, it took 7.4 ms of a 8.5 ms alignment).
    view = occlusion.view(points, prediction.pose, config) if occlusion is not None and uses_view else None
    if occlusion is None or lost:
        return None, None, False, view
    if 3.0 * largest_position_std(prediction.covariance) >= occlusion.rule.margin:
        return None, None, False, view
    in_front, beyond = occlusion.classify(points, prediction.pose)
    kept: NDArray[np.bool_] = ~in_front
    remaining = int(np.count_nonzero(kept))
    if remaining < occlusion.rule.min_points:
        return None, beyond, True, view
    if remaining == len(points):
        return None, beyond, False, view
    return kept, beyond, False, view


def poor_fit(score: float, reason: str, result: IcpResult, rules: Rules) -> bool:
    """Whether the plan explains `result` poorly: rejected for its fit, or accepted with a
    `score` (see `scan_score`) below the lost rule's."""
    return (reason != "" and rules.gate.fit_rejection(result) != "") or (reason == "" and score < rules.lost.min_score)


# 3. The pending place


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
    recovery's `margin` (or the prediction's was rejected). A scan that says nothing either way
    (it could not be aligned, or the gate rejects the fits at both places: a poor scan, such as the
    one after an odometry fault on fhw, whose true place explained 12 % of it) keeps the place
    pending for the next scan (`PendingDecision.kept`); the lost rule bounds how long."""
    if pending is None:
        return PendingDecision(None, None)
    there = compose(pending[0], between(pending[1], prediction.odom))
    if fit.result is None:
        return PendingDecision(None, None, kept=(there, prediction.odom))
    follow = localize(points, rules.plan, there, rules.wide_config)
    if rules.gate.rejection(follow, there):
        return PendingDecision(there, None, kept=(there, prediction.odom) if fit.reason != "" else None)
    if fit.reason == "" and follow.inlier_ratio <= fit.result.inlier_ratio + rules.recovery.margin:
        return PendingDecision(there, None)
    return PendingDecision(there, follow)


# 4. The search around the prediction


def search_near_prediction(
    points: NDArray[np.float64],
    prediction: Prediction,
    fit: FitDecision,
    pending: PendingDecision,
    rules: Rules,
    lost: bool,
    budget: SearchBudget,
) -> SearchDecision:
    """The fit the update goes on with after a search around the prediction, when the gate cannot
    vouch for it (`search_cause`; not while `lost`, nor after a confirmed pending place, which the
    update goes on with).

    A place found for an uncertain prediction agrees with it and is taken at once. After a fit
    rejected for its jump, odometry may have faulted and the prediction says nothing; but a
    corrupted scan (turned, shifted) fits some place beyond the gate too. So the place (the
    search's, or the sound fit's where the search finds none) is not taken on one scan's word:
    it is left pending for the next scan (`confirm_pending`), which after a fault fits that place
    again and after a corrupted scan fits the prediction better. The search draws on the update's
    `budget` of search nodes."""
    if pending.confirmed is not None:
        return SearchDecision(None, None, pending.confirmed, "", True)
    result, reason = fit.result, fit.reason
    cause = None if result is None or lost else search_cause(result, reason, prediction.covariance, rules)
    if result is None or cause is None:
        return SearchDecision(None, None, result, reason, False)
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
        return SearchDecision(cause, None, result, reason, False)
    place = found if found is not None else result
    source = "a search found" if found is not None else "the fit puts the robot at"
    reason = (
        f"{reason}; {source} a place {_distance(predicted, place.pose):.2f} m away, taken if the next scan confirms it"
    )
    return SearchDecision(cause, found, result, reason, False, pending=(place.pose, prediction.odom))


def search_cause(
    result: IcpResult, reason: str, predicted_covariance: NDArray[np.float64], rules: Rules
) -> SearchCause | None:
    """Why the gate cannot vouch for this update, if it cannot: "jump", a good fit rejected
    only for its jump; "uncertain", a prediction whose 3-sigma position uncertainty exceeds
    the translation limit. None: no search (or the recovery searches no neighbourhood)."""
    if rules.recovery.local_radius <= 0.0:
        return None
    if reason != "" and rules.gate.fit_rejection(result) == "":
        return "jump"
    if 3.0 * largest_position_std(predicted_covariance) > rules.gate.max_translation_jump:
        return "uncertain"
    return None


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
    `accepted`) more of it than that fit by the recovery's `margin`, and (given the
    prediction's covariance, `consistent_with`) lies within the chi-square bound of the
    fusion (`CHI2_3_999`, 99.9 %) of the prediction; else None.

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
    refined = localize(points, rules.plan, best.pose, rules.config)
    if rules.gate.rejection(refined, best.pose) or refined.inlier_ratio < config.min_inlier_ratio:
        return None
    if accepted is not None and refined.inlier_ratio <= accepted.inlier_ratio + config.margin:
        return None
    if consistent_with is not None and not rules.fusion.innovation(refined, predicted, consistent_with) <= CHI2_3_999:
        # A place the prediction's own uncertainty rules out: with a short-range scanner a
        # wrong place can explain more of a scan than the right one.
        return None
    return refined


# 5. Score and continuity


def judge_score(
    points: NDArray[np.float64],
    prediction: Prediction,
    fit: FitDecision,
    search: SearchDecision,
    rules: Rules,
    lost: bool,
    anchor: tuple[NDArray[np.float64], Pose] | None,
) -> ScoreDecision:
    """How much of the whole scan the plan explains (`scan_score`; a search's fit is over the whole
    scan), whether that is poor (`poor_fit`), and, for a poor fit while not `lost`, whether the
    scan continues the last one the plan explained well (`anchor`: its points and odometry pose;
    see `_continuity`)."""
    result, reason, searched = search.result, search.reason, search.searched
    if result is None:
        return ScoreDecision(0.0, False, None, reason)
    score = (
        scan_score(result, None, None, len(points))
        if searched
        else scan_score(result, fit.kept, fit.beyond, len(points))
    )
    poor = poor_fit(score, reason, result, rules)
    continues: bool | None = None
    if poor and not lost:
        continues, reason = _continuity(points, prediction.odom, fit, result, reason, searched, score, rules, anchor)
    return ScoreDecision(score, poor, continues, reason)


def scan_score(
    result: IcpResult, kept: NDArray[np.bool_] | None, beyond: NDArray[np.bool_] | None, scan_points: int
) -> float:
    """How much of the WHOLE scan of `scan_points` the plan explains: returns the occlusion rule
    left out (`kept` False) count as unexplained, so that a wrong prediction cannot hide the
    evidence against it, and so do returns `beyond` the walls seen from the prediction even
    when paired (the nearest-wall index's masks see occluders within 0.6 m only, so from a
    wrong place, a kidnapped robot, it pairs returns that came through walls)."""
    if beyond is None:
        return result.num_inliers / scan_points
    inliers = np.zeros(scan_points, dtype=bool)
    if kept is None:
        inliers[:] = result.inlier_mask
    else:
        inliers[kept] = result.inlier_mask
    return float(np.count_nonzero(inliers & ~beyond)) / scan_points


def _continuity(
    points: NDArray[np.float64],
    odom: Pose,
    fit: FitDecision,
    result: IcpResult,
    reason: str,
    searched: bool,
    score: float,
    rules: Rules,
    anchor: tuple[NDArray[np.float64], Pose] | None,
) -> tuple[bool, str]:
    """(continues, reason) for a fit the plan explains poorly (rejected for its fit, or
    accepted with a score below the lost rule's), checked against the last scan the plan
    explained well (`anchor`): if the scan continues it, the robot is among clutter and nothing
    is concluded; if not, the fit is not trusted (an accepted one gets a `reason`) and counts
    towards being lost. (Against the last well explained scan, not simply the previous one:
    after a kidnap the second scan continues the first one elsewhere.)

    A crowd hides most walls, and its people move between scans: the plan explains little of
    the scan and the scan does not continue the last one. If the plan explains the returns the
    occlusion rule kept (those on or beyond its walls) as well as a continuation must overlap,
    the scan is sound where it sees the plan; if the rule kept too few to align, the scan says
    nothing either way. Otherwise only the kept returns need to continue the last scan: a
    return short of the plan's walls says nothing about where the robot is."""
    kept = fit.kept
    continues = fit.occluded or (
        kept is not None and not searched and reason == "" and result.inlier_ratio >= rules.continuity.min_overlap
    )
    if not continues and anchor is not None:
        continues = rules.continuity.continues(
            points if kept is None else points[kept], anchor[0], between(anchor[1], odom)
        )
        if not continues and reason == "":
            reason = (
                f"the plan explains only {100 * score:.0f} % of the scan and it does not "
                f"continue the last scan the plan explained"
            )
    return continues, reason


# 6. Correction


def correct(prediction: Prediction, search: SearchDecision, score: ScoreDecision, rules: Rules) -> Correction:
    """The pose and covariance after an accepted fit: its fusion with the prediction; after an
    odometry fault (not fused) or a search, the fit alone, except along a degenerate axis, where
    the prediction is corrected only as far as the variances say. Without an accepted fit, the
    prediction's."""
    result = search.result
    if result is None or score.reason != "":
        return Correction(prediction.pose, prediction.covariance, False, None, "prediction")
    degeneracy = rules.degeneracy.check(result)
    fused = None if search.searched else rules.fusion.fuse(result, prediction.pose, prediction.covariance)
    if fused is not None:
        return Correction(fused[0], fused[1], True, degeneracy, "fused")
    if degeneracy is not None:
        pose, covariance = fuse_along_weak_axis(degeneracy, result, prediction.pose, prediction.covariance)
        return Correction(pose, covariance, True, degeneracy, "weak_axis")
    return Correction(result.pose, finite_or(result.covariance, prediction.covariance), True, None, "fit")


# 7. Lost


def judge_lost(
    detector: LostDetector,
    score: ScoreDecision,
    correction: Correction,
    search: SearchDecision,
    was_lost: bool,
    rules: Rules,
) -> LostDecision:
    """The lost rule's verdict, with this scan counted in `detector` unless it is clutter
    (`ScoreDecision.continues`)."""
    if score.continues:
        lost = detector.hold()
        return LostDecision(lost, True, False, detector.score, detector.rejections)
    # While lost, a fit from the prediction (the place the localizer lost track at) ends the lost
    # state only when it explains as much of the scan as the recovery asks of a place it adopts:
    # a wrong place may explain a third of the scan and pass the gate. (Otherwise the recovery
    # ends it; in a symmetric room it cannot choose, and a sound track would stay lost.)
    clears = not was_lost or search.searched or score.score >= rules.recovery.min_inlier_ratio
    counted = correction.accepted and clears
    lost = detector.update(score.score, counted)
    return LostDecision(lost, False, counted, detector.score, detector.rejections)


# 8. Recovery


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


# 9. Bookkeeping


def keep_records(
    recovery: Recovery,
    fit: FitDecision,
    score: ScoreDecision,
    result: IcpResult | None,
    scan_points: int,
    accepted: bool,
    relocalized: bool,
    lost: bool,
) -> Bookkeeping:
    """Whether the scan becomes the continuity anchor (an `accepted` fit the plan explains well,
    or clutter that continues the last anchor), and, for a soundly tracked scan (accepted, well
    explained, not `relocalized`, not `lost`), what the recovery learns of this plan and scanner
    from it: the share of its returns beyond the walls seen from the prediction (see
    `Recovery.beyond_limit`) and the share of its `scan_points` the fit `result` explained (over
    the whole scan, as the recovery's fits count theirs: returns left out in front of the walls
    are not explained; see `Recovery.explained_seen`)."""
    anchored = bool(accepted and (score.continues or not score.poor))
    share = explained = None
    sound = accepted and not score.poor and not relocalized and not lost
    if sound and fit.beyond is not None:
        share = float(np.mean(fit.beyond))
        recovery.observe_beyond(share)
    if sound and result is not None and scan_points > 0:
        explained = result.num_inliers / scan_points
        recovery.observe_explained(explained)
    return Bookkeeping(anchored, share, explained)


def finite_or(covariance: NDArray[np.float64], fallback: NDArray[np.float64]) -> NDArray[np.float64]:
    """`covariance` as float64 when it is finite, else `fallback`."""
    cov = np.asarray(covariance, dtype=np.float64)
    return cov.copy() if np.isfinite(cov).all() else fallback


def _distance(a: Pose, b: Pose) -> float:
    """Metres between the positions of two poses."""
    return math.hypot(a[0] - b[0], a[1] - b[1])
