"""Stage 7 of `Localizer.update`: the place an adopted jump left behind, weighed against this scan
(`weigh_left_place`).

A place the sweep for an odometry fault or a rejected jump left pending is taken when the next
scan confirms it (stage 3). Two scans that prefer a place tell an odometry fault from nothing
else that looks like one: where a SLAM map's passes disagree by half a metre, a scan fits the
other pass's copy of the walls as well, and on freiburg-campus (odometry seed 8) two scans in a
row preferred it by the fault cost; from the sixth scan after, the scans preferred the place the
track had left by 5-17 cost units, and nothing looked there (docs/limitations.md, "Two scans'
word"). So the place left behind stays a hypothesis: followed with the odometry and climbed to
the mode of each scan's likelihood in the plan's field, it is taken back when a scan prefers it to
the track by the fault cost, and forgotten when a scan prefers the track to it by as much (the
max-mixture's own threshold, `planicp.tracking.odometry_fault`). A true fault's left place, where
the odometry alone would have put the robot, is ruled out at once.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
from ...se2 import between, compose
from ..decisions import Correction, LeftPlaceDecision
from ..odometry_fault import climb, fault_cost, scan_cost
from .fit import aligned_from
from .rules import Rules


def weigh_left_place(
    points: NDArray[np.float64],
    left: tuple[Pose, Pose] | None,
    odom: Pose,
    correction: Correction,
    rules: Rules,
    lost: bool,
) -> LeftPlaceDecision:
    """The place left behind (`left`: the place and the odometry pose it was left at) followed to
    this scan's odometry pose `odom`, climbed in the plan's likelihood field (no prior), and
    weighed against the corrected pose (see the module). An update without an accepted fit, or
    while `lost`, does not judge it: it stays followed (dropped while lost; the recovery looks
    for the robot then). Only where the refinement's field is used and the fault component is
    on (`PosteriorRefinement.weighs_faults`)."""
    if left is None or lost or not rules.refinement.weighs_faults:
        return LeftPlaceDecision(None)
    there = compose(left[0], between(left[1], odom))
    if not correction.accepted:
        return LeftPlaceDecision(None, kept=(there, odom))
    place, cost = climb(points, there, rules.plan, rules.refinement)
    current = scan_cost(points, correction.pose, rules.plan, rules.refinement)
    threshold = fault_cost(rules.refinement.fault_probability)
    if cost + threshold < current:
        return LeftPlaceDecision(place, cost, current, returned=aligned_from(points, place, rules))
    if current + threshold < cost:
        return LeftPlaceDecision(place, cost, current)
    return LeftPlaceDecision(place, cost, current, kept=(place, odom))
