"""A plan scaled about its map origin: the fix for a plan read at the wrong metres per pixel.

A raster read at a guessed resolution is the building scaled by (guess / true resolution) about the
map frame's origin: every wall point, the image's origin and its pixel size scale together. So the
scaled plan of a raster plan is the same image read at `resolution * factor` with its origin
scaled by `factor`: its wall points are exactly the original ones times `factor`. A plan made of
points has its points scaled and keeps its point spacing's visibility raster in proportion.
Metres, map frame.
"""

from __future__ import annotations

from .._validation import positive
from .plan_map import PlanMap
from .plan_raster import PlanRaster


def scaled_plan(plan: PlanMap, factor: float) -> PlanMap:
    """`plan` with every map coordinate multiplied by `factor` (> 0) about the map origin (0, 0).

    Args:
        plan: the plan (a `PlanMap`).
        factor: the scale factor, e.g. `estimate_scale(...).factor`: 1.03 makes the plan 3 %
            larger. Yaws are unchanged.

    Raises:
        TypeError: `plan` is not a PlanMap.
        ValueError: `factor` not a finite number > 0.
    """
    if not isinstance(plan, PlanMap):
        raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
    factor = positive(factor, "factor")
    raster = plan.raster
    if raster is not None and plan.edge_detector is not None:
        ox, oy, yaw = raster.origin
        scaled = PlanRaster(raster.walls, raster.resolution * factor, (ox * factor, oy * factor, yaw))
        return PlanMap.from_raster(scaled, edge_detector=plan.edge_detector)
    return PlanMap.from_points(plan.points * factor, resolution=plan.raster_resolution * factor)
