"""The corrected pose refined to the posterior's mode (or the mean of its two modes) in the plan's
likelihood field.

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
the prior's pose. `cost` is twice the negative log posterior. It has a mode in each basin the scan
fits, and one climb finds only the mode of the basin it starts in: ICP, having slid to a wrong
basin, would leave the climb from its pose there, however much less probable that basin is than
the one the prediction lies in. So both are climbed, and each end is read in the Laplace
approximation: a Gaussian of covariance `(w J^T J + P^-1)^-1` and of mass
`exp(-cost/2) / sqrt(det(w J^T J + P^-1))`. Where the two Gaussians lie within two standard
deviations of each other (the Mahalanobis distance under their mean covariance), their mixture has
one mode: the climbs found one, and the end of lower cost is the pose. Farther apart, the posterior
has two modes, and the pose is its mean, each mode weighed by its share of the mass; their spread
about the mean is added to the pose's covariance (`Refinement.spread`). The mean is the estimate
of least expected squared error; the mode of lower cost alone would throw the other mode's mass
away. On freiburg-campus a scan whose walls the map drew twice, 0.3 m apart, has a mode at each
drawing (costs 60.1 and 62.3); the lower, 0.33 m from the reference pose, was taken with a 6 cm
deviation, where the mean lies 0.25 m from it with deviations (11.7, 8.9 cm) that cover both. A
mode that costs 10 units more than the other weighs about e^-5 of it, and the mean is the other
mode. Where the fit was fused with the
odometry prediction, and where the fit is degenerate (the field says nothing along a corridor),
the prediction is the prior; where the fusion judged the odometry to have faulted and the scan
constrains every direction, the prediction is no evidence and the scan's likelihood alone
decides (one climb). A search's place is not refined (its own alignment decided it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
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
        pose: the refined pose, T_map_base: the posterior's mode, or the mean of its two modes.
        prior: "prediction" (the fit was fused with it, or is degenerate) or "none" (the
            odometry faulted and the scan constrains every direction).
        cost, start_cost: the cost (see the module) at the mode of lower cost (`pose` where there
            is one mode) and at `start`.
        iterations: accepted Levenberg-Marquardt steps of the climb that ended at that mode.
        from_prior: whether the mode of lower cost is the end of the climb from the prior's pose
            (True) or of the climb from `start` (False).
        other: the other mode, T_map_base, where the two climbs ended in two; else None.
        other_share: the other mode's share of the posterior mass (0 when there is none).
        spread: 3x3 covariance of the two modes about `pose` (zeros when there is one mode),
            m^2 and rad^2: what the correction adds to its covariance.
    """

    start: Pose
    pose: Pose
    prior: str
    cost: float
    start_cost: float
    iterations: int
    from_prior: bool = False
    other: Pose | None = None
    other_share: float = 0.0
    spread: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))

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
    """The posterior's mode, or mean of its two modes, from two climbs: from `start` and from the
    prior's pose (see the module).

    Args:
        points: (N, 2) scan points in the robot frame, metres.
        start: the corrected pose, T_map_base.
        plan: the plan (its `likelihood_field`).
        prior: (name, pose, 3x3 covariance) of the prior; None: no prior.
        rule: the refinement's settings.
    """
    grid = plan.likelihood_field()
    if prior is None:
        name, prior_pose, prior_covariance = "none", start, np.eye(3) * NO_PRIOR_VARIANCE
    else:
        name, prior_pose, prior_covariance = prior
    covariance = np.asarray(prior_covariance, dtype=np.float64).tolist()
    pose, cost, start_cost, information, iterations = grid.refine(
        points, start, prior_pose, covariance, rule.return_weight, rule.max_iterations
    )
    mode = _Mode(_pose(*pose), float(cost), np.asarray(information, dtype=np.float64), int(iterations))
    if prior is None or not _apart(prior_pose, start):
        return Refinement(start, mode.pose, name, mode.cost, float(start_cost), mode.iterations)
    other_pose, other_cost, _, other_information, other_iterations = grid.refine(
        points, prior_pose, prior_pose, covariance, rule.return_weight, rule.max_iterations
    )
    other = _Mode(
        _pose(*other_pose), float(other_cost), np.asarray(other_information, dtype=np.float64), int(other_iterations)
    )
    from_prior = other.cost < mode.cost
    best, second = (other, mode) if from_prior else (mode, other)
    d = np.array(
        [second.pose[0] - best.pose[0], second.pose[1] - best.pose[1], wrap_angle(second.pose[2] - best.pose[2])]
    )
    if not _bimodal(d, best, second):
        return Refinement(start, best.pose, name, best.cost, float(start_cost), best.iterations, from_prior)
    share = _share(second, best)
    mean = _pose(best.pose[0] + share * d[0], best.pose[1] + share * d[1], best.pose[2] + share * d[2])
    spread = share * (1.0 - share) * np.outer(d, d)
    return Refinement(
        start, mean, name, best.cost, float(start_cost), best.iterations, from_prior, second.pose, share, spread
    )


@dataclass(frozen=True)
class _Mode:
    """The end of one climb: its pose (T_map_base), cost, information matrix and steps."""

    pose: Pose
    cost: float
    information: NDArray[np.float64]
    iterations: int


def _bimodal(d: NDArray[np.float64], a: _Mode, b: _Mode) -> bool:
    """Whether the Laplace approximations at two climbs' ends, `d` apart, make two modes: their
    Mahalanobis distance under the mean of their covariances exceeds 2 (a mixture of two like
    Gaussians has two modes only when they lie more than two standard deviations apart). False
    where an information matrix cannot be inverted."""
    try:
        mean_covariance = 0.5 * (np.linalg.inv(a.information) + np.linalg.inv(b.information))
        return float(d @ np.linalg.solve(mean_covariance, d)) > 4.0
    except np.linalg.LinAlgError:
        return False


def _share(second: _Mode, best: _Mode) -> float:
    """`second`'s share of the two modes' posterior mass in the Laplace approximation: each mode's
    mass is `exp(-cost/2) / sqrt(det(information))`. 0 where an information matrix is not
    positive definite (a climb that stopped on a ridge is no mode to weigh)."""
    signs, logdets = zip(*(np.linalg.slogdet(m.information) for m in (second, best)), strict=True)
    if min(signs) <= 0 or not all(math.isfinite(v) for v in logdets):
        return 0.0
    log_ratio = -0.5 * (second.cost - best.cost) - 0.5 * (logdets[0] - logdets[1])
    return 1.0 / (1.0 + math.exp(-log_ratio)) if log_ratio > -700.0 else 0.0


def _pose(x: float, y: float, yaw: float) -> Pose:
    """A pose of floats with its heading wrapped."""
    return (float(x), float(y), wrap_angle(float(yaw)))


def _apart(a: Pose, b: Pose) -> bool:
    """Whether two poses are far enough apart (1 mm, 0.1 mrad) for their climbs to differ."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) > 1e-3 or abs(wrap_angle(a[2] - b[2])) > 1e-4
