"""The corrected pose refined to the pose of highest posterior in the plan's likelihood field.

ICP pairs each return with its nearest plan point and keeps the pairs within a shrinking distance.
On a map whose walls are bands of noisy cells (a SLAM map), the pairs it keeps decide where it
stops: on freiburg-campus a long wall and a few returns 30 m away let it slide along the wall to a
minimum 0.3-0.6 m off, which it reports with a 2 cm deviation; the scan's likelihood there is far
below the true pose's (docs/design.md, "The pose of highest posterior"). A particle filter is not
misled there: it weighs poses by the likelihood of the whole scan in a likelihood field, and by
the motion model.

`refine_pose` does that weighing for the one pose tracking keeps: it climbs (Levenberg-Marquardt,
`planicp._core.LikelihoodGrid.refine`)

    cost(x) = w sum_i (1 - g(T_x s_i))^2 + (x - x_p)^T P^-1 (x - x_p)

`g` the plan's likelihood field (`PlanMap.likelihood_field`), `w` the weight of one return
(`PosteriorRefinement.return_weight`), `(x_p, P)` the prior, from two places: the corrected pose and
the prior's pose. The cost has a mode in each basin the scan fits, and one climb finds only the
mode of the basin it starts in: ICP, having slid to a wrong basin, would leave the climb from its
pose there, however much less probable that basin is than the one the prediction lies in. Of the
two climbs' ends the one of lower cost, the higher posterior, is taken (both when they end in the
same basin: the same pose). Where the fit was fused with the
odometry prediction, and where the fit is degenerate (the field says nothing along a corridor),
the prediction is the prior; where the fusion judged the odometry to have faulted and the scan
constrains every direction, the prediction is no evidence and the scan's likelihood alone
decides. A search's place is not refined (its own alignment decided it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass as pydantic_dataclass

from .._settings import SETTINGS, Flag, Real, Settings, Whole
from .._validation import Pose
from ..plans.plan_map import PlanMap
from ..se2 import wrap_angle

NO_PRIOR_VARIANCE = 1e6
"""Variance (m^2, rad^2) of the prior where the prediction is no evidence: none in practice."""


@pydantic_dataclass(frozen=True, config=SETTINGS)
class PosteriorRefinement(Settings):
    """Whether and how a corrected pose is refined in the plan's likelihood field.

    Attributes:
        enabled: refine (True) or keep the corrected pose as the fusion made it.
        return_weight: the weight of one return's residual: the returns of one scan are not
            independent measurements (their errors come from the same wall drawn a little off,
            the same pose), and a scan of 300 returns weighed as 300 would overrule any prior;
            0.3 weighs a scan of 300 returns as about 90, as a particle filter that scores
            60-100 of a scan's beams does.
        max_iterations: most Levenberg-Marquardt steps taken.
        fault_probability: the chance, per update, that the odometry strayed far beyond its
            motion noise (the fault component of the motion model, see
            `planicp.tracking.odometry_fault`): a place the scan fits better than the update's
            own pose by `-2 ln(fault_probability)` (13.8 at 1e-3) is searched for and taken,
            the pose it leaves weighed by the next scans; a fit beyond the prediction's
            covariance is weighed against the prediction's surroundings by as much. 0 turns
            both off.
        fault_heading_window: how far either way of the predicted heading that search starts
            its climbs and the place it finds may lie, radians (below 45 degrees: a building's
            rooms map onto one another by 90-degree turns).
    """

    enabled: Flag = True
    return_weight: Annotated[float, Real(gt=0.0, le=1.0)] = 0.3
    max_iterations: Annotated[int, Whole(ge=1, le=1000)] = 30
    fault_probability: Annotated[float, Real(ge=0.0, lt=1.0, note="(0 disables it)")] = 1e-3
    fault_heading_window: Annotated[float, Real(ge=0.0, lt=math.pi / 4.0, unit="radians")] = math.radians(44.0)

    @property
    def weighs_faults(self) -> bool:
        """Whether the motion model's fault component is in use: the refinement runs (its field is
        what a fault is judged in) and `fault_probability` is above 0."""
        return self.enabled and self.fault_probability > 0.0


@dataclass(frozen=True)
class Refinement:
    """The corrected pose refined in the plan's likelihood field (part of stage 6).

    Attributes:
        start: the corrected pose it started from, T_map_base.
        pose: the refined pose, T_map_base.
        prior: "prediction" (the fit was fused with it, or is degenerate) or "none" (the
            odometry faulted and the scan constrains every direction).
        cost, start_cost: the cost (see the module) at `pose` and at `start`.
        iterations: accepted Levenberg-Marquardt steps of the climb that ended at `pose`.
        from_prior: whether `pose` is the end of the climb from the prior's pose (True) or of
            the climb from `start` (False).
    """

    start: Pose
    pose: Pose
    prior: str
    cost: float
    start_cost: float
    iterations: int
    from_prior: bool = False

    @property
    def moved(self) -> float:
        """How far the refinement moved the position, metres."""
        return math.hypot(self.pose[0] - self.start[0], self.pose[1] - self.start[1])


def refine_pose(
    points: NDArray[np.float64],
    start: Pose,
    plan: PlanMap,
    prior: tuple[str, Pose, NDArray[np.float64]] | None,
    rule: PosteriorRefinement,
) -> Refinement:
    """The pose of lowest cost of two climbs, from `start` and from the prior's pose (see the module).

    Args:
        points: (N, 2) scan points in the robot frame, metres.
        start: the corrected pose, T_map_base.
        plan: the plan (its `likelihood_field`).
        prior: (name, pose, 3x3 covariance) of the prior; None: no prior.
        rule: the refinement's settings.
    """
    field = plan.likelihood_field()
    if prior is None:
        name, prior_pose, prior_covariance = "none", start, np.eye(3) * NO_PRIOR_VARIANCE
    else:
        name, prior_pose, prior_covariance = prior
    covariance = np.asarray(prior_covariance, dtype=np.float64).tolist()
    pose, cost, start_cost, _, iterations = field.refine(
        points, start, prior_pose, covariance, rule.return_weight, rule.max_iterations
    )
    from_prior = False
    if prior is not None and _apart(prior_pose, start):
        other, other_cost, _, _, other_iterations = field.refine(
            points, prior_pose, prior_pose, covariance, rule.return_weight, rule.max_iterations
        )
        if other_cost < cost:
            pose, cost, iterations, from_prior = other, other_cost, other_iterations, True
    refined: Pose = (float(pose[0]), float(pose[1]), wrap_angle(float(pose[2])))
    return Refinement(start, refined, name, float(cost), float(start_cost), int(iterations), from_prior)


def _apart(a: Pose, b: Pose) -> bool:
    """Whether two poses are far enough apart (1 mm, 0.1 mrad) for their climbs to differ."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) > 1e-3 or abs(wrap_angle(a[2] - b[2])) > 1e-4
