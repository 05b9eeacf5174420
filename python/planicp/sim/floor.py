"""A rasterised floor with two layers: the walls the architectural plan shows, and the clutter
(furniture, bins, ...) that the plan does NOT show but a LIDAR sees.

Conventions: metres and radians; frames follow ROS REP-103 (x forward, y left, yaw counter-clockwise).
Rasters are indexed ``[row, col]`` with the row index growing with +y (row 0 is the LOWEST y, i.e. NOT
image order); cell ``(r, c)`` covers ``x in [ox + c*res, ox + (c+1)*res)`` and
``y in [oy + r*res, oy + (r+1)*res)`` where ``(ox, oy) = origin``. Use `Floor.to_image` to get an
image in ROS ``map_server`` (top row = highest y) order.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _core
from .argument_checks import Pose, finite_float

__all__ = ["Floor"]


@dataclass(frozen=True, eq=False, repr=False)
class Floor:
    """A rasterised floor: walls (in the plan) and clutter (furniture, NOT in the plan).

    Attributes:
        walls: ``(rows, cols)`` bool; row index grows with +y (row 0 is the LOWEST y, i.e. not image order).
        clutter: ``(rows, cols)`` bool, same shape; furniture/people not in the plan. A cell that is both
            wall and clutter counts as wall.
        resolution: metres per cell (square cells).
        origin: map-frame ``(x, y)`` in metres of the lower-left CORNER of cell ``(0, 0)``; cell ``(r, c)``
            covers ``x in [ox + c*res, ox + (c+1)*res)``, ``y in [oy + r*res, oy + (r+1)*res)``.

    The arrays are copied on construction and made read-only, so a ``Floor`` is immutable and derived data
    (ray-casting grid, pose-sampling masks) is cached on the instance. Equality is identity; compare the
    arrays explicitly to compare floors.
    """

    walls: NDArray[np.bool_]
    clutter: NDArray[np.bool_]
    resolution: float
    origin: tuple[float, float]

    def __post_init__(self) -> None:
        walls = _as_bool_grid(self.walls, "walls")
        clutter = _as_bool_grid(self.clutter, "clutter")
        if walls.shape != clutter.shape:
            raise ValueError(f"walls {walls.shape} and clutter {clutter.shape} must have the same shape")
        res = finite_float(self.resolution, "resolution")
        if res <= 0.0:
            raise ValueError(f"resolution must be > 0 metres per cell, got {res}")
        try:
            ox, oy = (float(v) for v in self.origin)
        except (TypeError, ValueError):
            raise ValueError(f"origin must be a pair of floats (x, y) in metres, got {self.origin!r}") from None
        if not (math.isfinite(ox) and math.isfinite(oy)):
            raise ValueError(f"origin must be finite, got {(ox, oy)}")
        object.__setattr__(self, "walls", walls)
        object.__setattr__(self, "clutter", clutter)
        object.__setattr__(self, "resolution", res)
        object.__setattr__(self, "origin", (ox, oy))

    def __reduce__(self) -> tuple[type[Floor], tuple[Any, ...]]:
        # pickle only the defining fields: the cache is rebuilt on demand and arrays come back read-only
        return (Floor, (self.walls, self.clutter, self.resolution, self.origin))

    def __repr__(self) -> str:
        rows, cols = self.shape
        return (
            f"Floor(shape=({rows}, {cols}), resolution={self.resolution!r}, origin={self.origin!r}, "
            f"wall_cells={int(self.walls.sum())}, clutter_cells={int(self.clutter.sum())})"
        )

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the rasters."""
        rows, cols = self.walls.shape
        return int(rows), int(cols)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of the raster in metres (map frame)."""
        rows, cols = self.shape
        ox, oy = self.origin
        return ox, oy, ox + cols * self.resolution, oy + rows * self.resolution

    def occupied(self) -> NDArray[np.bool_]:
        """``walls | clutter`` as a new ``(rows, cols)`` bool array."""
        return self.walls | self.clutter

    def wall_points(self) -> NDArray[np.float64]:
        """Wall-SURFACE points, ``(N, 2)`` float64 in metres (map frame).

        For each wall cell with a free 4-neighbour (free = not wall; outside the raster counts as free), one
        point at the midpoint of each cell face shared with free space -- i.e. on the surface where simulated
        beams stop. Only wall cells count (clutter is not in the plan). Order is deterministic: faces facing
        +x, then -x, then +y, then -y; within each group row-major by cell.
        """
        w = self.walls
        padded = np.pad(w, 1, constant_values=False)
        rows, cols = w.shape
        res = self.resolution
        ox, oy = self.origin
        out = []
        for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)):
            neighbour = padded[1 + dr : rows + 1 + dr, 1 + dc : cols + 1 + dc]
            r, c = np.nonzero(w & ~neighbour)
            out.append(np.column_stack([ox + (c + 0.5 + 0.5 * dc) * res, oy + (r + 0.5 + 0.5 * dr) * res]))
        return np.ascontiguousarray(np.concatenate(out), dtype=np.float64)

    def to_image(self) -> NDArray[np.uint8]:
        """``uint8`` image in ROS ``map_server`` / image convention: row 0 is the TOP (highest y).

        Walls are 0 (black), everything else 255 (white). Clutter is NOT drawn (it is not in the plan).
        With ``origin`` as the map_server ``origin`` and ``resolution`` as its resolution the image reproduces
        the plan.
        """
        return np.where(self.walls[::-1], np.uint8(0), np.uint8(255)).astype(np.uint8)

    def sample_pose(self, rng: np.random.Generator, clearance: float = 0.5) -> Pose:
        """A random pose ``(x, y, yaw)`` (metres, radians in ``[-pi, pi)``) inside the building.

        "Inside" is the largest 4-connected region of free cells (neither wall nor clutter) that does not
        touch the raster border. The position is uniform over the cells of that region whose every point is at
        least ``clearance`` metres (Euclidean) from every wall or clutter cell square, and uniform within the
        cell, so the returned position is guaranteed to have that clearance. Yaw is uniform.

        Raises:
            ValueError: ``clearance`` negative or not finite, or no cell satisfies the conditions.
        """
        clearance = finite_float(clearance, "clearance")
        if clearance < 0.0:
            raise ValueError(f"clearance must be >= 0 metres, got {clearance}")
        cells = self._pose_cells(clearance)
        if cells.size == 0:
            raise ValueError(f"no free cell inside the building has {clearance} m clearance from walls and clutter")
        k = int(rng.integers(cells.size))
        cols = self.shape[1]
        r, c = divmod(int(cells[k]), cols)
        u, v = rng.random(2)
        res = self.resolution
        ox, oy = self.origin
        yaw = float(rng.uniform(-math.pi, math.pi))
        return float(ox + (c + u) * res), float(oy + (r + v) * res), yaw

    # -- cached derived data (functools: the arrays are read-only, so what is derived from them holds) ---

    def _native_grid(self, layer: str) -> _core.OccupancyGrid:
        """The native ray-casting grid of ``"occupied"`` (walls and clutter) or ``"walls"`` cells."""
        return self._occupied_grid if layer == "occupied" else self._walls_grid

    @functools.cached_property
    def _occupied_grid(self) -> _core.OccupancyGrid:
        return _core.OccupancyGrid(np.ascontiguousarray(self.occupied()), self.resolution, self.origin)

    @functools.cached_property
    def _walls_grid(self) -> _core.OccupancyGrid:
        return _core.OccupancyGrid(np.ascontiguousarray(self.walls), self.resolution, self.origin)

    @functools.cached_property
    def _inside_mask(self) -> NDArray[np.bool_]:
        """Mask of the largest free 4-connected region not touching the raster border."""
        inside = _largest_interior_region(~self.occupied())
        inside.flags.writeable = False
        return inside

    def _inside(self) -> NDArray[np.bool_]:
        return self._inside_mask

    def _pose_cells(self, clearance: float) -> NDArray[np.intp]:
        """Flat indices of the inside cells at least `clearance` metres from every occupied cell."""
        return self._pose_cells_by_clearance(clearance)

    @functools.cached_property
    def _pose_cells_by_clearance(self) -> Callable[[float], NDArray[np.intp]]:
        # One memo per floor (a method under lru_cache would keep every floor alive in one global memo).
        @functools.cache
        def cells(clearance: float) -> NDArray[np.intp]:
            blocked = _dilate_by_clearance(self.occupied(), clearance / self.resolution)
            found = np.flatnonzero(self._inside() & ~blocked)
            found.flags.writeable = False
            return found

        return cells


def _as_bool_grid(value: ArrayLike, name: str) -> NDArray[np.bool_]:
    arr = np.asarray(value)
    if arr.dtype != np.bool_:
        raise ValueError(f"{name} must be a boolean array, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"{name} must be a non-empty 2-D (rows, cols) array, got shape {arr.shape}")
    out = np.array(arr, dtype=np.bool_, order="C", copy=True)
    out.flags.writeable = False
    return out


# ----------------------------------------------------------------------------------------------------------
# Connected components and clearance (OpenCV)
# ----------------------------------------------------------------------------------------------------------


def _largest_interior_region(free: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Largest 4-connected component of ``free`` that does not touch the raster border (empty if none).

    Ties in size go to the component whose first cell comes first in row-major order.
    """
    import cv2

    rows, cols = free.shape
    count, labels, stats, _ = cv2.connectedComponentsWithStats(free.astype(np.uint8), connectivity=4)
    left, top = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    width, height = stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT]
    sizes = stats[:, cv2.CC_STAT_AREA].astype(np.int64)
    sizes[(left == 0) | (top == 0) | (left + width == cols) | (top + height == rows)] = 0
    sizes[0] = 0  # label 0: the cells that are not free
    best = int(sizes.max()) if count else 0
    if best <= 0:
        return np.zeros((rows, cols), dtype=np.bool_)
    winners = np.flatnonzero(sizes == best)
    # first cell of each (row-major): the first cell of its top row that carries its label
    firsts = [int(top[k]) * cols + int(np.argmax(labels[top[k]] == k)) for k in winners]
    label = int(winners[int(np.argmin(firsts))])
    out: NDArray[np.bool_] = labels == label
    return out


