"""Stage 5 of `Localizer.update`: how much of the scan the plan explains, and whether a poorly
explained scan is clutter (`judge_score`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
from ...se2 import between
from ..decisions import FitDecision, Prediction, ScoreDecision, SearchDecision
from ..icp_result import IcpResult
from .fit import poor_fit
from .rules import Rules


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
    see `_continuity`).

    Returns beyond the walls seen from the prediction count as unexplained only where the plan's
    walls stop every beam: a SLAM map's cells (`PlanMap.cells_mark_returns`) are specks that
    beams from other poses passed, and from the reference pose itself the cast through them put
    12-37 % of the returns (the median scan) beyond a wall on the eight real logs' maps; on
    freiburg-campus a fit 5 cm from the reference, from a prediction 0.3 m off, scored 11 % that
    way and was refused (docs/benchmarks.md, "Returns beyond a SLAM map's cells")."""
    result, reason, searched = search.result, search.reason, search.searched
    if result is None:
        return ScoreDecision(0.0, False, None, reason)
    beyond = None if rules.plan.cells_mark_returns else fit.beyond
    score = (
        scan_score(result, None, None, len(points)) if searched else scan_score(result, fit.kept, beyond, len(points))
    )
    poor = poor_fit(score, reason, result, rules)
    continues: bool | None = None
    if poor and not lost:
        continues, reason = _continuity(points, prediction.odom, fit, result, reason, searched, score, rules, anchor)
    elif (
        not lost and score < rules.lost_as_set.min_score and _sound_where_it_sees(fit, result, reason, searched, rules)
    ):
        # Below the lost rule's bar as set, above the bar learned from the track: a crowd's scan
        # is not poor by the learned bar, but counted with its score it would put the track in
        # doubt (`LostDecision.doubted`) and the whole plan would be searched beside it, where a
        # place whose walls the crowd's returns fall on explains more of its scans (the crowd
        # bench's second drive at 40 people: a place 3.8 m away adopted). It is held as a crowd.
        continues = True
    return ScoreDecision(score, poor, continues, reason)


def _sound_where_it_sees(fit: FitDecision, result: IcpResult, reason: str, searched: bool, rules: Rules) -> bool:
    """Whether the scan is sound where it sees the plan: the occlusion rule kept too few returns
    to align (the scan says nothing either way), or the fit from the prediction of those it kept
    passed and explains at least as many of them as a continuation must overlap."""
    kept = fit.kept
    return fit.occluded or (
        kept is not None and not searched and reason == "" and result.inlier_ratio >= rules.continuity.min_overlap
    )


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
    continues = _sound_where_it_sees(fit, result, reason, searched, rules)
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
