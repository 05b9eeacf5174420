"""The plan as the localizer sees it: wall-surface points in metres, in the map frame."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import _core
from ._validation import as_pose, as_points, positive


class PlanMap:
    """Wall-surface points of a floor plan (metres, map frame), prepared once for alignment.

    Building one makes a KD-tree over the points, a wall normal per point and a raster of the
    points for visibility ray casting; all are read-only afterwards, so one `PlanMap` serves any
    number of alignments, from any number of threads.
    """

    __slots__ = ("_native", "_points")

    def __init__(self, native: _core.PointMap) -> None:
        """Wraps a native map; use a `from_*` constructor instead."""
        if not isinstance(native, _core.PointMap):
            raise TypeError("use PlanMap.from_points(...) (or another from_* constructor) to build a PlanMap")
        self._native = native
        points = native.points
        points.setflags(write=False)
        self._points = points

    @classmethod
    def from_points(cls, xy: Any, *, resolution: float | None = None) -> PlanMap:
        """A plan from wall points.

        Args:
            xy: (N, 2) wall-surface points, metres, map frame. N >= 1, all finite.
            resolution: cell size in metres of the raster used for visibility ray casting.
                It should be about 1.5 times the spacing of neighbouring points along a wall, so
                that rays cannot slip between them; None estimates it that way from the points.

        Raises:
            TypeError: `xy` does not hold real numbers.
            ValueError: wrong shape, no points, a NaN/inf coordinate, or a bad resolution.
        """
        points = as_points(xy, "plan points")
        if resolution is not None:
            resolution = positive(resolution, "resolution", "metres")
        return cls(_core.PointMap(points, resolution))

    @property
    def points(self) -> NDArray[np.float64]:
        """(N, 2) wall points, metres, map frame (read-only)."""
        return self._points

    @property
    def normals(self) -> NDArray[np.float64]:
        """(N, 2) unit wall normals fitted to each point's neighbours ((0, 0) where none fits)."""
        return self._native.normals

    @property
    def raster_resolution(self) -> float:
        """Cell size of the visibility raster, metres."""
        return self._native.raster_resolution

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the points, metres."""
        lo, hi = self._points.min(axis=0), self._points.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def visible_indices(self, pose: Any, max_range: float = 30.0) -> NDArray[np.uint32]:
        """Indices (ascending) of the wall points a 360-degree LIDAR at `pose` sees.

        Rays are cast through the visibility raster from the pose's position, each stopping at
        the first wall cell; the points in those cells are visible. Only x and y of `pose`
        matter.

        Args:
            pose: (x, y, yaw) in the map frame, metres and radians.
            max_range: sensor range, metres.
        """
        x, y, _ = as_pose(pose, "pose")
        return self._native.visible_indices(x, y, positive(max_range, "max_range", "metres"))

    def visible_from(self, pose: Any, max_range: float = 30.0) -> NDArray[np.float64]:
        """(M, 2) wall points visible from `pose` within `max_range` (see `visible_indices`)."""
        return self._points[self.visible_indices(pose, max_range)]

    def __len__(self) -> int:
        return len(self._native)

    def __repr__(self) -> str:
        xmin, ymin, xmax, ymax = self.extent
        return (
            f"PlanMap({len(self)} wall points, x {xmin:.2f}..{xmax:.2f} m, y {ymin:.2f}..{ymax:.2f} m, "
            f"visibility raster {self.raster_resolution:.3f} m)"
        )
