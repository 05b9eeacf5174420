"""An odometry fault told from the scan: the heading sweep in the plan's likelihood field.

The prediction's covariance (`MotionNoise`) is a Gaussian: it says how far wheel odometry strays
over a motion, and it cannot say that the odometry sometimes strays far more (a wheel slips, the
robot is pushed, a long pause lets a gyro drift; on fhw, scans up to a minute apart, the odometry
turned 9-66 degrees more than the robot did on 16 of 243 updates). From a prediction 18 degrees
off, ICP settles in the wrong basin and reports it with a 2 cm deviation; under the Gaussian the
true pose, 7 of its standard deviations away, is less probable than that wrong fit, whatever the
scan says. A particle filter survives such steps only when its motion noise happens to have
spread particles that far.

The motion model here is a max-mixture (Olson and Agarwal, "Inference on networks of mixtures for
robust robot mapping", 2013): the Gaussian, or with probability `fault_probability` per update a
fault that leaves the pose anywhere near the prediction. Under the fault component a place costs
`F = -2 ln(fault_probability)` in the units of the refinement's cost (`w sum (1 - g)^2`, see
`posterior_refinement`), wherever it lies. So a place beyond the Gaussian's reach is more probable
than the update's own fit when the scan's cost there is lower by more than `F`; that can only
happen when the fit's cost exceeds the track's typical cost (the median of the last accepted
updates that were not themselves that far above it, `CostHistory`) by `F`, and only then is the
sweep run (a few updates in a hundred on the real logs, none on most). A place the sweep finds
is a fault found only when it also explains the scan as the track's scans are (its cost within
`F` of the typical one): a place merely less bad than the fit is no evidence of where the robot
is.

The sweep climbs the likelihood field (no prior) from the prediction's position turned by every
`FAULT_HEADING_STEP` within `fault_heading_window` either way, and then once more, fully, from the
best end. The window stays below 45 degrees, half of the 90-degree turn that maps most buildings'
rooms onto one another, so it cannot settle in a rotated copy of the room; a climb's end turned
beyond it is not a place the sweep finds (a climb with no prior can slide along a corridor and
turn with it: on orebro one from 24 degrees off the prediction ended 5 m along the corridor,
turned by 180 degrees, where the corridor fits the scan reversed), nor one the step cannot have
left the robot at by turning more than the robot or slipping (`within_fault`: beyond the sector
the reported motion sweeps from the last pose), and when the full climb leaves them, the best
end of the sweep's climbs is the place. The search stage takes what it finds at once, the
posterior's mode, and keeps the prediction it leaves as a second hypothesis that the next scans
weigh (`planicp.tracking.stages.left_place`): a scan turned within the window fits a turned place
as a fault's scan fits the true one, and only the scans after tell them apart.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose
from ..plans.plan_map import PlanMap
from ..se2 import between, compose, inverse, wrap_angle
from .acceptance_gate import AcceptanceGate
from .icp_result import IcpResult
from .posterior_refinement import NO_PRIOR_VARIANCE, PosteriorRefinement, Refinement, refine_pose

FAULT_HEADING_STEP = math.radians(6.0)
"""Radians between the sweep's starting headings: a climb from a heading within a few degrees of
a mode reaches it (on fhw, starts 3 to 12 degrees apart ended at the same pose)."""

SWEEP_POINTS = 64
"""Most returns each climb of the sweep reads (every k-th of the scan); the best end is climbed
again with all of them."""

SWEEP_ITERATIONS = 10
"""Levenberg-Marquardt steps of each climb of the sweep."""

HISTORY = 20
"""Accepted updates whose costs make the track's typical cost (their median)."""

MIN_HISTORY = 3
"""Accepted updates needed before a typical cost is known (before, no sweep runs): the fewest
whose median one outlier cannot carry beyond the range of the others. (With every other of fhw's
scans tracked, a 33-degree fault at the fifth update, before a fifth cost, went unswept on every
odometry draw: 25 to 116 updates off; docs/benchmarks.md, "Sparser scans".)"""

_NO_PRIOR = (np.eye(3) * NO_PRIOR_VARIANCE).tolist()


def fault_cost(fault_probability: float) -> float:
    """`F = -2 ln(fault_probability)`: what a place costs under the fault component."""
    return -2.0 * math.log(fault_probability)


