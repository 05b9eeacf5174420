"""Seeded synthetic floor plans and 2D LIDAR simulation.

This module is self-contained (numpy only) and is used by ``planicp demo``, by the test suite and by the
simulator. It provides

* :class:`Floor` -- a rasterised floor with two layers: ``walls`` (what the architectural plan shows) and
  ``clutter`` (furniture, bins, ... that the plan does NOT show but a LIDAR sees);
* :func:`generate_floor` -- seeded, furnished floors in three layouts (``"office"``, ``"hall"``,
  ``"diagonal"``);
* :func:`simulate_ranges` / :func:`simulate_scan` -- an exact grid ray caster (Amanatides-Woo traversal,
  vectorised over beams) returning ROS ``sensor_msgs/LaserScan``-style ranges or sensor-frame points;
* :func:`ranges_to_points` and :func:`perturb_pose` helpers.

Conventions
-----------
* Units: metres and radians everywhere.
* Frames follow ROS REP-103: x forward, y left, yaw counter-clockwise about +z. A pose ``(x, y, yaw)`` is the
  sensor pose in the map frame; sensor-frame points ``p`` map to ``R(yaw) @ p + (x, y)``.
* Rasters are indexed ``[row, col]`` with the row index growing with +y (row 0 is the LOWEST y, i.e. NOT
  image order); cell ``(r, c)`` covers ``x in [ox + c*res, ox + (c+1)*res)`` and
  ``y in [oy + r*res, oy + (r+1)*res)`` where ``(ox, oy) = origin``. Use :meth:`Floor.to_image` to get an
  image in ROS ``map_server`` (top row = highest y) order.
* Invalid LIDAR readings follow REP-117: ``+inf`` for "no return within ``max_range``" (and dropped beams),
  ``-inf`` for a return closer than ``min_range``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "LAYOUTS",
    "Floor",
    "generate_floor",
    "perturb_pose",
    "ranges_to_points",
    "simulate_ranges",
    "simulate_scan",
]

#: Layout names accepted by :func:`generate_floor`.
LAYOUTS: Final[tuple[str, ...]] = ("office", "hall", "diagonal")

# Cell classes of the ray-casting grid and return sources.
_FREE: Final = 0
_WALL: Final = 1
_CLUTTER: Final = 2
_DYNAMIC: Final = 3

_TWO_PI: Final = 2.0 * math.pi
# Grid-line crossings closer than this (in cells along the ray) are one corner crossing: the ray passes
# diagonally and does not hit the two cells it only grazes at the corner (makes rays through exact grid
# corners independent of 1-ulp rounding).
_CORNER_TIE: Final = 1e-9
_FULL_CIRCLE_TOL: Final = 1e-9

# Generator constants (metres).
_MARGIN: Final = 1.0  # minimum free margin between the building and the raster border
_T_OUTER: Final = 0.25  # outer wall thickness
_T_MIN: Final = 0.15  # interior wall thickness range
_T_MAX: Final = 0.25
_ROOM_MIN_WIDTH: Final = 4.0  # clear width between wall faces
_ROOM_MIN_DEPTH: Final = 3.0
_CORRIDOR_WIDTH: Final = (1.8, 2.4)
_DOOR_WIDTH: Final = (0.8, 1.2)
_DOOR_CLEAR: Final = 1.0  # keep-clear distance on both sides of a doorway
_HALL_MIN_SIDE: Final = 6.0
_HALL_AREA_PER_ROOM: Final = 16.0
_DIAGONAL_ANGLE: Final = (math.radians(15.0), math.radians(40.0))
_MAX_RESOLUTION: Final = 0.25
_MAX_CELLS: Final = 100_000_000

Pose = tuple[float, float, float]


# ----------------------------------------------------------------------------------------------------------
# Floor
# ----------------------------------------------------------------------------------------------------------


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
    _cache: dict[Any, Any] = field(init=False, default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        walls = _as_bool_grid(self.walls, "walls")
        clutter = _as_bool_grid(self.clutter, "clutter")
        if walls.shape != clutter.shape:
            raise ValueError(f"walls {walls.shape} and clutter {clutter.shape} must have the same shape")
        res = _finite_float(self.resolution, "resolution")
        if res <= 0.0:
            raise ValueError(f"resolution must be > 0 metres per cell, got {res}")
        try:
            ox, oy = (float(v) for v in self.origin)
        except (TypeError, ValueError):
            raise ValueError(
                f"origin must be a pair of floats (x, y) in metres, got {self.origin!r}"
            ) from None
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
        clearance = _finite_float(clearance, "clearance")
        if clearance < 0.0:
            raise ValueError(f"clearance must be >= 0 metres, got {clearance}")
        cells = self._pose_cells(clearance)
        if cells.size == 0:
            raise ValueError(
                f"no free cell inside the building has {clearance} m clearance from walls and clutter"
            )
        k = int(rng.integers(cells.size))
        cols = self.shape[1]
        r, c = divmod(int(cells[k]), cols)
        u, v = rng.random(2)
        res = self.resolution
        ox, oy = self.origin
        yaw = float(rng.uniform(-math.pi, math.pi))
        return float(ox + (c + u) * res), float(oy + (r + v) * res), yaw

    # -- cached derived data ---------------------------------------------------------------------------

    def _cell_class(self) -> NDArray[np.uint8]:
        """``uint8`` grid: 0 free, 1 wall, 2 clutter (clutter under a wall counts as wall)."""
        grid = self._cache.get("cell_class")
        if grid is None:
            grid = np.zeros(self.shape, dtype=np.uint8)
            grid[self.clutter] = _CLUTTER
            grid[self.walls] = _WALL
            grid.flags.writeable = False
            self._cache["cell_class"] = grid
        return grid

    def _padded_class_flat(self) -> NDArray[np.uint8]:
        """Flattened cell classes with one free cell of padding around the raster (ray-casting lookups)."""
        flat = self._cache.get("padded_class")
        if flat is None:
            flat = np.pad(self._cell_class(), 1, constant_values=_FREE).ravel()
            flat.flags.writeable = False
            self._cache["padded_class"] = flat
        return flat

    def _skip_levels(self) -> NDArray[np.uint8]:
        """Box-clearance levels used for exact empty-space skipping in the ray caster."""
        levels = self._cache.get("skip_levels")
        if levels is None:
            levels = _box_clearance_levels(self.occupied())
            levels.flags.writeable = False
            self._cache["skip_levels"] = levels
        return levels

    def _inside(self) -> NDArray[np.bool_]:
        """Mask of the largest free 4-connected region not touching the raster border."""
        inside = self._cache.get("inside")
        if inside is None:
            inside = _largest_interior_region(~self.occupied())
            inside.flags.writeable = False
            self._cache["inside"] = inside
        return inside

    def _pose_cells(self, clearance: float) -> NDArray[np.intp]:
        key = ("pose_cells", clearance)
        cells = self._cache.get(key)
        if cells is None:
            blocked = _dilate_by_clearance(self.occupied(), clearance / self.resolution)
            cells = np.flatnonzero(self._inside() & ~blocked)
            cells.flags.writeable = False
            self._cache[key] = cells
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


def _finite_float(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {out}")
    return out


def _int_arg(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    out = int(value)
    if out < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {out}")
    return out


def _pose_arg(pose: Any, name: str = "pose") -> Pose:
    try:
        values = [float(v) for v in pose]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a sequence (x, y, yaw) of floats, got {pose!r}") from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{name} must be three finite floats (x, y, yaw), got {pose!r}")
    return values[0], values[1], values[2]


def _wrap_angle(a: float) -> float:
    """Wrap to ``[-pi, pi)``."""
    return (a + math.pi) % _TWO_PI - math.pi


# ----------------------------------------------------------------------------------------------------------
# Connected components and clearance (pure numpy)
# ----------------------------------------------------------------------------------------------------------


def _largest_interior_region(free: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Largest 4-connected component of ``free`` that does not touch the raster border (empty if none).

    Run-length labelling: horizontal runs are nodes, vertically overlapping runs in adjacent rows are edges,
    components are found by vectorised min-label hooking with pointer jumping. Ties in size go to the
    component whose first run comes first in row-major order.
    """
    rows, cols = free.shape
    padded = np.zeros((rows, cols + 2), dtype=np.int8)
    padded[:, 1:-1] = free
    d = np.diff(padded, axis=1)
    sr, sc = np.nonzero(d == 1)  # run starts (row-major, so runs are sorted)
    _, ec = np.nonzero(d == -1)  # run ends (exclusive column)
    n = sr.size
    mask = np.zeros((rows, cols), dtype=np.bool_)
    if n == 0:
        return mask
    stride = cols + 1
    key_start = sr.astype(np.int64) * stride + sc
    key_end = sr.astype(np.int64) * stride + ec
    # For each run b (row > 0), the runs a of the row below with a.c0 < b.c1 and a.c1 > b.c0.
    base = (sr.astype(np.int64) - 1) * stride
    lo = np.searchsorted(key_end, base + sc, side="right")
    hi = np.searchsorted(key_start, base + ec, side="left")
    counts = np.where(sr > 0, np.maximum(hi - lo, 0), 0)
    v = np.repeat(np.arange(n), counts)
    first = np.repeat(lo - np.cumsum(counts) + counts, counts)
    u = first + np.arange(v.size)
    parent = np.arange(n)
    while True:
        pu, pv = parent[u], parent[v]
        differ = pu != pv
        if not differ.any():
            break
        pu, pv = pu[differ], pv[differ]
        m = np.minimum(pu, pv)
        np.minimum.at(parent, pu, m)
        np.minimum.at(parent, pv, m)
        while True:  # pointer jumping until every node points at a root
            nxt = parent[parent]
            if np.array_equal(nxt, parent):
                break
            parent = nxt
    lengths = (ec - sc).astype(np.int64)
    sizes = np.bincount(parent, weights=lengths, minlength=n)
    touches = (sr == 0) | (sr == rows - 1) | (sc == 0) | (ec == cols)
    sizes[np.unique(parent[touches])] = 0.0
    best = int(np.argmax(sizes))
    if sizes[best] <= 0.0:
        return mask
    sel = parent == best
    marks = np.zeros((rows, cols + 1), dtype=np.int32)
    np.add.at(marks, (sr[sel], sc[sel]), 1)
    np.add.at(marks, (sr[sel], ec[sel]), -1)
    mask[:] = np.cumsum(marks, axis=1)[:, :cols] > 0
    return mask


