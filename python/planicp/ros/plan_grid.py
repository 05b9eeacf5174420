"""The plan as a `nav_msgs/OccupancyGrid`, so that RViz and a costmap see the walls planicp aligns to."""

from __future__ import annotations

import numpy as np

from .._validation import positive
from ..mapping.occupancy_grid_message import OccupancyGridMessage
from ..plans.plan_map import PlanMap
from ..plans.plan_raster import PlanRaster


def plan_occupancy_grid(plan: PlanMap, resolution: float = 0.05) -> OccupancyGridMessage:
    """Wall cells 100, every other cell 0 (free), as map_server publishes a plan drawn in black on
    white.

    A plan read from an image or a map_server map keeps its own pixels, resolution and origin
    (including the origin's yaw, which `info.origin` carries). A plan without a raster (points,
    HouseExpo, DXF) is rasterised at `resolution` metres per cell, axis-aligned.

    Returns:
        The grid with row 0 at the origin (lowest y), as `nav_msgs/OccupancyGrid.data` is laid out.
    """
    if not isinstance(plan, PlanMap):
        raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
    raster = plan.raster
    if raster is None:
        raster = PlanRaster.from_points(plan.points, positive(resolution, "resolution", "metres"))
    # Image rows run from the top; the message's rows from the origin (bottom).
    walls = raster.walls[::-1]
    data = np.where(walls, np.int8(100), np.int8(0)).astype(np.int8)
    return OccupancyGridMessage(np.ascontiguousarray(data), raster.resolution, raster.origin)