class CostHistory:
    """The scan's cost in the likelihood field (no prior) at the last `HISTORY` accepted poses,
    and the odometry pose (T_odom_base) of the last of them."""

    def __init__(self) -> None:
        self._costs: deque[float] = deque(maxlen=HISTORY)
        self._odom: Pose | None = None

    def record(self, cost: float, odom: Pose | None = None, threshold: float = math.inf) -> None:
        """Adds the cost at an accepted pose, whose update received the odometry pose `odom`,
        unless it exceeds the typical cost by more than `threshold` (the fault cost: a scan far
        worse explained than the track's, accepted because no place explained it better, says
        what a corrupted scan costs, not what the track's scans do); the pose is the last
        accepted one either way."""
        typical = self.typical()
        if typical is None or cost <= typical + threshold:
            self._costs.append(float(cost))
        self._odom = odom

    def clear(self) -> None:
        """Forgets every cost (the robot was placed anew)."""
        self._costs.clear()
        self._odom = None

    def motion_since(self, odom: Pose, otherwise: Pose) -> Pose:
        """The odometry motion from the last accepted pose's update to the odometry pose `odom`
        (base frame at its start): the steps a fault may lie in, since the updates after it held
        their predictions. `otherwise` when no accepted pose is recorded."""
        return otherwise if self._odom is None else between(self._odom, odom)

    def typical(self) -> float | None:
        """Median of the recorded costs; None before `MIN_HISTORY` are recorded."""
        if len(self._costs) < MIN_HISTORY:
            return None
        return statistics.median(self._costs)  # numpy's median of 20 costs takes 25 times as long


def scan_cost(points: NDArray[np.float64], pose: Pose, plan: PlanMap, rule: PosteriorRefinement) -> float:
    """The scan's cost `w sum (1 - g)^2` in the plan's likelihood field at `pose` (no prior)."""
    p = (float(pose[0]), float(pose[1]), float(pose[2]))
    return float(plan.likelihood_field().cost(points, p, p, _NO_PRIOR, rule.return_weight))


def climb(points: NDArray[np.float64], start: Pose, plan: PlanMap, rule: PosteriorRefinement) -> tuple[Pose, float]:
    """The mode of the scan's likelihood in the plan's field (no prior) that a climb from `start`
    reaches (`rule.max_iterations` Levenberg-Marquardt steps), and the scan's cost there."""
    s = (float(start[0]), float(start[1]), float(start[2]))
    end, cost, _, _, _ = plan.likelihood_field().refine(
        points, s, s, _NO_PRIOR, rule.return_weight, rule.max_iterations
    )
    return (float(end[0]), float(end[1]), wrap_angle(float(end[2]))), float(cost)


@dataclass(frozen=True)
class FaultSweep:
    """What the sweep found (see the module).

    Attributes:
        pose: the place of lowest cost the sweep reached, T_map_base.
        cost: the scan's cost there (no prior).
        current_cost: the scan's cost at the update's own pose (its fit, or the prediction).
        typical: the track's typical cost (`CostHistory.typical`).
        threshold: `F`, what the place's cost must undercut `current_cost` by.
    """

    pose: Pose
    cost: float
    current_cost: float
    typical: float
    threshold: float

    @property
    def more_probable(self) -> bool:
        """Whether the place, as a fault, is more probable than the update's own pose, and
        explains the scan as the track's scans are explained (its cost within the fault cost of
        the typical one). A place that is only less bad (a climb that turned the heading right
        but stayed 20 cm along a corridor, where the field's narrow basin could not reach the
        truth) is no fault found: taken, it held the track 20 cm off with a 1 cm deviation."""
        return self.cost + self.threshold < self.current_cost and self.cost <= self.typical + self.threshold


