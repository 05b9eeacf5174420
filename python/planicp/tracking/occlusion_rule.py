"""Returns in front of the plan's walls: people, furniture and robots between the sensor and a wall.

Each return is compared with the range at which a beam from the predicted pose, in the same
direction, meets the plan's walls (ray cast through the plan's raster, natively, over the arc the
scan spans). A return more than
`margin` metres short of that expected range is something the plan does not show, standing in
front of a wall, and is left out of the alignment. Nearest-neighbour outlier rejection cannot do
this when the obstacle stands near a wall, or when obstacles are most of the scan: with 63 % of
the returns on a crowd, trimming alone lost track (4.6 m RMS over five drives) while the
`Localizer`'s defaults, this rule among them, kept 0.32 cm (`benches/crowd.py`, session 5).

It needs a trustworthy prediction: it is applied when the predicted position's 3-sigma
uncertainty is below `margin`, and when enough returns remain. From a less certain prediction the
returns are all aligned first; only where the gate rejects that fit is the rule tried with the
margin widened to the uncertainty (`margin_for`: a return on a wall the robot may be that much
nearer looks that much short of it), and its fit kept only where the plan explains the returns
it kept as soundly as a crowd's (`planicp.tracking.stages.fit`).
"""

from __future__ import annotations

from typing import Annotated

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass

from .. import _core
from .._settings import SETTINGS, Real, Settings, Whole
from .._validation import Pose
from ..plans.plan_map import PlanMap
from ..plans.plan_raster import PlanRaster
from .icp_config import IcpConfig


@dataclass(frozen=True, config=SETTINGS)
class OcclusionRule(Settings):
    """When a return counts as standing in front of a plan wall.

    Attributes:
        margin: metres a return must fall short of the expected wall range to be left out (> 0);
            also the largest 3-sigma position uncertainty of the prediction for the rule to apply
            at once (beyond it, the rule's margin when it is tried, `margin_for`).
        beams: directions the expected ranges are cast in, over the full circle (>= 8).
        min_points: fewest returns that must remain; otherwise the whole scan is used (>= 3).
    """

    margin: Annotated[float, Real(gt=0.0, unit="metres")] = 0.2
    beams: Annotated[int, Whole(ge=8, le=1 << 20)] = 1440
    min_points: Annotated[int, Whole(ge=3)] = 50

    def margin_for(self, position_std: float) -> float:
        """The margin from a prediction whose widest position standard deviation is
        `position_std` metres: `margin`, or 3 `position_std` where that is more."""
        return max(self.margin, 3.0 * position_std)


class OcclusionFilter:
    """`OcclusionRule` applied to a plan. The expected ranges are cast exactly through the plan's
    raster (the plan image, or the wall points rastered), over the arc the returns span.

    (A `WallView`'s own ranges, from the coarser visibility raster, would save this cast, but its
    cells lengthen walls at their ends and put the wall up to half a cell deeper. With them the
    crowd bench at 66 % of the returns blocked went from 0.28 to 0.81 cm RMS over two drives.)
    """

    def __init__(self, plan: PlanMap, rule: OcclusionRule) -> None:
        raster = plan.raster
        if raster is None or raster.origin[2] != 0.0:
            raster = PlanRaster.from_points(plan.points, plan.raster_resolution)
        self.rule = rule
        self._plan = plan
        # Rows of the native grid grow with +y; images put the top row first.
        self._grid = _core.OccupancyGrid(
            np.ascontiguousarray(raster.walls[::-1]), raster.resolution, (raster.origin[0], raster.origin[1])
        )

    def view(self, points: NDArray[np.float64], pose: Pose, config: IcpConfig) -> _core.WallView:
        """The plan as seen from `pose` (T_map_base) over the arc the base-frame `points` span
        (see `PlanMap.view_from`), in each direction as far as one of them could pair with a wall
        when aligned with `config`: its visible points serve `localize(..., view=...)` for the
        KD-tree search."""
        if not len(points):
            return self._plan._native.view_from((pose[0], pose[1], pose[2]), 1.0, self.rule.beams, points, False)
        native = config._native
        return self._plan._native.view_from(
            (pose[0], pose[1], pose[2]),
            _core.visibility_range(points, native),
            self.rule.beams,
            points,
            False,
            _core.largest_pair_distance(native),
        )

    def in_front(self, points: NDArray[np.float64], pose: Pose) -> NDArray[np.bool_]:
        """(N,) bool: which base-frame `points` lie more than `margin` short of the plan's wall in
        their direction from `pose` (T_map_base). Directions are measured from the base origin: a
        return on a wall lies on the wall whatever the ray's origin, so the laser's mount does not
        matter."""
        return self.classify(points, pose)[0]

    def classify(
        self, points: NDArray[np.float64], pose: Pose, margin: float | None = None
    ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """(in front, beyond): which base-frame `points` lie more than `margin` (metres; default
        the rule's) short of the plan's wall in their direction from `pose` (see `in_front`), and
        which lie more than `margin` beyond it: returns a beam could not give from `pose`, since
        the wall would have stopped it.
        At a wall's edge a return may belong to either neighbouring direction: it is in front of
        the farthest of the three nearest directions' walls, beyond the nearest. One native call
        casts the arc the returns span (and one direction either side) and classifies them."""
        if len(points) == 0:
            return np.zeros(0, dtype=bool), np.zeros(0, dtype=bool)
        margin = self.rule.margin if margin is None else margin
        return self._grid.classify_returns((pose[0], pose[1], pose[2]), points, margin, self.rule.beams)
