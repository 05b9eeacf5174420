"""Returns in front of the plan's walls: people, furniture and robots between the sensor and a wall.

Each return is compared with the range at which a beam from the predicted pose, in the same
direction, meets the plan's walls (ray cast through the plan's raster). A return more than
`margin` metres short of that expected range is something the plan does not show, standing in
front of a wall, and is left out of the alignment. Nearest-neighbour outlier rejection cannot do
this when the obstacle stands near a wall, or when obstacles are most of the scan: with 63 % of
the returns on a crowd, trimming alone lost track (4.6 m RMS over five drives) while the
`Localizer`'s defaults, this rule among them, kept 0.35 cm (`benches/crowd.py`).

It needs a trustworthy prediction: it is only applied when the predicted position's 3-sigma
uncertainty is below `margin`, and when enough returns remain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from . import _core
from ._validation import Pose, positive, whole_number
from .plan_map import PlanMap
from .plan_raster import PlanRaster


@dataclass(frozen=True)
class OcclusionRule:
    """When a return counts as standing in front of a plan wall.

    Attributes:
        margin: metres a return must fall short of the expected wall range to be left out (> 0);
            also the largest 3-sigma position uncertainty of the prediction for the rule to apply.
        beams: directions the expected ranges are cast in, over the full circle (>= 8).
        min_points: fewest returns that must remain; otherwise the whole scan is used (>= 3).
    """

    margin: float = 0.2
    beams: int = 1440
    min_points: int = 50

    def __post_init__(self) -> None:
        positive(self.margin, "margin", "metres")
        whole_number(self.beams, "beams", 8, 1 << 20)
        whole_number(self.min_points, "min_points", 3)


class OcclusionFilter:
    """`OcclusionRule` applied to a plan (the plan's walls rasterised once)."""

    def __init__(self, plan: PlanMap, rule: OcclusionRule) -> None:
        raster = plan.raster
        if raster is None or raster.origin[2] != 0.0:
            raster = PlanRaster.from_points(plan.points, plan.raster_resolution)
        self.rule = rule
        # Rows of the native grid grow with +y; images put the top row first.
        self._grid = _core.OccupancyGrid(np.ascontiguousarray(raster.walls[::-1]), raster.resolution,
                                         (raster.origin[0], raster.origin[1]))

    def in_front(self, points: NDArray[np.float64], pose: Pose) -> NDArray[np.bool_]:
        """(N,) bool: which base-frame `points` lie more than `margin` short of the plan's wall in
        their direction from `pose` (T_map_base). Directions are measured from the base origin: a
        return on a wall lies on the wall whatever the ray's origin, so the laser's mount does not
        matter."""
        return self.classify(points, pose)[0]

    def classify(self, points: NDArray[np.float64], pose: Pose) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """(in front, beyond): which base-frame `points` lie more than `margin` short of the plan's
        wall in their direction from `pose` (see `in_front`), and which lie more than `margin`
        beyond it: returns a beam could not give from `pose`, since the wall would have stopped it.
        One cast serves both."""
        rule = self.rule
        if len(points) == 0:
            return np.zeros(0, dtype=bool), np.zeros(0, dtype=bool)
        step = 2.0 * math.pi / rule.beams
        ranges = np.hypot(points[:, 0], points[:, 1])
        k = np.round((np.arctan2(points[:, 1], points[:, 0]) + math.pi) / step).astype(np.int64) % rule.beams
        # Beam j looks along base angle -pi + j step. Only the arc the returns span (and one beam on
        # either side) is cast: from the end of the widest gap between the returns' beams round to
        # its start, a quarter less for a 270-degree scan.
        first, count = _spanned_arc(k, rule.beams)
        expected = np.full(rule.beams, np.inf)
        # The yaw as the beams' angle_min offset; the arc may wrap past +pi.
        cast = self._grid.cast((pose[0], pose[1], pose[2]), -math.pi + first * step, step, count, 0.0, 1e6)
        expected[(first + np.arange(count)) % rule.beams] = np.where(np.isfinite(cast), cast, np.inf)
        # At a wall's edge a return may belong to either neighbouring beam: in front of the farthest
        # of the three nearest beams' walls, beyond the nearest.
        around = [expected[(k - 1) % rule.beams], expected[k], expected[(k + 1) % rule.beams]]
        short: NDArray[np.bool_] = ranges < np.maximum.reduce(around) - rule.margin
        beyond: NDArray[np.bool_] = ranges > np.minimum.reduce(around) + rule.margin
        return short, beyond


def _spanned_arc(beams_used: NDArray[np.int64], beams: int) -> tuple[int, int]:
    """(first beam, count): the shortest arc of beams (indices mod `beams`) that covers every
    index in `beams_used` and one beam on either side."""
    used = np.flatnonzero(np.bincount(beams_used, minlength=beams))
    if len(used) == 0:
        return 0, 0
    gaps = np.diff(np.append(used, used[0] + beams))
    widest = int(np.argmax(gaps))
    if gaps[widest] <= 3:
        return 0, beams
    first = int(used[(widest + 1) % len(used)]) - 1
    count = beams - int(gaps[widest]) + 3
    return first % beams, min(count, beams)