def _dilate_by_clearance(occ: NDArray[np.bool_], q: float) -> NDArray[np.bool_]:
    """Cells with some point closer than ``q`` cells (Euclidean) to some point of an occupied cell.

    Two cells at integer offset ``(dr, dc)`` are ``hypot(max(|dr|-1, 0), max(|dc|-1, 0))`` cells apart (the
    gap between the squares), so the result is ``occ`` dilated by the offsets with that gap ``< q``. Each row
    offset is a horizontal box dilation done with prefix sums.
    """
    out = occ.copy()
    if q <= 0.0:
        return out
    rows, cols = occ.shape
    prefix = np.zeros((rows, cols + 1), dtype=np.int32)
    np.cumsum(occ, axis=1, out=prefix[:, 1:])
    col = np.arange(cols)
    horizontal: dict[int, NDArray[np.bool_]] = {}
    reach = math.ceil(q) + 1
    for dr in range(-reach, reach + 1):
        a = max(abs(dr) - 1, 0)
        if a >= q:
            continue
        s = math.sqrt(q * q - a * a)
        w = math.ceil(s + 1.0) - 1  # largest |dc| with max(|dc|-1, 0) < s
        h = horizontal.get(w)
        if h is None:
            hi = np.minimum(col + w + 1, cols)
            lo = np.maximum(col - w, 0)
            h = (prefix[:, hi] - prefix[:, lo]) > 0
            horizontal[w] = h
        # out[r] |= h[r + dr]
        if dr >= 0:
            if dr < rows:
                out[: rows - dr] |= h[dr:]
        elif -dr < rows:
            out[-dr:] |= h[: rows + dr]
    return out


# ----------------------------------------------------------------------------------------------------------
# Floor generation
# ----------------------------------------------------------------------------------------------------------


class _Placement:
    """Rigid transform from the building-local frame to the map frame (rotation about the origin + shift)."""

    def __init__(self, angle: float = 0.0, shift: tuple[float, float] = (0.0, 0.0)) -> None:
        self.angle = angle
        self.c = math.cos(angle)
        self.s = math.sin(angle)
        self.tx, self.ty = shift

    def point(self, x: float, y: float) -> tuple[float, float]:
        return self.c * x - self.s * y + self.tx, self.s * x + self.c * y + self.ty


