"""Returns in front of the plan's walls: people, furniture and robots between the sensor and a wall.

Each return is compared with the range at which a beam from the predicted pose, in the same
direction, meets the plan's walls (one ray cast through the plan's visibility raster, which also
gives the alignment the wall points visible from the prediction). A return more than
`margin` metres short of that expected range is something the plan does not show, standing in
front of a wall, and is left out of the alignment. Nearest-neighbour outlier rejection cannot do
this when the obstacle stands near a wall, or when obstacles are most of the scan: with 63 % of
the returns on a crowd, trimming alone lost track (4.6 m RMS over five drives) while the
`Localizer`'s defaults, this rule among them, kept 0.35 cm (`benches/crowd.py`).

It needs a trustworthy prediction: it is only applied when the predicted position's 3-sigma
uncertainty is below `margin`, and when enough returns remain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from . import _core
from ._validation import Pose, positive, whole_number
from .icp_config import IcpConfig
from .plan_map import PlanMap


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
    """`OcclusionRule` applied to a plan: the expected ranges come from one ray cast through the
    plan's visibility raster (`PlanMap.view_from`), which also gives the alignment its visible
    wall points."""

    def __init__(self, plan: PlanMap, rule: OcclusionRule) -> None:
        self.rule = rule
        self._plan = plan

    def view(self, points: NDArray[np.float64], pose: Pose, config: IcpConfig | None = None) -> _core.WallView:
        """The plan as seen from `pose` (T_map_base), cast in the rule's `beams` directions far
        enough to classify the base-frame `points` (the farthest plus the margin: a direction
        with no wall that near reads inf, which classifies as an uncapped cast would) and, with
        `config`, to align them (`localize(..., view=...)`)."""
        farthest = float(np.sqrt(np.max(np.einsum("ij,ij->i", points, points)))) if len(points) else 0.0
        reach = farthest + self.rule.margin
        if config is not None and len(points):
            reach = max(reach, _core.visibility_range(points, config._native))
        return self._plan._native.view_from((pose[0], pose[1], pose[2]), reach, self.rule.beams)

    def in_front(self, points: NDArray[np.float64], pose: Pose) -> NDArray[np.bool_]:
        """(N,) bool: which base-frame `points` lie more than `margin` short of the plan's wall in
        their direction from `pose` (T_map_base). Directions are measured from the base origin: a
        return on a wall lies on the wall whatever the ray's origin, so the laser's mount does not
        matter."""
        return self.classify(points, pose)[0]

    def classify(self, points: NDArray[np.float64], pose: Pose,
                 view: _core.WallView | None = None) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """(in front, beyond): which base-frame `points` lie more than `margin` short of the plan's
        wall in their direction from `pose` (see `in_front`), and which lie more than `margin`
        beyond it: returns a beam could not give from `pose`, since the wall would have stopped it.
        At a wall's edge a return may belong to either neighbouring direction: it is in front of
        the farthest of the three nearest directions' walls, beyond the nearest. `view`: a view
        from `pose` (see `view`) to reuse instead of casting one."""
        if len(points) == 0:
            return np.zeros(0, dtype=bool), np.zeros(0, dtype=bool)
        if view is None:
            view = self.view(points, pose)
        return view.classify(points, self.rule.margin)
