"""The plan's scale from the robot's own first scans: a 1-D search over scale, then refined.

A plan read at a guessed metres per pixel is the building scaled by some `k` (plan / world) about
the map origin. Scans scaled by the same `k` about the robot fit it exactly; so `estimate_scale`
tracks the first scans, chained by their odometry (its translations scaled by `k` too, since the
plan's metres are `k` of the world's), from the given start pose with the existing alignment
(`planicp.localize`) for each candidate `k` of a grid, and scores each candidate by the share of
the scans' returns the plan explains (the alignment's inlier ratio) and their RMSE. The best
candidate is then refined with the scans' own evidence: at the tracked poses, the similarity fit of
each scan (`scale_evidence.scale_fit`) measures how far the scans still are from fitting; the
median of those errors corrects `k`, and the scans are tracked again at the corrected `k` until
the correction is below 1e-4. The grid gives the basin (a plan 20 % off is tracked nowhere near
the truth at `k = 1`), the refinement the precision (a tenth of a percent in simulation).

The result's `factor` is 1 / k: multiply the plan by it (`PlanMap.scaled(factor)`, or read the
image at `resolution * factor`) to make it true to the building. Metres, map frame, T_map_base.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose, as_points, as_pose
from ..plans.plan_map import PlanMap
from ..se2 import between, compose
from .acceptance_gate import AcceptanceGate
from .icp_config import IcpConfig
from .localize import localize
from .scale_evidence import WallLookup, scale_fit

DEFAULT_RATIOS = tuple(round(0.80 + 0.02 * i, 2) for i in range(24))
"""Plan / world scales the search tries by default: 0.80 to 1.26 in steps of 2 % (a plan read at a
resolution guessed within a fifth)."""

MAX_REFINEMENTS = 4
"""Most refinement rounds (each tracks the scans once more)."""


@dataclass(frozen=True)
class ScaleCandidate:
    """How well the scans, scaled as one candidate says, fit the plan.

    Attributes:
        factor: the candidate's correction of the plan (1 / its plan-to-world scale).
        explained: mean share of the scans' returns within the alignment's
            `max_correspondence_distance` of the plan (the inlier ratio), in [0, 1].
        rmse: median over the scans of the inliers' RMS distance to the plan, metres.
        fitted: scans whose fit the acceptance gate passed (the others followed the odometry).
    """

    factor: float
    explained: float
    rmse: float
    fitted: int


@dataclass(frozen=True)
class ScaleSearch:
    """The plan's scale as the first scans measure it (`estimate_scale`).

    Attributes:
        factor: multiply the plan's coordinates by this (`plan.scaled(factor)`, or read its image
            at `resolution * factor`) to make it true to the building.
        std: its standard deviation, from the spread of the scans' own scale errors at the
            refined scale (1.4826 MAD / sqrt(scans measured)), not less than 1e-4.
        candidates: every candidate of the grid, in the order tried, with how well it explained
            the scans, then the refined scales.
        scans: scans whose scale error was measured at the refined scale.
    """

    factor: float
    std: float
    candidates: tuple[ScaleCandidate, ...]
    scans: int

    @property
    def best(self) -> ScaleCandidate:
        """The candidate of the grid that explained the scans best."""
        return max(self.candidates, key=lambda c: (round(c.explained, 3), -c.rmse))


def estimate_scale(
    plan: PlanMap,
    scans: Sequence[Any],
    odometry: Any,
    initial_pose: Any,
    *,
    ratios: Sequence[float] = DEFAULT_RATIOS,
    config: IcpConfig | None = None,
    gate: AcceptanceGate | None = None,
) -> ScaleSearch:
    """The factor that makes `plan` true to the building, from the robot's first scans.

    Args:
        plan: the plan whose scale is in doubt.
        scans: the first scans, each (N, 2) points in the base frame, metres (10 to 50 scans
            driven over a few metres; more scans, more walls, a better estimate).
        odometry: (K, 3) odometry poses T_odom_base at the scans' times (metres, radians), one per
            scan: the scans are chained by their odometry motion.
        initial_pose: (x, y, yaw) of the robot at the first scan in the plan's map frame
            (where the drawing shows the robot: in the plan's own, possibly wrong, metres).
        ratios: plan / world scales tried (> 0); the best one is refined.
        config: ICP settings of the alignments (None: `IcpConfig.for_tracking(plan)`).
        gate: which fits are followed (None: `AcceptanceGate()`); the others follow the odometry.

    Returns:
        A `ScaleSearch`: `factor`, its `std`, and how well each candidate explained the scans.

    Raises:
        TypeError, ValueError: a malformed scan, pose or odometry, fewer than 3 scans, scans and
            odometry of different lengths, or no candidate ratio.
    """
    if not isinstance(plan, PlanMap):
        raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
    points = [as_points(scan, f"scans[{i}]") for i, scan in enumerate(scans)]
    odom = np.asarray(odometry, dtype=np.float64)
    if odom.ndim != 2 or odom.shape[1] != 3 or len(odom) != len(points):
        raise ValueError(
            f"odometry must be ({len(points)}, 3) poses (x, y, yaw), one per scan, got shape {odom.shape}: "
            "give the odometry pose at each scan's time"
        )
    if len(points) < 3:
        raise ValueError(f"need at least 3 scans to estimate a scale, got {len(points)}: give the first 10 to 50")
    if not np.isfinite(odom).all():
        raise ValueError("odometry holds NaN or infinite values")
    start = as_pose(initial_pose, "initial_pose")
    grid = [float(r) for r in ratios]
    if not grid or not all(math.isfinite(r) and r > 0.0 for r in grid):
        raise ValueError(f"ratios must be finite plan / world scales > 0, got {list(ratios)!r}")
    config = config if config is not None else IcpConfig.for_tracking(plan)
    gate = gate if gate is not None else AcceptanceGate()
    motions = [between(_pose(odom[i - 1]), _pose(odom[i])) for i in range(1, len(odom))]
    lookup = WallLookup(plan)

    tried: list[ScaleCandidate] = []
    for ratio in grid:
        candidate, _ = _track(plan, points, motions, start, ratio, config, gate, None)
        tried.append(candidate)
    best = max(tried, key=lambda c: (round(c.explained, 3), -c.rmse))
    ratio = 1.0 / best.factor
    errors: NDArray[np.float64] = np.zeros(0)
    for _ in range(MAX_REFINEMENTS):
        candidate, errors = _track(plan, points, motions, start, ratio, config, gate, lookup)
        if not len(errors):
            break
        correction = float(np.median(errors))
        ratio *= 1.0 + correction
        tried.append(ScaleCandidate(1.0 / ratio, candidate.explained, candidate.rmse, candidate.fitted))
        if abs(correction) < 1e-4:
            break
    n = len(errors)
    spread = 1.4826 * float(np.median(np.abs(errors - np.median(errors)))) if n else math.inf
    factor = 1.0 / ratio
    std = max(factor * spread / math.sqrt(n), 1e-4) if n else math.inf
    return ScaleSearch(factor, std, tuple(tried), n)


def _pose(row: NDArray[np.float64]) -> Pose:
    return (float(row[0]), float(row[1]), float(row[2]))


def _track(
    plan: PlanMap,
    scans: list[NDArray[np.float64]],
    motions: list[Pose],
    start: Pose,
    ratio: float,
    config: IcpConfig,
    gate: AcceptanceGate,
    lookup: WallLookup | None,
) -> tuple[ScaleCandidate, NDArray[np.float64]]:
    """The scans scaled by `ratio` tracked from `start` by their odometry scaled alike; with a
    `lookup`, the scale error each sound fit still shows."""
    pose = start
    explained, rmse, errors = [], [], []
    fitted = 0
    for i, scan in enumerate(scans):
        if i:
            dx, dy, dyaw = motions[i - 1]
            pose = compose(pose, (dx * ratio, dy * ratio, dyaw))
        scaled = scan * ratio
        result = localize(scaled, plan, pose, config)
        explained.append(result.inlier_ratio)
        if math.isfinite(result.rmse):
            rmse.append(result.rmse)
        if gate.rejection(result, pose):
            continue
        fitted += 1
        pose = result.pose
        if lookup is not None:
            fit = scale_fit(lookup, scaled, pose, 0.3)
            if fit is not None:
                errors.append(fit.error)
    candidate = ScaleCandidate(
        1.0 / ratio, float(np.mean(explained)), float(np.median(rmse)) if rmse else math.inf, fitted
    )
    return candidate, np.asarray(errors, dtype=np.float64)