def sweep_for_fault(
    points: NDArray[np.float64],
    predicted: Pose,
    current: Pose,
    plan: PlanMap,
    rule: PosteriorRefinement,
    history: CostHistory,
    motion: Pose,
    tolerance: float,
) -> FaultSweep | None:
    """The sweep around `predicted` when the scan's cost at `current` (the update's fit, or the
    prediction) exceeds the track's typical cost by the fault cost; None when it does not, when
    no typical cost is known yet, or when the rule weighs no faults (`weighs_faults`).

    Args:
        points: (N, 2) scan points in the robot frame, metres.
        predicted: the odometry prediction, T_map_base.
        current: the pose the update goes on with so far, T_map_base.
        plan: the plan (its `likelihood_field`).
        rule: the refinement's settings (`return_weight`, `fault_probability`,
            `fault_heading_window`).
        history: the track's recent costs.
        motion: the odometry motion (base frame at its start) that moved the last accepted pose
            to `predicted` (`CostHistory.motion_since`).
        tolerance: metres a place may lie from the motion's sector (`within_fault`).
    """
    if not rule.weighs_faults:
        return None
    typical = history.typical()
    if typical is None:
        return None
    threshold = fault_cost(rule.fault_probability)
    current_cost = scan_cost(points, current, plan, rule)
    if current_cost <= typical + threshold:
        return None
    found = fault_place(points, predicted, plan, rule, motion, tolerance)
    if found is None:  # every climb turned or slid out of reach: no fault the model allows
        return FaultSweep(current, current_cost, current_cost, typical, threshold)
    pose, cost = found
    return FaultSweep(pose, cost, current_cost, typical, threshold)