class _Canvas:
    """Mutable rasteriser used while generating a floor; all primitives are given in the map frame.

    Cells are tested by their centre (closed shapes). Walls are drawn at least as thick as the projection of
    a cell onto their normal, so every wall is 4-connected (no ray or flood fill leaks through it).
    """

    def __init__(self, rows: int, cols: int, res: float, origin: tuple[float, float]) -> None:
        self.rows, self.cols, self.res = rows, cols, res
        self.ox, self.oy = origin
        self.walls = np.zeros((rows, cols), dtype=np.bool_)
        self.clutter = np.zeros((rows, cols), dtype=np.bool_)
        self.keep_clear = np.zeros((rows, cols), dtype=np.bool_)
        self.interior = np.zeros((rows, cols), dtype=np.bool_)

    # -- cell windows -------------------------------------------------------------------------------------

    def _window(
        self, xmin: float, xmax: float, ymin: float, ymax: float
    ) -> tuple[slice, slice, NDArray[np.float64], NDArray[np.float64]] | None:
        """Cells whose centre lies in the box, with their centre coordinates (broadcastable)."""
        res = self.res
        c0 = max(0, math.ceil((xmin - self.ox) / res - 0.5))
        c1 = min(self.cols - 1, math.floor((xmax - self.ox) / res - 0.5))
        r0 = max(0, math.ceil((ymin - self.oy) / res - 0.5))
        r1 = min(self.rows - 1, math.floor((ymax - self.oy) / res - 0.5))
        if c1 < c0 or r1 < r0:
            return None
        xs = self.ox + (np.arange(c0, c1 + 1, dtype=np.float64) + 0.5) * res
        ys = self.oy + (np.arange(r0, r1 + 1, dtype=np.float64) + 0.5) * res
        return slice(r0, r1 + 1), slice(c0, c1 + 1), xs[None, :], ys[:, None]

    def rect(
        self, cx: float, cy: float, angle: float, half_u: float, half_v: float
    ) -> tuple[slice, slice, NDArray[np.bool_]] | None:
        """Cells of an oriented rectangle (centre, orientation of its u axis, half extents)."""
        if half_u < 0.0 or half_v < 0.0:
            return None
        c, s = math.cos(angle), math.sin(angle)
        ex = abs(c) * half_u + abs(s) * half_v
        ey = abs(s) * half_u + abs(c) * half_v
        win = self._window(cx - ex, cx + ex, cy - ey, cy + ey)
        if win is None:
            return None
        rs, cs, xs, ys = win
        dx, dy = xs - cx, ys - cy
        m = (np.abs(c * dx + s * dy) <= half_u) & (np.abs(-s * dx + c * dy) <= half_v)
        return rs, cs, m

    def disc(self, cx: float, cy: float, radius: float) -> tuple[slice, slice, NDArray[np.bool_]] | None:
        """Cells of a disc; a non-empty disc always marks at least the cell containing its centre."""
        if radius <= 0.0:
            return None
        cc = math.floor((cx - self.ox) / self.res)
        rr = math.floor((cy - self.oy) / self.res)
        if not (0 <= cc < self.cols and 0 <= rr < self.rows):
            return None
        win = self._window(cx - radius, cx + radius, cy - radius, cy + radius)
        if win is None:  # smaller than a cell: the cell containing the centre
            return slice(rr, rr + 1), slice(cc, cc + 1), np.ones((1, 1), dtype=np.bool_)
        rs, cs, xs, ys = win
        m = (xs - cx) ** 2 + (ys - cy) ** 2 <= radius * radius
        if not m.any():
            m[min(max(rr - rs.start, 0), m.shape[0] - 1), min(max(cc - cs.start, 0), m.shape[1] - 1)] = True
        return rs, cs, m

    def _min_half_thickness(self, normal_angle: float) -> float:
        return 0.5 * self.res * (abs(math.cos(normal_angle)) + abs(math.sin(normal_angle)))

    # -- plan primitives ----------------------------------------------------------------------------------

    def wall(self, p0: tuple[float, float], p1: tuple[float, float], thickness: float) -> None:
        """Straight wall along the centre-line p0-p1, extended by half its thickness at both ends."""
        length = math.hypot(p1[0] - p0[0], p1[1] - p0[1])
        angle = math.atan2(p1[1] - p0[1], p1[0] - p0[0])
        ht = max(0.5 * thickness, self._min_half_thickness(angle + 0.5 * math.pi))
        cells = self.rect(0.5 * (p0[0] + p1[0]), 0.5 * (p0[1] + p1[1]), angle, 0.5 * (length + thickness), ht)
        if cells is not None:
            rs, cs, m = cells
            self.walls[rs, cs] |= m

    def pillar(self, cx: float, cy: float, angle: float, side: float) -> None:
        cells = self.rect(cx, cy, angle, 0.5 * side, 0.5 * side)
        if cells is not None:
            rs, cs, m = cells
            self.walls[rs, cs] |= m

    def door(self, cx: float, cy: float, wall_angle: float, width: float, thickness: float) -> None:
        """Cut a doorway of ``width`` centred on a wall centre-line point; keep ~1 m either side clear."""
        normal = wall_angle + 0.5 * math.pi
        depth = max(0.5 * thickness, self._min_half_thickness(normal)) + 1.5 * self.res
        cells = self.rect(cx, cy, wall_angle, 0.5 * width, depth)
        if cells is not None:
            rs, cs, m = cells
            self.walls[rs, cs] &= ~m
        clear = self.rect(cx, cy, wall_angle, 0.5 * width + 0.3, _DOOR_CLEAR + 0.5 * thickness)
        if clear is not None:
            rs, cs, m = clear
            self.keep_clear[rs, cs] |= m

    def outer_shell(self, polygon: NDArray[np.float64], thickness: float) -> None:
        """Ring wall whose OUTER face is the convex CCW ``polygon``; sets ``interior`` to the inside."""
        xs = self.ox + (np.arange(self.cols) + 0.5) * self.res
        ys = self.oy + (np.arange(self.rows) + 0.5) * self.res
        inside_outer = np.ones((self.rows, self.cols), dtype=np.bool_)
        inside_inner = np.ones((self.rows, self.cols), dtype=np.bool_)
        interior = np.ones((self.rows, self.cols), dtype=np.bool_)
        k = len(polygon)
        for i in range(k):
            (x0, y0), (x1, y1) = polygon[i], polygon[(i + 1) % k]
            length = math.hypot(x1 - x0, y1 - y0)
            if length <= 0.0:
                continue
            nx, ny = -(y1 - y0) / length, (x1 - x0) / length  # inward normal of a CCW polygon
            dist = (xs[None, :] - x0) * nx + (ys[:, None] - y0) * ny
            inside_outer &= dist >= 0.0
            band = max(thickness, 2.0 * self._min_half_thickness(math.atan2(ny, nx)))
            inside_inner &= dist > band
            interior &= dist > thickness
        self.walls |= inside_outer & ~inside_inner
        self.interior = interior

    # -- clutter ------------------------------------------------------------------------------------------

    def place_clutter(self, shapes: list[tuple[str, tuple[float, ...]]]) -> bool:
        """Add a furniture item made of rects/discs if it fits; return whether it was placed.

        An item fits if every cell is inside the building, none is in a doorway keep-clear zone and the item
        shrunk by one cell does not intersect a wall (it may touch walls, e.g. a cabinet, but not cross them).
        """
        parts = []
        for kind, p in shapes:
            if kind == "rect":
                cx, cy, ang, hu, hv = p
                full = self.rect(cx, cy, ang, hu, hv)
                core = self.rect(cx, cy, ang, hu - self.res, hv - self.res)
            else:
                cx, cy, r = p
                full = self.disc(cx, cy, r)
                core = self.disc(cx, cy, r - self.res) if r > self.res else None
            if full is None:
                return False
            rs, cs, m = full
            if (m & ~self.interior[rs, cs]).any() or (m & self.keep_clear[rs, cs]).any():
                return False
            if core is not None:
                crs, ccs, cm = core
                if (cm & self.walls[crs, ccs]).any():
                    return False
            parts.append(full)
        for rs, cs, m in parts:
            self.clutter[rs, cs] |= m
        return True


def _furniture_item(
    rng: np.random.Generator, box: tuple[float, float, float, float]
) -> list[tuple[str, tuple[float, ...]]] | None:
    """One furniture item in building-local coordinates inside the clear room ``box`` (x0, y0, x1, y1).

    Cabinets/shelves stand flush against a wall face (0.35-0.6 m deep, 0.8-2 m long); tables are free-standing
    rectangles (possibly rotated) or four table legs; chairs/bins are discs (r 0.15-0.35 m).
    """
    x0, y0, x1, y1 = box
    kind = rng.random()
    if kind < 0.40:  # cabinet / shelf against a wall
        length, depth = rng.uniform(0.8, 2.0), rng.uniform(0.35, 0.6)
        side = int(rng.integers(4))
        if side < 2:
            if x1 - x0 < length:
                return None
            cx = rng.uniform(x0 + length / 2, x1 - length / 2)
            cy = y0 + depth / 2 if side == 0 else y1 - depth / 2
            return [("rect", (cx, cy, 0.0, length / 2, depth / 2))]
        if y1 - y0 < length:
            return None
        cy = rng.uniform(y0 + length / 2, y1 - length / 2)
        cx = x0 + depth / 2 if side == 2 else x1 - depth / 2
        return [("rect", (cx, cy, 0.5 * math.pi, length / 2, depth / 2))]
    if x1 - x0 < 2.5 or y1 - y0 < 2.5:
        return None
    cx, cy = rng.uniform(x0 + 1.0, x1 - 1.0), rng.uniform(y0 + 1.0, y1 - 1.0)
    if kind < 0.65:  # solid table / desk
        angle = rng.uniform(0.0, math.pi) if rng.random() < 0.4 else 0.0
        return [("rect", (cx, cy, angle, rng.uniform(0.3, 0.8), rng.uniform(0.3, 0.5)))]
    if kind < 0.75:  # table seen as four legs
        angle = rng.uniform(0.0, math.pi) if rng.random() < 0.4 else 0.0
        hu, hv, r = rng.uniform(0.35, 0.75), rng.uniform(0.3, 0.45), rng.uniform(0.05, 0.06)
        c, s = math.cos(angle), math.sin(angle)
        legs: list[tuple[str, tuple[float, ...]]] = []
        for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            u, v = su * (hu - r), sv * (hv - r)
            legs.append(("disc", (cx + c * u - s * v, cy + s * u + c * v, r)))
        return legs
    return [("disc", (cx, cy, rng.uniform(0.15, 0.35)))]


