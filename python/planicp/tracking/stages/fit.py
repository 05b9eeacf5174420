"""Stage 2 of `Localizer.update`: the scan aligned from the prediction and judged by the gate
(`fit_from_prediction`), with the occlusion rule applied."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ... import _core
from ..._validation import Pose
from ..decisions import FitDecision, Prediction
from ..icp_config import IcpConfig
from ..icp_result import IcpResult
from ..localize import localize
from ..motion_noise import largest_position_std
from ..occlusion_rule import OcclusionFilter
from .rules import Rules


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
    as left out. (Where the rule kept too few returns to align, every return was aligned already:
    a fit that slides then is pulled by what stands in front of the walls, and the scan stays
    `occluded`.) (In
    `tests/test_localizer.py::test_gate_rejects_a_correction_beyond_max_translation_jump`, a
    prediction 25 cm off left 400 of 1080 returns out and the fit of the rest stopped 15 cm
    from the truth; judging the returns again from that fit and aligning from there stayed
    there too, while all returns from the prediction reach the truth.) Where the prediction was
    too uncertain for the rule and the gate rejects the fit of every return, the rule is tried
    with its margin widened (`_widened`)."""
    predicted = prediction.pose
    kept, beyond, occluded, view = _unoccluded(points, prediction, rules, lost)
    result = localize(points if kept is None else points[kept], rules.plan, predicted, rules.config, view=view)
    if kept is not None and rules.occlusion is not None:
        if _misjudged(result, predicted, rules.occlusion.rule.margin):
            result = localize(points, rules.plan, predicted, rules.config, view=view)
            return result, None, beyond, False, True
    if kept is None and beyond is None and not lost and rules.gate.rejection(result, predicted) != "":
        widened = _widened(points, prediction, rules, view)
        if widened is not None:
            return widened[0], widened[1], widened[2], False, False
    return result, kept, beyond, occluded, False


def _widened(
    points: NDArray[np.float64], prediction: Prediction, rules: Rules, view: _core.WallView | None
) -> tuple[IcpResult, NDArray[np.bool_], NDArray[np.bool_]] | None:
    """(fit, kept, beyond) of the occlusion rule tried where the prediction was too uncertain for
    it and the gate rejected the fit of every return: the returns more than the prediction's
    3-sigma position uncertainty short of the plan's walls (`OcclusionRule.margin_for`) left out
    and the rest aligned. Taken only where the gate passes that fit, the plan explains the
    returns kept as soundly as the crowd rule asks of a crowded scan's (`ContinuityRule.min_overlap`),
    and the fit lands within a quarter of that margin of the prediction (farther, the rule judged
    the returns from the wrong place); None otherwise, or where the rule keeps too few returns
    or all of them. So a crowd round the robot from its first scans (the `Localizer`'s first
    prediction is 10 cm uncertain) is left out instead of being taken for a wrong pose, and after
    an odometry fault, where the returns on the walls look short of them from the prediction and
    the rest fit the wrong pose about half as well, nothing changes."""
    occlusion = rules.occlusion
    if occlusion is None:
        return None
    margin = occlusion.rule.margin_for(largest_position_std(prediction.covariance))
    if margin <= occlusion.rule.margin:
        return None
    predicted = prediction.pose
    kept, beyond, _ = _classified(points, predicted, occlusion, margin)
    if kept is None:
        return None
    result = localize(points[kept], rules.plan, predicted, rules.config, view=view)
    sound = result.inlier_ratio >= rules.continuity.min_overlap and not _misjudged(result, predicted, margin)
    if not sound or rules.gate.rejection(result, predicted) != "":
        return None
    return result, kept, beyond


def _misjudged(result: IcpResult, predicted: Pose, margin: float) -> bool:
    """Whether the fit landed more than a quarter of the occlusion rule's `margin` (metres) from
    the prediction it judged the returns from: the prediction was off by a good part of the
    margin, and returns on the walls looked short of them."""
    return math.hypot(result.pose[0] - predicted[0], result.pose[1] - predicted[1]) > margin / 4.0


def _classified(
    points: NDArray[np.float64], pose: Pose, occlusion: OcclusionFilter, margin: float | None = None
) -> tuple[NDArray[np.bool_] | None, NDArray[np.bool_], bool]:
    """(kept, beyond, occluded): the occlusion rule's classes of `points` from `pose` with
    `margin` (default the rule's): the points not in front of the plan's walls (None when fewer
    than the rule's `min_points` remain, `occluded`, or all do), those beyond the walls."""
    in_front, beyond = occlusion.classify(points, pose, margin)
    kept: NDArray[np.bool_] = ~in_front
    remaining = int(np.count_nonzero(kept))
    if remaining < occlusion.rule.min_points:
        return None, beyond, True
    if remaining == len(points):
        return None, beyond, False
    return kept, beyond, False


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
    kept, beyond, occluded = _classified(points, prediction.pose, occlusion)
    return kept, beyond, occluded, view


def aligned_from(points: NDArray[np.float64], pose: Pose, rules: Rules, config: IcpConfig | None = None) -> IcpResult:
    """ICP from `pose` with `config` (default `rules.wide_config`, the KD-tree over the walls seen
    from there): the fits at pending places and at places a search found. The walls are those the occlusion
    filter's view shows over the scan's arc, as far as a return could pair (the cast the fit from
    the prediction uses); `localize`'s own cast, over every direction to the scan's range, took
    8-15 ms on freiburg-campus's 80 m ranges. Without the occlusion filter, `localize` casts."""
    occlusion = rules.occlusion
    config = rules.wide_config if config is None else config
    casts = config.correspondence_search == "kd_tree" and config.use_visibility
    view = occlusion.view(points, pose, config) if occlusion is not None and casts else None
    return localize(points, rules.plan, pose, config, view=view)


def poor_fit(score: float, reason: str, result: IcpResult, rules: Rules) -> bool:
    """Whether the plan explains `result` poorly: rejected for its fit, or accepted with a
    `score` (see `scan_score`) below the lost rule's."""
    return (reason != "" and rules.gate.fit_rejection(result) != "") or (reason == "" and score < rules.lost.min_score)