def fault_place(
    points: NDArray[np.float64],
    predicted: Pose,
    plan: PlanMap,
    rule: PosteriorRefinement,
    motion: Pose,
    tolerance: float,
) -> tuple[Pose, float] | None:
    """The place of lowest cost (T_map_base) the climbs of the sweep reach within the fault
    model, and the scan's cost there: the climbs from `fault_starts` on `SWEEP_POINTS` of the
    returns, and the best end climbed again with all of them (that end itself when the full
    climb leaves the model). None when every climb ends beyond it (`within_fault`). Arguments as
    for `sweep_for_fault`."""
    field = plan.likelihood_field()
    step = max(1, -(-len(points) // SWEEP_POINTS))
    sparse = np.ascontiguousarray(points[::step])
    best: tuple[float, tuple[float, float, float]] | None = None
    for start in fault_starts(predicted, motion, rule.fault_heading_window, tolerance):
        end, cost, _, _, _ = field.refine(sparse, start, start, _NO_PRIOR, rule.return_weight, SWEEP_ITERATIONS)
        if within_fault(end, predicted, motion, rule, tolerance) and (best is None or cost < best[0]):
            best = (cost, end)
    if best is None:
        return None
    pose, cost = climb(points, best[1], plan, rule)
    if not within_fault(pose, predicted, motion, rule, tolerance):
        pose = (float(best[1][0]), float(best[1][1]), wrap_angle(float(best[1][2])))
        cost = scan_cost(points, pose, plan, rule)
    return pose, cost


def fault_starts(predicted: Pose, motion: Pose, window: float, reach: float) -> list[Pose]:
    """Where the sweep's climbs start (T_map_base): at every `FAULT_HEADING_STEP` of heading error
    within `window` radians either way, the places the robot is at when the odometry's heading
    went wrong by that much at the end of `motion` (the predicted position), halfway through it,
    or at its start (the whole drive turned about the last pose, `predicted` composed with the
    inverse of `motion`): a climb reaches a mode only from within a few tenths of a metre, and a
    fault early in a long step leaves the robot metres from the predicted position (on fhw with
    every third scan tracked, a 39-degree fault over a 1.9 m step, 1.7 m). A start within `reach`
    metres of one already made at its heading is left out."""
    last = compose(predicted, inverse(motion))
    dx, dy = float(predicted[0]) - last[0], float(predicted[1]) - last[1]
    turns = int(window // FAULT_HEADING_STEP)
    starts: list[Pose] = []
    for k in range(-turns, turns + 1):
        turn = k * FAULT_HEADING_STEP
        c, s = math.cos(turn), math.sin(turn)
        made: list[tuple[float, float]] = []
        for share in (1.0, 0.5, 0.0):  # of the drive before the heading went wrong
            x = last[0] + share * dx + (1.0 - share) * (c * dx - s * dy)
            y = last[1] + share * dy + (1.0 - share) * (s * dx + c * dy)
            if all(math.hypot(x - a, y - b) > reach for a, b in made):
                made.append((x, y))
                starts.append((x, y, float(predicted[2]) + turn))
    return starts


@dataclass(frozen=True)
class MixtureModes:
    """The two modes the max-mixture motion model weighs for a place beyond the prediction.

    Attributes:
        faulted: the mode of the scan's likelihood (no prior) a climb from the place reaches:
            the odometry faulted, and the prediction is no evidence.
        held: the mode a climb from the prediction reaches under the prediction's Gaussian: it
            did not.
        threshold: `F`, what the fault component costs.
    """

    faulted: Refinement
    held: Refinement
    threshold: float

    @property
    def fault_preferred(self) -> bool:
        """Whether the faulted mode is the more probable: its cost plus `F` below the held one's."""
        return self.faulted.cost + self.threshold < self.held.cost


def mixture_modes(
    points: NDArray[np.float64],
    place: Pose,
    predicted: Pose,
    predicted_covariance: NDArray[np.float64],
    plan: PlanMap,
    rule: PosteriorRefinement,
) -> MixtureModes:
    """The faulted and held modes (see `MixtureModes`) for `place` and the prediction `predicted`
    (T_map_base) with its 3x3 covariance, in the plan's likelihood field."""
    faulted = refine_pose(points, place, plan, None, rule)
    return with_held_mode(faulted, points, predicted, predicted_covariance, plan, rule)


def with_held_mode(
    faulted: Refinement,
    points: NDArray[np.float64],
    predicted: Pose,
    predicted_covariance: NDArray[np.float64],
    plan: PlanMap,
    rule: PosteriorRefinement,
) -> MixtureModes:
    """`mixture_modes` for a faulted mode already climbed (`refine_pose` with no prior): the held
    mode is climbed only when the faulted one is worth weighing."""
    held = refine_pose(points, predicted, plan, ("prediction", predicted, predicted_covariance), rule)
    return MixtureModes(faulted, held, fault_cost(rule.fault_probability))


def holds_as_fault(
    fit: IcpResult, predicted: Pose, motion: Pose, rule: PosteriorRefinement, gate: AcceptanceGate
) -> bool:
    """Whether ICP's `fit` from a place the sweep found (`fault_place`) is the fault's place of the
    update whose odometry `motion` moved the last pose to `predicted` (T_map_base): it passes
    `gate`'s bars on the fit (not its bar on the correction, which a fault exceeds) and stays
    within the fault model to the gate's correction limit (`within_fault`)."""
    tolerance = gate.max_translation_jump
    return gate.fit_rejection(fit) == "" and within_fault(fit.pose, predicted, motion, rule, tolerance)


def within_fault(pose: Pose, predicted: Pose, motion: Pose, rule: PosteriorRefinement, tolerance: float) -> bool:
    """Whether `pose` (T_map_base) is a place the fault component covers, for the update whose
    odometry `motion` (base frame at its start) moved the last pose to `predicted`: the odometry
    turned more than the robot did (`rule.fault_heading_window` either way) or its wheels slipped
    (the robot moved less than it reports, down to not at all). So the robot's heading is within
    the window of `predicted`'s, and its position within `tolerance` metres (the acceptance gate's
    correction limit: what a sound fit may correct without a search) of the sector the motion
    sweeps from the last pose: up to the motion's length, in directions within the window of the
    motion's. A place behind the last pose, or beyond the motion's reach, is a look-alike, not the
    step's fault (on orebro, swapped scan sets, a climb slid 6.2 m back along a corridor, behind
    the last pose, after a 5 m step, and the next scan confirmed it)."""
    window = rule.fault_heading_window
    if abs(wrap_angle(float(pose[2]) - float(predicted[2]))) > window:
        return False
    last = compose(predicted, inverse(motion))
    length = math.hypot(float(motion[0]), float(motion[1]))
    qx, qy = float(pose[0]) - last[0], float(pose[1]) - last[1]
    r = math.hypot(qx, qy)
    if length < 1e-9:
        return r <= tolerance
    heading = last[2] + math.atan2(float(motion[1]), float(motion[0]))
    off = wrap_angle(math.atan2(qy, qx) - heading)
    if abs(off) <= window:
        return r - length <= tolerance
    edge = heading + math.copysign(window, off)  # the sector's nearer side, a segment from `last`
    along = min(max(qx * math.cos(edge) + qy * math.sin(edge), 0.0), length)
    return math.hypot(qx - along * math.cos(edge), qy - along * math.sin(edge)) <= tolerance