def _to_map(
    shapes: list[tuple[str, tuple[float, ...]]], placement: _Placement
) -> list[tuple[str, tuple[float, ...]]]:
    out: list[tuple[str, tuple[float, ...]]] = []
    for kind, p in shapes:
        x, y = placement.point(p[0], p[1])
        if kind == "rect":
            out.append((kind, (x, y, p[2] + placement.angle, p[3], p[4])))
        else:
            out.append((kind, (x, y, p[2])))
    return out


def _furnish(
    rng: np.random.Generator,
    canvas: _Canvas,
    placement: _Placement,
    box: tuple[float, float, float, float],
    count: int,
    attempts: int = 15,
) -> None:
    for _ in range(count):
        for _ in range(attempts):
            item = _furniture_item(rng, box)
            if item is not None and canvas.place_clutter(_to_map(item, placement)):
                break


def _split_span(rng: np.random.Generator, total: float, n: int, minimum: float) -> NDArray[np.float64]:
    """n random widths >= minimum summing to total."""
    if n == 1:
        return np.array([total])
    return minimum + rng.dirichlet(np.full(n, 3.0)) * (total - n * minimum)


def _office_min_size(rooms: int) -> tuple[float, float]:
    """Minimum building (length along the corridor, depth) that always fits ``rooms`` office rooms."""
    n_top = (rooms + 1) // 2
    bands = 2 if rooms >= 2 else 1
    length = 2 * _T_OUTER + n_top * _ROOM_MIN_WIDTH + (n_top - 1) * _T_MAX
    depth = 2 * _T_OUTER + bands * (_ROOM_MIN_DEPTH + _T_MAX) + _CORRIDOR_WIDTH[1]
    return length, depth


def _chamfered_rectangle(length: float, depth: float, cuts: list[float]) -> NDArray[np.float64]:
    """CCW polygon of the rectangle [0, length] x [0, depth] with corners cut by 45 deg chamfers.

    ``cuts`` gives the leg length of the chamfer at the corners (0,0), (L,0), (L,D), (0,D) (0 = square).
    """
    a0, a1, a2, a3 = cuts
    pts = [
        (a0, 0.0), (length - a1, 0.0), (length, a1), (length, depth - a2),
        (length - a2, depth), (a3, depth), (0.0, depth - a3), (0.0, a0),
    ]  # fmt: skip
    dedup: list[tuple[float, float]] = []
    for p in pts:
        if not dedup or math.hypot(p[0] - dedup[-1][0], p[1] - dedup[-1][1]) > 1e-12:
            dedup.append(p)
    if math.hypot(dedup[0][0] - dedup[-1][0], dedup[0][1] - dedup[-1][1]) <= 1e-12:
        dedup.pop()
    return np.array(dedup, dtype=np.float64)


def _build_office(
    rng: np.random.Generator,
    canvas: _Canvas,
    placement: _Placement,
    length: float,
    depth: float,
    rooms: int,
    furniture_per_room: int,
    chamfers: list[float],
) -> None:
    """Corridor along local x with one band of rooms on each side (one band if rooms == 1)."""
    to = _T_OUTER
    poly = np.array([placement.point(x, y) for x, y in _chamfered_rectangle(length, depth, chamfers)])
    canvas.outer_shell(poly, to)

    def wall(a: tuple[float, float], b: tuple[float, float], t: float) -> None:
        canvas.wall(placement.point(*a), placement.point(*b), t)

    def door(x: float, y: float, along_x: bool, width: float, t: float) -> None:
        px, py = placement.point(x, y)
        canvas.door(px, py, placement.angle + (0.0 if along_x else 0.5 * math.pi), width, t)

    def thick() -> float:
        return float(rng.uniform(_T_MIN, _T_MAX))

    n_top = (rooms + 1) // 2
    n_bot = rooms // 2
    cw = float(rng.uniform(*_CORRIDOR_WIDTH))
    t_hi = thick()
    t_lo = thick() if n_bot else 0.0
    interior_depth = depth - 2 * to
    free = interior_depth - cw - t_hi - t_lo - (2 if n_bot else 1) * _ROOM_MIN_DEPTH
    if n_bot:
        d_bot = _ROOM_MIN_DEPTH + free * float(rng.uniform(0.35, 0.65))
        y_lo = to + d_bot + t_lo / 2  # corridor wall centre-lines
        y_hi = y_lo + t_lo / 2 + cw + t_hi / 2
        wall((to / 2, y_lo), (length - to / 2, y_lo), t_lo)
    else:
        y_lo = to - t_lo / 2  # the outer wall bounds the corridor
        y_hi = to + cw + t_hi / 2
    wall((to / 2, y_hi), (length - to / 2, y_hi), t_hi)
    corridor_box = (to, y_lo + t_lo / 2, length - to, y_hi - t_hi / 2)

    # bands: (clear y-range of the rooms, corridor wall centre y and thickness, far outer face y)
    bands = [((y_hi + t_hi / 2, depth - to), (y_hi, t_hi), n_top, depth - to)]
    if n_bot:
        bands.append(((to, y_lo - t_lo / 2), (y_lo, t_lo), n_bot, to))
    chamfer_room = max(chamfers) + 0.5
    room_boxes = []
    doors: list[tuple[float, float, bool, float, float]] = []
    for (b0, b1), (yc, tc), n, far in bands:
        t_div = [thick() for _ in range(n - 1)]
        widths = _split_span(rng, length - 2 * to - sum(t_div), n, _ROOM_MIN_WIDTH)
        x = to
        faces = []
        for i in range(n):
            faces.append((x, x + widths[i]))
            x += widths[i]
            if i < n - 1:
                xc = x + t_div[i] / 2
                wall((xc, yc), (xc, far + (to / 2 if far > yc else -to / 2)), t_div[i])
                x += t_div[i]
        for i, (fx0, fx1) in enumerate(faces):
            room_boxes.append((fx0, b0, fx1, b1))
            w = float(rng.uniform(*_DOOR_WIDTH))
            doors.append((float(rng.uniform(fx0 + 0.6 + w / 2, fx1 - 0.6 - w / 2)), yc, True, w, tc))
            if i < n - 1 and rng.random() < 0.5:  # door to the next room
                w2 = float(rng.uniform(0.8, 1.0))
                lo, hi = b0 + 0.6 + w2 / 2, b1 - 0.6 - w2 / 2
                if hi > lo:
                    doors.append((fx1 + t_div[i] / 2, float(rng.uniform(lo, hi)), False, w2, t_div[i]))
            if rng.random() < 0.35:  # partial wall from the outer side: alcove / closet
                lo, hi = max(fx0 + 1.5, to + chamfer_room), min(fx1 - 1.5, length - to - chamfer_room)
                if hi > lo:
                    xa = float(rng.uniform(lo, hi))
                    alen = float(rng.uniform(1.2, max(1.3, 0.5 * (b1 - b0))))
                    end = far - alen if far > yc else far + alen
                    wall((xa, far), (xa, end), thick())
    for x, y, along_x, w, t in doors:
        door(x, y, along_x, w, t)
    if furniture_per_room <= 0:
        return
    for box in room_boxes:
        _furnish(rng, canvas, placement, box, furniture_per_room)
    # bins / plants along the corridor walls
    cx0, cy0, cx1, cy1 = corridor_box
    for _ in range(max(1, round(length / 6.0))):
        for _ in range(15):
            r = float(rng.uniform(0.15, 0.25))
            y = cy0 + r if rng.random() < 0.5 else cy1 - r
            px, py = placement.point(float(rng.uniform(cx0 + 0.5, cx1 - 0.5)), y)
            if canvas.place_clutter([("disc", (px, py, r))]):
                break