def _dilate_by_clearance(occ: NDArray[np.bool_], q: float) -> NDArray[np.bool_]:
    """Cells with some point closer than ``q`` cells (Euclidean) to some point of an occupied cell.

    Two cells at integer offset ``(dr, dc)`` are ``hypot(max(|dr|-1, 0), max(|dc|-1, 0))`` cells apart (the
    gap between the squares), so the result is ``occ`` dilated by the kernel of the offsets with that gap
    ``< q``: in kernel row ``dr`` the columns ``|dc| <= w`` with ``w`` the largest ``|dc|`` whose
    ``max(|dc|-1, 0)`` is below ``sqrt(q^2 - max(|dr|-1, 0)^2)``. Cells outside the raster are free.
    """
    if q <= 0.0:
        return occ.copy()
    import cv2

    reach = math.ceil(q) + 1
    widths = {}
    for dr in range(-reach, reach + 1):
        a = max(abs(dr) - 1, 0)
        if a < q:
            widths[dr] = math.ceil(math.sqrt(q * q - a * a) + 1.0) - 1
    half = max(widths.values())
    kernel = np.zeros((2 * reach + 1, 2 * half + 1), dtype=np.uint8)
    for dr, w in widths.items():
        kernel[reach + dr, half - w : half + w + 1] = 1
    grown = cv2.dilate(occ.astype(np.uint8), kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    out: NDArray[np.bool_] = grown.astype(np.bool_)
    return out
