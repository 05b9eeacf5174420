"""The plan as a `nav_msgs/OccupancyGrid`, so that RViz and a costmap see the walls planicp aligns to."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import as_pose, positive
from ..mapping.occupancy_grid_message import OccupancyGridMessage
from ..plans.plan_map import PlanMap
from ..plans.plan_raster import PlanRaster
from ..plans.ros_map import recognised_reading


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


def plan_from_occupancy_grid(
    data: Any, width: int, height: int, resolution: float, origin: Any, occupied: int = 65
) -> PlanMap:
    """The plan in a `nav_msgs/OccupancyGrid` (as map_server publishes a map): cells at or above
    `occupied` (0..100) are walls. The grid is read as `PlanMap.from_ros_map` reads a map whose
    YAML says nothing (`planicp.plans.ros_map.recognised_reading`): a SLAM map, whose occupied
    cells nearly all border free or unknown space, as its cells' centres (and refined in their
    density field); a drawing, most of whose cells lie inside walls of material, as "auto" (the
    centres of walls one or two cells thick, the faces of thicker ones). On the office plan's grid,
    reading every wall cell's centre instead leaves tracking 12 cm off after a global localization,
    as each room seems a cell wider than it is.

    Args:
        data: the `width * height` cell values, row 0 at the origin (lowest y), -1 unknown.
        width: cells per row.
        height: rows.
        resolution: metres per cell.
        origin: (x, y, yaw) of the grid's lower-left corner in the map frame.
        occupied: the lowest value that is a wall (map_server: 65 for an occupied threshold of 0.65).

    Raises:
        ValueError: the data does not hold width * height cells, no cell is a wall, or a bad
            resolution or origin.
    """
    cells = np.asarray(data, dtype=np.int16).ravel()
    if width <= 0 or height <= 0 or cells.size != width * height:
        raise ValueError(
            f"occupancy grid of {width} x {height} cells holds {cells.size} values: the message is malformed"
        )
    walls = (cells >= occupied).reshape(height, width)[::-1]  # image order: row 0 at the top
    if not walls.any():
        raise ValueError(
            f"the occupancy grid has no cell >= {occupied} (occupied): no walls to localize against; "
            "publish the building's map (map_server) on the map topic"
        )
    raster = PlanRaster(
        np.ascontiguousarray(walls), positive(resolution, "resolution", "metres"), as_pose(origin, "origin")
    )
    plan = PlanMap.from_raster(raster, edge_detector=recognised_reading(raster.walls))
    # An occupancy grid on a map topic is in metres, as map_server serves a map_server map.
    plan.metric = True
    return plan