def _pillar_grid(rng: np.random.Generator, lo: float, hi: float) -> NDArray[np.float64]:
    """Pillar coordinates along one axis: spacing 4.5-7 m, centred, >= 2.5 m from the walls."""
    spacing = float(rng.uniform(4.5, 7.0))
    span = hi - lo - 5.0
    if span < 0.0:
        return np.empty(0)
    n = math.floor(span / spacing) + 1
    return 0.5 * (lo + hi - (n - 1) * spacing) + spacing * np.arange(n, dtype=np.float64)


def _build_hall(
    rng: np.random.Generator,
    canvas: _Canvas,
    length: float,
    depth: float,
    rooms: int,
    furniture_per_room: int,
) -> None:
    """One open hall: pillars on a grid (in the plan), free-standing partitions, furniture."""
    to = _T_OUTER
    poly = np.array([(0.0, 0.0), (length, 0.0), (length, depth), (0.0, depth)])
    canvas.outer_shell(poly, to)
    side = float(rng.uniform(0.4, 0.6))
    px = _pillar_grid(rng, to, length - to)
    py = _pillar_grid(rng, to, depth - to)
    for x in px:
        for y in py:
            canvas.pillar(float(x), float(y), 0.0, side)
    box = (to, to, length - to, depth - to)
    gap = 2.0  # partitions keep >= 2 m from the outer walls and >= 1.2 m from pillars and each other
    for _ in range(max(1, rooms // 3)):
        for _ in range(30):
            t = float(rng.uniform(_T_MIN, 0.2))
            horizontal = bool(rng.random() < 0.5)
            along = (box[0], box[2]) if horizontal else (box[1], box[3])
            across = (box[1], box[3]) if horizontal else (box[0], box[2])
            max_half = min(2.5, 0.5 * (along[1] - along[0]) - gap)
            if max_half < 1.0 or across[1] - across[0] < 2 * gap:
                continue
            half = float(rng.uniform(1.0, max_half))
            u = float(rng.uniform(along[0] + gap + half, along[1] - gap - half))
            v = float(rng.uniform(across[0] + gap, across[1] - gap))
            x, y = (u, v) if horizontal else (v, u)
            angle = 0.0 if horizontal else 0.5 * math.pi
            probe = canvas.rect(x, y, angle, half + t / 2 + 1.2, t / 2 + 1.2)
            if probe is None or (probe[2] & canvas.walls[probe[0], probe[1]]).any():
                continue
            a, b = ((x - half, y), (x + half, y)) if horizontal else ((x, y - half), (x, y + half))
            canvas.wall(a, b, t)
            break
    _furnish(rng, canvas, _Placement(), box, rooms * furniture_per_room)


def _diagonal_building(
    width: float, height: float, theta: float, min_len: float, min_depth: float
) -> tuple[float, float]:
    """Largest-area building (length, depth) with length >= min_len, depth >= min_depth that, rotated by
    ``theta``, fits the ``width`` x ``height`` box."""
    c, s = abs(math.cos(theta)), abs(math.sin(theta))
    best = (min_len, min_depth)
    best_area = -1.0
    for d in np.linspace(min_depth, max(min_depth, min(width, height) / max(c, s)), 200):
        length = min((width - d * s) / c, (height - d * c) / s)
        if length >= min_len and length * d > best_area:
            best, best_area = (float(length), float(d)), float(length * d)
    return best


def _max_sinusoid(a: float, b: float, lo: float, hi: float) -> float:
    """max of a*sin(t) + b*cos(t) over t in [lo, hi]."""

    def f(t: float) -> float:
        return a * math.sin(t) + b * math.cos(t)

    candidates = [f(lo), f(hi)]
    t_star = math.atan2(a, b)
    for t in (t_star, t_star + math.pi, t_star - math.pi):
        if lo <= t <= hi:
            candidates.append(f(t))
    return max(candidates)


def generate_floor(
    seed: int,
    layout: str = "office",
    *,
    width: float = 40.0,
    height: float = 25.0,
    resolution: float = 0.05,
    rooms: int = 10,
    furniture_per_room: int = 6,
) -> Floor:
    """Seeded, furnished floor plan.

    The building occupies the map-frame box ``[0, width] x [0, height]`` metres (its outer wall faces lie in
    the box) and the raster adds a free margin of ``ceil(1 m / resolution) + 1`` cells on every side, so
    ``origin`` is negative and nothing touches the raster border. The outside of the building is never
    connected to the inside (no exterior doors).

    Layouts:
      ``"office"``: 0.25 m outer walls, a corridor (1.8-2.4 m) along x with a row of rooms on each side
        (``ceil(rooms/2)`` above, ``floor(rooms/2)`` below; clear widths >= 4 m, depths >= 3 m), one door
        (0.8-1.2 m) from each room to the corridor, doors between neighbouring rooms with probability 0.5,
        partial walls (alcoves) from the outer wall with probability 0.35 per room; interior walls
        0.15-0.25 m.
      ``"hall"``: one open room with square pillars (0.4-0.6 m, in the plan) on a grid of 4.5-7 m,
        ``max(1, rooms // 3)`` free-standing partition walls and ``rooms * furniture_per_room`` furniture
        items.
      ``"diagonal"``: an office building with randomly chamfered corners (45 deg in the building frame),
        rotated by +-15-40 deg and scaled to the largest area that fits ``width`` x ``height``; no wall is
        axis-aligned in the map frame.

    Furniture (clutter layer, not in the plan): cabinets flush against walls (0.35-0.6 m deep, 0.8-2 m
    long), free tables (possibly rotated), tables seen as four legs (r 0.05-0.06 m), chairs/bins (discs
    r 0.15-0.35 m), plus bins along office corridors. ``furniture_per_room`` items are attempted per room
    (an item that does not fit after 15 tries is skipped); 0 gives an empty clutter layer. Furniture keeps
    1 m clear on both sides of every doorway and never crosses a wall. All randomness comes from
    ``np.random.default_rng(seed)``, so a (seed, arguments) pair always yields the same floor.

    Args:
        seed: non-negative integer seed.
        layout: one of :data:`LAYOUTS`.
        width, height: size in metres of the map-frame box the building occupies.
        resolution: metres per cell, in ``(0, 0.25]``.
        rooms: number of rooms (office/diagonal) or furniture zones (hall), >= 1.
        furniture_per_room: furniture items per room, >= 0.

    Raises:
        ValueError: unknown layout, bad seed, non-positive or non-finite sizes, resolution <= 0 or > 0.25,
            rooms < 1, negative furniture_per_room, a box too small for the requested rooms, or a raster of
            more than 1e8 cells.
    """
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or int(seed) < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}; expected one of {', '.join(LAYOUTS)}")
    width = _finite_float(width, "width")
    height = _finite_float(height, "height")
    if width <= 0.0 or height <= 0.0:
        raise ValueError(f"width and height must be > 0 metres, got width={width}, height={height}")
    resolution = _finite_float(resolution, "resolution")
    if resolution <= 0.0:
        raise ValueError(f"resolution must be > 0 metres per cell, got {resolution}")
    if resolution > _MAX_RESOLUTION:
        raise ValueError(
            f"resolution {resolution} m is too coarse for 0.15 m walls and 0.8 m doors; "
            f"use <= {_MAX_RESOLUTION}"
        )
    rooms = _int_arg(rooms, "rooms", 1)
    furniture_per_room = _int_arg(furniture_per_room, "furniture_per_room", 0)

    if layout == "office":
        min_len, min_depth = _office_min_size(rooms)
        if width < min_len or height < min_depth:
            raise ValueError(
                f"an office floor with {rooms} rooms needs width >= {min_len:.2f} m and height >= "
                f"{min_depth:.2f} m, got {width} x {height}"
            )
    elif layout == "hall":
        inner_w, inner_h = width - 2 * _T_OUTER, height - 2 * _T_OUTER
        if (
            inner_w < _HALL_MIN_SIDE
            or inner_h < _HALL_MIN_SIDE
            or inner_w * inner_h < _HALL_AREA_PER_ROOM * rooms
        ):
            raise ValueError(
                f"a hall with {rooms} rooms needs an interior of at least {_HALL_MIN_SIDE} m per side and "
                f"{_HALL_AREA_PER_ROOM * rooms:.0f} m^2 (width/height include {_T_OUTER} m outer walls), "
                f"got {width} x {height}"
            )
    else:
        min_len, min_depth = _office_min_size(rooms)
        lo, hi = _DIAGONAL_ANGLE
        need_w = _max_sinusoid(min_depth, min_len, lo, hi)
        need_h = _max_sinusoid(min_len, min_depth, lo, hi)
        if width < need_w or height < need_h:
            raise ValueError(
                f"a diagonal floor with {rooms} rooms needs width >= {need_w:.2f} m and height >= "
                f"{need_h:.2f} m (a {min_len:.2f} x {min_depth:.2f} m building rotated by up to 40 deg), "
                f"got {width} x {height}"
            )

    margin_cells = math.ceil(_MARGIN / resolution - 1e-9) + 1
    cols = math.ceil(width / resolution - 1e-9) + 2 * margin_cells
    rows = math.ceil(height / resolution - 1e-9) + 2 * margin_cells
    if rows * cols > _MAX_CELLS:
        raise ValueError(f"raster of {rows} x {cols} cells is too large (limit {_MAX_CELLS:.0e} cells)")
    origin = (-margin_cells * resolution, -margin_cells * resolution)
    canvas = _Canvas(rows, cols, resolution, origin)
    rng = np.random.default_rng(int(seed))

    if layout == "office":
        _build_office(rng, canvas, _Placement(), width, height, rooms, furniture_per_room, [0.0] * 4)
    elif layout == "hall":
        _build_hall(rng, canvas, width, height, rooms, furniture_per_room)
    else:
        theta = float(rng.uniform(*_DIAGONAL_ANGLE)) * (1.0 if rng.random() < 0.5 else -1.0)
        length, depth = _diagonal_building(width, height, theta, min_len, min_depth)
        chamfers = [float(rng.uniform(1.0, 2.0)) if rng.random() < 0.6 else 0.0 for _ in range(4)]
        if not any(chamfers):
            chamfers[int(rng.integers(4))] = float(rng.uniform(1.0, 2.0))
        # rotate about the building centre, then centre the rotated building in the box
        c, s = math.cos(theta), math.sin(theta)
        hx, hy = 0.5 * length, 0.5 * depth
        shift = (0.5 * width - (c * hx - s * hy), 0.5 * height - (s * hx + c * hy))
        _build_office(
            rng, canvas, _Placement(theta, shift), length, depth, rooms, furniture_per_room, chamfers
        )
    clutter = canvas.clutter & ~canvas.walls
    return Floor(walls=canvas.walls, clutter=clutter, resolution=resolution, origin=origin)


# ----------------------------------------------------------------------------------------------------------
# Ray casting
# ----------------------------------------------------------------------------------------------------------


def _box_clearance_levels(occ: NDArray[np.bool_]) -> NDArray[np.uint8]:
    """For each cell the largest ``h`` in (0, 1, 2, 4, ..., 64) such that the ``(2h+1) x (2h+1)`` box of cells
    centred on it contains no occupied cell (cells outside the raster count as free); 0 for occupied cells."""
    out = np.zeros(occ.shape, dtype=np.uint8)
    for h in (1, 2, 4, 8, 16, 32, 64):
        box_occ = _box_any(_box_any(occ, h, axis=1), h, axis=0)
        if box_occ.all():
            break
        out[~box_occ] = h
    return out


def _box_any(a: NDArray[np.bool_], h: int, axis: int) -> NDArray[np.bool_]:
    """``out[i] = any(a[i-h : i+h+1])`` along ``axis`` (clipped at the raster edges), via prefix sums."""
    work = a if axis == 1 else a.T
    rows, n = work.shape
    # ext[:, q] = number of True in work[:, :q - h] (0 for q <= h, the total for q >= n + h)
    ext = np.zeros((rows, n + 2 * h + 1), dtype=np.int32)
    np.cumsum(work, axis=1, out=ext[:, h + 1 : h + 1 + n])
    ext[:, h + 1 + n :] = ext[:, h + n : h + n + 1]
    out = (ext[:, 2 * h + 1 : 2 * h + 1 + n] - ext[:, :n]) > 0
    return out if axis == 1 else out.T


def _cast_grid(
    floor: Floor,
    x: float,
    y: float,
    angles: NDArray[np.float64],
    max_range: float,
) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """Exact first-hit distance (metres) and hit class along rays from (x, y) (inside the raster).

    Amanatides-Woo traversal, vectorised over beams: a ray enters a new cell at each crossing of a vertical
    grid line (x event ``i`` at ``t = (fx + i) / |dx|`` cells) or horizontal grid line (y event ``j``). The
    cell entered at an x event is ``(cy0 + sy * #{y events at t' <= t}, cx0 + sx * (i + 1))`` and
    symmetrically for y events, so the cells along the ray are enumerated in closed form without merging the
    two event sequences. Crossings less than ``_CORNER_TIE`` cells apart count as one corner crossing: both
    events name the diagonal cell and the two cells touched only at the corner are not hit. Events are
    generated in windows of t for the beams still travelling; before each window the beams skip empty space
    using a cached box-clearance map (a beam whose cell is the centre of an occupied-free ``(2h+1)^2`` box
    can advance ``h - 1`` cells without entering an occupied cell; one cell is kept as a rounding guard), so
    the result is still exact. Returns ``inf``/``_FREE`` where nothing is hit within ``max_range`` before the
    ray leaves the raster.
    """
    cls = floor._cell_class()
    rows, cols = cls.shape
    padded = floor._padded_class_flat()  # (rows + 2) * (cols + 2), one free cell around the raster
    stride = cols + 2
    skip = floor._skip_levels()
    res = floor.resolution
    ox, oy = floor.origin
    n = angles.size
    dist = np.full(n, np.inf)
    hit_cls = np.zeros(n, dtype=np.uint8)
    gx = (x - ox) / res
    gy = (y - oy) / res
    cx0 = min(max(math.floor(gx), 0), cols - 1)
    cy0 = min(max(math.floor(gy), 0), rows - 1)
    start = int(cls[cy0, cx0])
    if start != _FREE:
        dist[:] = 0.0
        hit_cls[:] = start
        return dist, hit_cls

    dx, dy = np.cos(angles), np.sin(angles)
    adx, ady = np.abs(dx), np.abs(dy)
    sx = np.where(dx > 0.0, 1.0, -1.0)
    sy = np.where(dy > 0.0, 1.0, -1.0)
    fx = np.where(dx > 0.0, cx0 + 1 - gx, gx - cx0)  # distance (cells) to the first vertical grid line
    fy = np.where(dy > 0.0, cy0 + 1 - gy, gy - cy0)
    inv_x = np.full(n, np.inf)
    inv_y = np.full(n, np.inf)
    np.divide(1.0, adx, out=inv_x, where=adx > 0.0)
    np.divide(1.0, ady, out=inv_y, where=ady > 0.0)
    fx = np.where(adx > 0.0, fx, 1.0)
    fy = np.where(ady > 0.0, fy, 1.0)
    # parameter (cells) at which the ray leaves the raster: nothing beyond can be hit
    # (an axis the ray does not move along never bounds it: 0 * inf would give NaN on an edge)
    with np.errstate(invalid="ignore"):
        t_exit = np.minimum(
            np.where(adx > 0.0, np.where(dx > 0.0, cols - gx, gx) * inv_x, np.inf),
            np.where(ady > 0.0, np.where(dy > 0.0, rows - gy, gy) * inv_y, np.inf),
        )
    t_max = max_range / res
    t_end = np.minimum(t_exit, t_max)
    per_axis = ((fx, inv_x, adx, sx), (fy, inv_y, ady, sy))

    t_cur = np.zeros(n)
    active = np.arange(n)
    window = 16.0
    while active.size:
        # empty-space skipping (exact lower bound on the first hit)
        tc = t_cur[active]
        ddx, ddy = dx[active], dy[active]
        for _ in range(4):
            ci = np.clip(np.floor(gx + tc * ddx), 0, cols - 1).astype(np.intp)
            ri = np.clip(np.floor(gy + tc * ddy), 0, rows - 1).astype(np.intp)
            tc += np.maximum(skip[ri, ci].astype(np.float64) - 1.0, 0.0)
        going = tc < t_end[active]
        active, tc = active[going], tc[going]
        if not active.size:
            break
        t1 = tc + window
        t_hi = np.minimum(t1, t_exit[active])[:, None]
        steps = np.arange(math.ceil(window) + 4, dtype=np.float64)
        best_t = np.full(active.size, np.inf)
        best_c = np.zeros(active.size, dtype=np.uint8)
        for axis in (0, 1):
            f_a, inv_a, a_a, s_a = (v[active][:, None] for v in per_axis[axis])
            f_b, inv_b, a_b, s_b = (v[active][:, None] for v in per_axis[1 - axis])
            idx = np.maximum(np.floor(tc[:, None] * a_a - f_a) - 1.0, 0.0) + steps  # event indices
            t = (f_a + idx) * inv_a
            ok = (t >= tc[:, None]) & (t < t_hi) & (t <= t_max)
            ts = np.where(ok, t, 0.0) + _CORNER_TIE
            # crossings of the other axis at parameter <= t (+ the corner tie tolerance): floor estimate,
            # then a fix-up with the same float comparisons, so that both event sequences agree on the order
            m = np.maximum(np.floor(ts * a_b - f_b) + 1.0, 0.0)
            with np.errstate(invalid="ignore"):  # 0 * inf for beams parallel to the other axis
                m += (f_b + m) * inv_b <= ts
                m -= (m > 0.0) & ((f_b + m - 1.0) * inv_b > ts)
            main = s_a * (idx + 1.0)
            other = s_b * m
            if axis == 0:
                flat = (cy0 + 1.0 + other) * stride + (cx0 + 1.0 + main)
            else:
                flat = (cy0 + 1.0 + main) * stride + (cx0 + 1.0 + other)
            c_hit = np.take(padded, flat.astype(np.intp), mode="clip")
            th = np.where(ok & (c_hit != _FREE), t, np.inf)
            first = th.min(axis=1)
            better = first < best_t
            if better.any():
                rows_b = np.flatnonzero(better)
                best_t[rows_b] = first[rows_b]
                best_c[rows_b] = c_hit[rows_b, np.argmin(th[rows_b], axis=1)]
        found = np.isfinite(best_t)
        dist[active[found]] = best_t[found] * res
        hit_cls[active[found]] = best_c[found]
        keep = ~found & (t_end[active] >= t1)
        t_cur[active[keep]] = t1[keep]
        active = active[keep]
        window = min(window * 2.0, 64.0)
    return dist, hit_cls


def _cast_discs(
    x: float, y: float, angles: NDArray[np.float64], discs: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Exact ray-circle first-hit distance (metres) from (x, y); 0 if the origin is inside a disc."""
    dx, dy = np.cos(angles)[:, None], np.sin(angles)[:, None]
    wx, wy = x - discs[None, :, 0], y - discs[None, :, 1]
    b = dx * wx + dy * wy
    c = wx * wx + wy * wy - discs[None, :, 2] ** 2
    disc = b * b - c
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(np.where(disc >= 0.0, disc, 0.0))
    t = np.where((disc >= 0.0) & (t >= 0.0), t, np.inf)
    t = np.where(c <= 0.0, 0.0, t)
    out: NDArray[np.float64] = t.min(axis=1)
    return out


def _beam_angles(beams: Any, fov: Any) -> tuple[int, float, float]:
    beams = _int_arg(beams, "beams", 2)
    fov = _finite_float(fov, "fov")
    if not 0.0 < fov <= _TWO_PI + _FULL_CIRCLE_TOL:
        raise ValueError(f"fov must be in (0, 2*pi] radians, got {fov}")
    if fov >= _TWO_PI - _FULL_CIRCLE_TOL:
        return beams, -math.pi, _TWO_PI / beams
    return beams, -0.5 * fov, fov / (beams - 1)


def _simulate(
    floor: Floor,
    pose: Any,
    rng: np.random.Generator,
    *,
    beams: int = 1080,
    fov: float = _TWO_PI,
    max_range: float = 30.0,
    min_range: float = 0.1,
    range_sigma: float = 0.015,
    dropout: float = 0.0,
    dynamic_discs: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], float, float, NDArray[np.uint8]]:
    if not isinstance(floor, Floor):
        raise ValueError(f"floor must be a Floor, got {type(floor).__name__}")
    x, y, yaw = _pose_arg(pose)
    beams, angle_min, angle_increment = _beam_angles(beams, fov)
    max_range = _finite_float(max_range, "max_range")
    min_range = _finite_float(min_range, "min_range")
    if min_range < 0.0:
        raise ValueError(f"min_range must be >= 0 metres, got {min_range}")
    if max_range <= min_range:
        raise ValueError(f"max_range ({max_range}) must be > min_range ({min_range})")
    range_sigma = _finite_float(range_sigma, "range_sigma")
    if range_sigma < 0.0:
        raise ValueError(f"range_sigma must be >= 0 metres, got {range_sigma}")
    dropout = _finite_float(dropout, "dropout")
    if not 0.0 <= dropout <= 1.0:
        raise ValueError(f"dropout must be a probability in [0, 1], got {dropout}")
    discs: NDArray[np.float64] | None = None
    if dynamic_discs is not None:
        discs = np.asarray(dynamic_discs, dtype=np.float64)
        if discs.ndim != 2 or discs.shape[1] != 3:
            raise ValueError(f"dynamic_discs must have shape (K, 3) of (x, y, radius), got {discs.shape}")
        if not np.isfinite(discs).all() or (discs[:, 2] <= 0.0).any():
            raise ValueError("dynamic_discs must be finite with radius > 0")
    xmin, ymin, xmax, ymax = floor.extent
    if not (xmin <= x < xmax and ymin <= y < ymax):
        raise ValueError(f"sensor position ({x}, {y}) is outside the floor extent {floor.extent}")

    world = yaw + angle_min + angle_increment * np.arange(beams, dtype=np.float64)
    dist, source = _cast_grid(floor, x, y, world, max_range)
    if discs is not None and discs.shape[0]:
        t_disc = _cast_discs(x, y, world, discs)
        closer = (t_disc <= max_range) & (t_disc < dist)
        dist = np.where(closer, t_disc, dist)
        source = np.where(closer, np.uint8(_DYNAMIC), source).astype(np.uint8)
    noise = rng.normal(0.0, range_sigma, beams) if range_sigma > 0.0 else np.zeros(beams)
    dropped = rng.random(beams) < dropout
    ranges = dist + noise
    ranges[~np.isfinite(dist) | (ranges > max_range)] = np.inf
    ranges[np.isfinite(dist) & (ranges < min_range)] = -np.inf
    ranges[dropped] = np.inf
    source = np.where(np.isfinite(ranges), source, np.uint8(_FREE)).astype(np.uint8)
    return ranges, angle_min, angle_increment, source


def simulate_ranges(
    floor: Floor,
    pose: tuple[float, float, float],
    rng: np.random.Generator,
    *,
    beams: int = 1080,
    fov: float = _TWO_PI,
    max_range: float = 30.0,
    min_range: float = 0.1,
    range_sigma: float = 0.015,
    dropout: float = 0.0,
    dynamic_discs: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], float, float]:
    """Simulate a 2D LIDAR at ``pose`` like a ROS ``LaserScan``.

    Args:
        floor: the floor; walls AND clutter occlude.
        pose: sensor pose ``(x, y, yaw)`` in the map frame (metres, radians); the position must lie inside
            ``floor.extent``. A sensor inside an occupied cell or disc measures 0 (reported as ``-inf``).
        rng: source of noise and dropout (``beams`` normal draws if ``range_sigma > 0``, then ``beams``
            uniform draws, regardless of the geometry).
        beams: number of beams, >= 2.
        fov: field of view in radians, in ``(0, 2*pi]``. Beam ``i`` is at
            ``angle_min + i * angle_increment`` in the sensor frame with ``angle_min = -fov/2``; for a full
            circle ``angle_increment = fov/beams`` (the last beam does not duplicate the first), otherwise
            ``fov/(beams-1)`` (the last beam is at ``+fov/2``).
        max_range, min_range: metres, ``0 <= min_range < max_range``.
        range_sigma: standard deviation (metres) of the additive Gaussian range noise, >= 0.
        dropout: probability in ``[0, 1]`` that a beam returns nothing (``+inf``).
        dynamic_discs: optional ``(K, 3)`` array of ``(x, y, radius)`` (map frame, metres) moving obstacles
            (people) that also occlude, by exact ray-circle intersection.

    Returns:
        ``(ranges, angle_min, angle_increment)``: ``ranges`` is ``(beams,)`` float64 in metres -- the exact
        distance to the first occupied cell boundary (exact grid traversal; a beam passing within 1e-9 cells
        of a cell corner does not hit the cells it only grazes there) or disc, plus noise; ``+inf`` when
        nothing is hit within ``max_range`` (or the noisy range exceeds it) or the beam dropped out; ``-inf``
        when the noisy range is below ``min_range`` (REP-117).

    Raises:
        ValueError: bad ``beams``/``fov``/ranges/``range_sigma``/``dropout``, ``dynamic_discs`` not
            ``(K, 3)`` with positive radii, a non-finite pose or a sensor outside the floor extent.
    """
    ranges, angle_min, angle_increment, _ = _simulate(
        floor, pose, rng, beams=beams, fov=fov, max_range=max_range, min_range=min_range,
        range_sigma=range_sigma, dropout=dropout, dynamic_discs=dynamic_discs,
    )  # fmt: skip
    return ranges, angle_min, angle_increment


def ranges_to_points(
    ranges: ArrayLike,
    angle_min: float,
    angle_increment: float,
    range_min: float = 0.0,
    range_max: float = np.inf,
) -> NDArray[np.float64]:
    """``(M, 2)`` float64 points (metres, sensor frame) of finite ranges within ``[range_min, range_max]``.

    Beam ``i`` points along ``angle_min + i * angle_increment`` (radians, CCW from the sensor's +x axis).
    """
    r = np.asarray(ranges, dtype=np.float64)
    if r.ndim != 1:
        raise ValueError(f"ranges must be a 1-D array, got shape {r.shape}")
    angle_min = _finite_float(angle_min, "angle_min")
    angle_increment = _finite_float(angle_increment, "angle_increment")
    range_min = float(range_min)
    range_max = float(range_max)
    if math.isnan(range_min) or math.isnan(range_max) or range_min > range_max:
        raise ValueError(f"need range_min <= range_max, got {range_min} and {range_max}")
    keep = np.isfinite(r) & (r >= range_min) & (r <= range_max)
    idx = np.flatnonzero(keep)
    a = angle_min + angle_increment * idx
    rk = r[idx]
    return np.column_stack([rk * np.cos(a), rk * np.sin(a)]).astype(np.float64, copy=False)


def simulate_scan(
    floor: Floor, pose: tuple[float, float, float], rng: np.random.Generator, **kwargs: Any
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Convenience wrapper of :func:`simulate_ranges` (same keyword arguments and random draws).

    Returns:
        ``(points, is_clutter)``: ``points`` ``(M, 2)`` float64 in metres in the sensor frame (valid returns
        only, in beam order) and ``is_clutter`` ``(M,)`` bool, True where the return came from clutter or a
        dynamic disc rather than a plan wall.
    """
    ranges, angle_min, angle_increment, source = _simulate(floor, pose, rng, **kwargs)
    valid = np.isfinite(ranges)
    points = ranges_to_points(ranges, angle_min, angle_increment)
    return points, source[valid] != _WALL


def perturb_pose(
    pose: tuple[float, float, float], rng: np.random.Generator, translation: float, rotation: float
) -> tuple[float, float, float]:
    """``pose`` offset by exactly ``translation`` metres in a uniformly random direction and by
    ``+rotation`` or ``-rotation`` radians (random sign). The yaw is wrapped to ``[-pi, pi)``."""
    x, y, yaw = _pose_arg(pose)
    translation = _finite_float(translation, "translation")
    rotation = _finite_float(rotation, "rotation")
    if translation < 0.0 or rotation < 0.0:
        raise ValueError(f"translation and rotation must be >= 0, got {translation} and {rotation}")
    phi = float(rng.uniform(-math.pi, math.pi))
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return (
        x + translation * math.cos(phi),
        y + translation * math.sin(phi),
        _wrap_angle(yaw + sign * rotation),
    )
