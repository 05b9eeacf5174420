"""Stage 7 of `Localizer.update`: the place an adopted jump left behind, weighed against this scan
(`weigh_left_place`).

A place the sweep for an odometry fault finds is taken at once (stage 4), one a rejected jump
left pending when the next scan confirms it (stage 3). One scan does not tell an odometry fault
from what looks like one: a scan turned within the fault window fits a turned place, and where a
SLAM map's passes disagree by half a metre, a scan fits the other pass's copy of the walls as
well (on freiburg-campus, odometry seed 8, two scans in a row preferred it by the fault cost;
from the sixth scan after, the scans preferred the place the track had left by 5-17 cost units,
docs/limitations.md, "One scan's word, weighed after"). So the place left behind stays a hypothesis: followed
with the odometry and climbed to the mode of each scan's likelihood in the plan's field, it
gathers what each scan says for it against the track (`LeftPlace.evidence`, the log-likelihood
ratio of the two, as a sequential test adds it up) and is taken back once that exceeds the fault
cost, forgotten once it falls below minus the fault cost (the max-mixture's own threshold,
`planicp.tracking.odometry_fault`). A true fault's left place, where the odometry alone would have
put the robot, is ruled out at once.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
from ...se2 import between, compose, wrap_angle
from ..decisions import Correction, LeftPlace, LeftPlaceDecision
from ..fusion_rule import CHI2_3_999
from ..odometry_fault import climb, fault_cost, scan_cost
from .fit import aligned_from
from .rules import Rules


def weigh_left_place(
    points: NDArray[np.float64],
    left: LeftPlace | None,
    odom: Pose,
    correction: Correction,
    rules: Rules,
    lost: bool,
    faulted: bool = False,
    motion_covariance: NDArray[np.float64] | None = None,
    offered: tuple[Pose, ...] = (),
) -> LeftPlaceDecision:
    """The place left behind (`left`) followed to this scan's odometry pose `odom`, climbed in the
    plan's likelihood field (no prior), and weighed against the corrected pose (see the module):
    this scan's cost at the corrected pose (the prediction, without an accepted fit) less its
    cost at the place is added to the place's evidence. While `lost` it is dropped (the recovery
    looks for the robot then). Only where the refinement's field is used and the fault component
    is on (`PosteriorRefinement.weighs_faults`).

    The evidence adds up over scans: after a scan turned within the fault window was taken as a
    fault on freiburg-campus, the next scans, from the turned prediction, fitted nothing and
    preferred the track left behind by 7.8 cost units each, less than the fault cost, until the
    track was lost. Where this update itself took a place the fault sweep found (`faulted`), the
    corrected pose needs a fault of its own and the place does not: the fault cost is added to
    what the scan says for it (on freiburg-campus the scan after a turned one found a place
    costing 21.6 where the track left behind cost 7.4), provided the place itself needs none: its
    mode lies within the 99.9 % chi-square bound of where the odometry takes it, over
    `motion_covariance` (the update's prediction covariance; on intel a turned scan led the
    place's alignment to the turned place the sweep took, and the fault cost, added for nothing,
    took it "back" there and dropped the prediction the fault left). Without an accepted fit, the place is
    taken back only where ICP from it passes the gate, and never ruled out (a scan that fits
    nothing soundly does not rule a place out).

    A place whose mode is the corrected pose's, within the 99.9 % bound of its covariance, is the
    track's own again and is forgotten (`merged`): kept, it had gathered the track's own scans'
    evidence for as long as the two coincided, and on seattle a scan turned by 90 degrees later
    took it "back", 0.8 m off, on that evidence.

    Without an accepted fit, the track's cost is the lowest of the corrected pose's (the
    prediction) and those of the places this scan `offered` the track (T_map_base: the fit from
    the prediction, a place left pending for the next scan to confirm): a scan the gate refused
    only for the size of its correction still says where the track is. Weighed against the
    prediction alone, a place left behind that explains the scan less well than the refused fit
    was taken "back" (seattle, every third scan tracked, odometry seed 3: the fit explained all of
    the scan, refused for a correction of 12 degrees, and the place left behind, 2.5 m off, cost
    73.5 against the prediction's 89.9)."""
    if left is None or lost or not rules.refinement.weighs_faults:
        return LeftPlaceDecision(None)
    there = compose(left.pose, between(left.odom, odom))
    # ICP first, as the track is aligned: the field's basin is a few centimetres wide, and the
    # odometry's step can leave the place farther off than that (on acapulco the place left
    # behind after a turned scan, climbed from where the odometry put it, cost 50 where the
    # track's scans cost 17, until the robot was lost).
    aligned = aligned_from(points, there, rules)
    start = aligned.pose if rules.gate.fit_rejection(aligned) == "" else there
    place, cost = climb(points, start, rules.plan, rules.refinement)
    current = scan_cost(points, correction.pose, rules.plan, rules.refinement)
    if not correction.accepted:
        current = min([current, *(scan_cost(points, p, rules.plan, rules.refinement) for p in offered)])
    threshold = fault_cost(rules.refinement.fault_probability)
    if correction.accepted and _within_motion(place, correction.pose, correction.covariance):
        return LeftPlaceDecision(place, cost, current, evidence=left.evidence + current - cost, merged=True)
    own_fault = faulted and motion_covariance is not None and _within_motion(place, there, motion_covariance)
    evidence = left.evidence + current - cost + (threshold if own_fault else 0.0)
    decided = LeftPlaceDecision(place, cost, current, evidence=evidence)
    if evidence > threshold:
        returned = aligned_from(points, place, rules)
        if correction.accepted or rules.gate.fit_rejection(returned) == "":
            return replace(decided, returned=returned)
    elif evidence < -threshold and correction.accepted:
        return decided
    # A scan that fits nothing soundly says nothing of where the place's climb ends.
    return replace(decided, kept=LeftPlace(place if correction.accepted else there, odom, evidence))


def _within_motion(place: Pose, there: Pose, covariance: NDArray[np.float64]) -> bool:
    """Whether `place` lies within the 99.9 % chi-square bound (`CHI2_3_999`) of `there` over
    `covariance` (x, y, yaw: m^2, m rad, rad^2)."""
    d = np.array([place[0] - there[0], place[1] - there[1], wrap_angle(place[2] - there[2])])
    try:
        return float(d @ np.linalg.solve(covariance, d)) <= CHI2_3_999
    except np.linalg.LinAlgError:
        return False
