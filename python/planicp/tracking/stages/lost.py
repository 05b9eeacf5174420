"""Stage 8 of `Localizer.update`: the lost rule's verdict (`judge_lost`)."""

from __future__ import annotations

from ..decisions import Correction, LostDecision, ScoreDecision, SearchDecision
from ..lost_rule import LostDetector
from .rules import Rules


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
    # While lost, the track from the prediction (the place the localizer lost track at) is a
    # place like those the recovery follows, and ends the lost state on the same evidence: fits
    # from it that explain as much of the scan as the recovery asks of a place it adopts, over
    # as many scans in a row as it confirms a place with. A wrong place may explain a third of
    # the scan and pass the gate, and on fhw one fit from a place 1.4 m off explained 61 % of its
    # scan: taken as found, the track drifted 75 m off for a hundred scans. (Otherwise the
    # recovery ends it; in a symmetric room it cannot choose, and a sound track would stay lost.)
    if was_lost and not search.searched:
        sound = correction.accepted and score.score >= rules.recovery.min_inlier_ratio
        detector.sound_streak = detector.sound_streak + 1 if sound else 0
        clears = detector.sound_streak >= rules.recovery.confirmations
    else:
        detector.sound_streak = 0
        clears = True
    counted = correction.accepted and clears
    lost = detector.update(score.score, counted)
    return LostDecision(lost, False, counted, detector.score, detector.rejections)
