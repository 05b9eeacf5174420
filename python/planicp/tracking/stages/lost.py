"""Stage 8 of `Localizer.update`: the lost rule's verdict (`judge_lost`)."""

from __future__ import annotations

from ..decisions import Correction, LeftPlaceDecision, LostDecision, ScoreDecision, SearchDecision
from ..lost_rule import LostDetector
from .rules import Rules


def judge_lost(
    detector: LostDetector,
    score: ScoreDecision,
    correction: Correction,
    search: SearchDecision,
    was_lost: bool,
    rules: Rules,
    left: LeftPlaceDecision | None = None,
) -> LostDecision:
    """The lost rule's verdict, with this scan counted in `detector` unless it is clutter
    (`ScoreDecision.continues`); a scan that takes back the place left behind (`left`, stage 7)
    counts as accepted, with the share of it ICP from there explains. A fit that ends the lost
    state regains the track (`LostDecision.regained`): a place near where it was lost, which
    `recover` judges as one the recovery finds there (`Recovery.regain`)."""
    if score.continues:
        lost = detector.hold(correction.accepted)
        return LostDecision(lost, True, False, detector.score, detector.rejections)
    # While lost, a fit from the prediction (the place the localizer lost track at) ends the lost
    # state only when it explains as much of the scan as the recovery asks of a place it adopts:
    # a wrong place may explain a third of the scan and pass the gate. (Otherwise the recovery
    # ends it; in a symmetric room it cannot choose, and a sound track would stay lost.)
    if left is not None and left.returned is not None and not was_lost:
        lost = detector.update(left.returned.inlier_ratio, True, rules.lost)
        return LostDecision(lost, False, True, detector.score, detector.rejections)
    clears = not was_lost or search.searched or score.score >= rules.recovery.min_inlier_ratio
    counted = correction.accepted and clears
    lost = detector.update(score.score, counted, rules.lost)
    doubted = _doubted(detector, lost, rules)
    return LostDecision(lost, False, counted, detector.score, detector.rejections, doubted, was_lost and not lost)


def _doubted(detector: LostDetector, lost: bool, rules: Rules) -> bool:
    """Whether the track is kept only because the lost rule's bar is relaxed: the rule as set
    (`Rules.lost_as_set`) would say lost over the same window."""
    return not lost and detector.lost_by(rules.lost_as_set)
