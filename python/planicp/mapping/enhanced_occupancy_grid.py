"""The enhanced occupancy grid (EOG, thesis section 5.5.1): what the robot saw, fused with the plan.

Every cell of the grid is in one of four states (`EogState`, colours of the thesis's table 5.1):

=====  ==============  ======  ==============================================================
code   state           colour  meaning
=====  ==============  ======  ==============================================================
0      UNKNOWN         grey    never observed, or observed with contradicting evidence
1      FREE            white   scans passed through it: p(occupied) <= `free_threshold`
2      OCCUPIED        black   scans ended in it: p(occupied) >= `occupied_threshold`, and it is
                               not part of a plan wall (an obstacle the plan lacks: furniture,
                               people, a changed building)
3      ARCHITECTURAL   blue    a wall of the plan, whatever the scans say of it
=====  ==============  ======  ==============================================================

How plan and observations combine:

- A plan wall cell is ARCHITECTURAL, observed or not: the plan is the authority on structure. A wall
  that the scans see (an occupied observation in a plan wall cell) is therefore shown ARCHITECTURAL.
- Scans of a wall end on its surface, which lies on the boundary between a wall cell and the free
  cell in front of it; range noise puts about half of those ends in the free cell. An occupied
  observation within `wall_tolerance_cells` cells (Chebyshev distance, default 1) of a plan wall
  cell is that wall seen by the sensor and is also shown ARCHITECTURAL. Anything occupied farther
  from every plan wall is an obstacle the plan lacks and is shown OCCUPIED (black).
- A plan wall cell that the scans consistently see as free (a door drawn closed, a wall that was
  removed) stays ARCHITECTURAL; `plan_conflicts()` lists those cells so they can be reviewed.

The observation layer is a log-odds occupancy grid in the native core (`planicp._core.LogOddsGrid`):
each beam is traced cell by cell from the sensor; cells before its end get a miss, the end cell of
a return gets a hit, each cell at most once per scan and a hit winning over a miss. The grid covers
the plan's extent plus `margin` and grows (keeping its lattice) when a scan reaches beyond it.

Geometry: cells are square, `resolution` metres, axis-aligned in the map frame; arrays are
(rows, cols) with the ROW INDEX GROWING WITH +y, so cell (0, 0) is the lower-left cell and its
lower-left corner is `origin` (the nav_msgs/OccupancyGrid layout). Image exports (`to_png`,
`to_ros_map`) flip the rows, as images put the top row first. The lattice is anchored at the plan
raster's origin (or at multiples of `resolution` for plans built from points), so a grid at the
plan's own resolution lines up with the plan's pixels.
"""

from __future__ import annotations

import math
import threading
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import as_points, as_pose, positive, real_number, whole_number
from ..plans.plan_map import PlanMap
from ..plans.ros_map import write_ros_map
from ..se2 import compose, transform_points
from .eog_state import STATE_COLOURS, EogState
from .occupancy_grid_message import OccupancyGridMessage
from .occupancy_model import OccupancyModel


def _logit(p: float) -> float:
    return math.log(p / (1.0 - p))


def _finest_resolution(width: float, height: float, max_cells: int) -> float:
    """Metres: the smallest cell size r with (width / r + 2) * (height / r + 2) <= max_cells, rounded up
    to two significant digits so that the quoted value itself fits."""
    # (w/r + 2)(h/r + 2) = c  <=>  (c - 4) r^2 - 2 (w + h) r - w h = 0.
    a = max(float(max_cells) - 4.0, 1.0)
    b = 2.0 * (width + height)
    r = (b + math.sqrt(b * b + 4.0 * a * width * height)) / (2.0 * a)
    digits = 10.0 ** (math.floor(math.log10(r)) - 1)
    return math.ceil(r / digits) * digits


def _span(plan: PlanMap) -> NDArray[np.float64]:
    """(width, height) in metres the grid must cover: the plan's points, and its raster's corners."""
    xmin, ymin, xmax, ymax = plan.extent
    span = np.array([xmax - xmin, ymax - ymin])
    if plan.raster is not None:
        corners = _raster_corners(plan)
        span = np.maximum(span, corners.max(axis=0) - corners.min(axis=0))
    return span


DEFAULT_MARGIN = 1.0
"""Metres an `EnhancedOccupancyGrid` extends beyond its plan by default."""

DEFAULT_MAX_CELLS = 1 << 24
"""Most cells an `EnhancedOccupancyGrid` may have by default."""


def finest_resolution(plan: PlanMap, margin: float = DEFAULT_MARGIN, max_cells: int = DEFAULT_MAX_CELLS) -> float:
    """Metres: the finest cell size at which an `EnhancedOccupancyGrid` over `plan` (with `margin`)
    fits in `max_cells` cells, rounded up to two significant digits."""
    w, h = (float(v) for v in _span(plan) + 2.0 * margin)
    return _finest_resolution(w, h, max_cells)


class EnhancedOccupancyGrid:
    """Scans at estimated poses fused with the plan; see the module documentation for the states.

    Args:
        plan: the plan whose walls are the ARCHITECTURAL cells and whose extent sizes the grid.
        resolution: cell size, metres (default 5 cm).
        margin: free space around the plan's extent in the initial grid, metres.
        model: the occupancy update and state thresholds.
        max_range: returns farther than this from the sensor (metres) count as no return.
        no_return_range: beams without a return (`integrate_ranges`: +inf or beyond `range_max`)
            clear the cells up to this distance, metres; 0 (default) leaves them out, since glass
            and black surfaces also return nothing.
        wall_tolerance_cells: occupied observations within this many cells of a plan wall are the
            wall itself (shown ARCHITECTURAL), see the module documentation.
        max_cells: most cells the grid may grow to (two 4-byte values per cell); a scan that would
            need more raises `PlanicpError` and is not integrated.
    """

    def __init__(
        self,
        plan: PlanMap,
        resolution: float = 0.05,
        *,
        margin: float = DEFAULT_MARGIN,
        model: OccupancyModel | None = None,
        max_range: float = 30.0,
        no_return_range: float = 0.0,
        wall_tolerance_cells: int = 1,
        max_cells: int = DEFAULT_MAX_CELLS,
    ) -> None:
        if not isinstance(plan, PlanMap):
            raise TypeError(f"plan must be a PlanMap, got {type(plan).__name__}")
        self.plan = plan
        self.resolution = positive(resolution, "resolution", "metres")
        margin = real_number(margin, "margin")
        if not (math.isfinite(margin) and margin >= 0.0):
            raise ValueError(f"margin must be a finite number of metres >= 0, got {margin!r}")
        self.model = model if model is not None else OccupancyModel()
        self.max_range = positive(max_range, "max_range", "metres")
        no_return = real_number(no_return_range, "no_return_range")
        if not (math.isfinite(no_return) and no_return >= 0.0):
            raise ValueError(f"no_return_range must be a finite number of metres >= 0, got {no_return_range!r}")
        self.no_return_range = no_return
        self.wall_tolerance_cells = whole_number(wall_tolerance_cells, "wall_tolerance_cells", 0, 1000)
        max_cells = whole_number(max_cells, "max_cells", 1, 2**62)

        # The budget from the arithmetic first: the walls' samples at a fine resolution (k^2 per wall
        # pixel) would take gigabytes before the grid could refuse its size.
        span = _span(plan)
        upper = float(np.prod(np.ceil((span + 2.0 * margin) / self.resolution) + 2.0))
        if upper > max_cells:
            # The finest cell that fits: (w/r + 2)(h/r + 2) <= max_cells, solved for r (slightly rounded up).
            w, h = (float(v) for v in span + 2.0 * margin)
            finest = _finest_resolution(w, h, max_cells)
            raise _core.PlanicpError(
                f"the occupancy grid over the plan ({w:.1f} x {h:.1f} m) at {self.resolution:g} m "
                f"would need about {upper:.3g} cells (max_cells {max_cells}); give a resolution "
                f"of at least {finest:.2g} m, a smaller margin or a larger max_cells"
            )
        self._wall_samples = _wall_samples(plan, self.resolution)
        raster = plan.raster
        anchor = (raster.origin[0], raster.origin[1]) if raster is not None and raster.origin[2] == 0.0 else (0.0, 0.0)
        lo = self._wall_samples.min(axis=0) - margin
        hi = self._wall_samples.max(axis=0) + margin
        if plan.raster is not None:
            corners = _raster_corners(plan)
            lo = np.minimum(lo, corners.min(axis=0) - margin)
            hi = np.maximum(hi, corners.max(axis=0) + margin)
        # Cells from the one holding `lo` to the last one starting below `hi` (1e-9 cells of slack
        # against rounding, so that an extent of whole cells is not widened by one).
        first = np.floor((lo - anchor) / self.resolution + 1e-9).astype(np.int64)
        last = np.maximum(np.ceil((hi - anchor) / self.resolution - 1e-9).astype(np.int64) - 1, first)
        cols, rows = (int(v) for v in last - first + 1)
        origin = (anchor[0] + int(first[0]) * self.resolution, anchor[1] + int(first[1]) * self.resolution)
        m = self.model
        self._grid = _Serialized(
            _core.LogOddsGrid(
                rows,
                cols,
                self.resolution,
                origin,
                _logit(m.p_hit),
                _logit(m.p_miss),
                _logit(m.p_min),
                _logit(m.p_max),
                max_cells,
            )
        )
        self._walls_for: tuple[tuple[int, int], tuple[float, float]] | None = None
        self._walls = np.zeros((rows, cols), dtype=bool)

    # --- geometry -------------------------------------------------------------------------------

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols); rows grow with +y."""
        shape: tuple[int, int] = self._grid.shape
        return shape

    @property
    def origin(self) -> tuple[float, float]:
        """Map-frame (x, y) of the lower-left corner of cell (0, 0), metres."""
        origin: tuple[float, float] = self._grid.origin
        return origin

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the grid, metres."""
        with self._grid.lock:  # the origin and the shape of one extent
            (x, y), (rows, cols) = self.origin, self.shape
        return (x, y, x + cols * self.resolution, y + rows * self.resolution)

    @property
    def scans(self) -> int:
        """Scans integrated so far."""
        scans: int = self._grid.scans
        return scans

    # --- integration ----------------------------------------------------------------------------

    def integrate(self, scan_xy: Any, pose: Any, sensor_offset: Any = (0.0, 0.0)) -> None:
        """Adds one scan given as points.

        Args:
            scan_xy: (N, 2) returns in the robot (base) frame, metres (as `Localizer.update`
                takes them; N may be 0).
            pose: T_map_base (x, y, yaw) the scan was taken from (metres, radians).
            sensor_offset: (x, y) or (x, y, yaw) of the laser in the base frame, where the beams
                start (the yaw is not needed: the points are already in the base frame).
        """
        pts = as_points(scan_xy, "scan_xy", allow_empty=True)
        base = as_pose(pose, "pose")
        offset = _offset(sensor_offset)
        sensor = compose(base, (offset[0], offset[1], 0.0))
        hits = transform_points(base, pts) if len(pts) else pts
        self._grid.integrate((sensor[0], sensor[1]), hits, np.zeros((0, 2)), self.max_range)

    def integrate_ranges(
        self,
        ranges: Any,
        angle_min: float,
        angle_increment: float,
        pose: Any,
        *,
        range_min: float,
        range_max: float,
        laser_pose: Any = (0.0, 0.0, 0.0),
    ) -> None:
        """Adds one scan given as a `sensor_msgs/LaserScan` carries it (REP-117 ranges).

        Beam i points at `angle_min + i * angle_increment` in the laser frame. A finite range in
        [range_min, range_max] is a return; +inf or a range above `range_max` is no return and
        clears `no_return_range` metres; NaN, -inf and ranges below `range_min` are skipped.

        Args:
            ranges: (B,) metres.
            angle_min: angle of the first beam, radians.
            angle_increment: angle between beams, radians.
            pose: T_map_base (x, y, yaw) at the scan's time.
            range_min: lower end of the laser's valid interval, metres.
            range_max: upper end of the laser's valid interval, metres.
            laser_pose: (x, y, yaw) of the laser in the base frame.
        """
        r = np.asarray(ranges)
        if r.dtype.kind not in "fiu":
            raise TypeError(f"ranges must hold real numbers, got dtype {r.dtype}")
        if r.ndim != 1:
            raise ValueError(f"ranges must be one-dimensional, got shape {r.shape}")
        r = r.astype(np.float64, copy=False)
        a0, da = real_number(angle_min, "angle_min"), real_number(angle_increment, "angle_increment")
        lo, hi = real_number(range_min, "range_min"), real_number(range_max, "range_max")
        if not (math.isfinite(a0) and math.isfinite(da)):
            raise ValueError(f"angle_min and angle_increment must be finite, got {a0!r}, {da!r}")
        if not (0.0 <= lo < hi and math.isfinite(hi)):
            raise ValueError(f"need 0 <= range_min < range_max (finite), got {lo!r}, {hi!r}")
        base = as_pose(pose, "pose")
        laser = compose(base, as_pose(laser_pose, "laser_pose"))
        angles = laser[2] + a0 + da * np.arange(len(r))
        directions = np.column_stack([np.cos(angles), np.sin(angles)])
        with np.errstate(invalid="ignore"):
            returned = np.isfinite(r) & (r >= lo) & (r <= hi)
            nothing = (r == np.inf) | (np.isfinite(r) & (r > hi))
        origin = np.array(laser[:2])
        hits = origin + directions[returned] * r[returned, None]
        if self.no_return_range > 0.0:
            misses = origin + directions[nothing] * self.no_return_range
        else:
            misses = np.zeros((0, 2))
        self._grid.integrate(
            (laser[0], laser[1]), np.ascontiguousarray(hits), np.ascontiguousarray(misses), self.max_range
        )

    # --- layers and states ----------------------------------------------------------------------

    def probabilities(self) -> NDArray[np.float64]:
        """(rows, cols) p(occupied) from the scans alone; NaN where never observed."""
        with self._grid.lock:  # both layers of one state of the grid
            log_odds = self._grid.log_odds().astype(np.float64)
            observed = self._grid.observed()
        p: NDArray[np.float64] = 1.0 - 1.0 / (1.0 + np.exp(log_odds))
        p[~observed] = np.nan
        return p

    def observation_states(self) -> NDArray[np.uint8]:
        """(rows, cols) UNKNOWN / FREE / OCCUPIED from the scans alone, without the plan (the layer
        `compare_grids` scores)."""
        p = self.probabilities()
        out = np.full(p.shape, EogState.UNKNOWN, dtype=np.uint8)
        with np.errstate(invalid="ignore"):
            out[p <= self.model.free_threshold] = EogState.FREE
            out[p >= self.model.occupied_threshold] = EogState.OCCUPIED
        return out

    def plan_walls(self) -> NDArray[np.bool_]:
        """(rows, cols) bool: cells that hold part of a plan wall."""
        key = (self.shape, self.origin)
        if self._walls_for != key:
            self._walls = _rasterise(self._wall_samples, self.origin, self.shape, self.resolution)
            self._walls_for = key
        walls: NDArray[np.bool_] = self._walls.copy()
        return walls

    def states(self) -> NDArray[np.uint8]:
        """(rows, cols) uint8 `EogState` codes: the plan fused with the observations (module doc)."""
        with self._grid.lock:  # the observations and the walls of one extent
            observed = self.observation_states()
            walls = self.plan_walls()
        out = observed.copy()
        near_walls = _dilate(walls, self.wall_tolerance_cells)
        out[(observed == EogState.OCCUPIED) & near_walls] = EogState.ARCHITECTURAL
        out[walls] = EogState.ARCHITECTURAL
        return out

    def plan_conflicts(self) -> NDArray[np.bool_]:
        """(rows, cols) bool: plan wall cells the scans saw as free (a door drawn closed, a
        removed wall, or a misaligned plan)."""
        with self._grid.lock:
            conflicts: NDArray[np.bool_] = self.plan_walls() & (self.observation_states() == EogState.FREE)
        return conflicts

    # --- exports --------------------------------------------------------------------------------

    def to_occupancy_grid(self) -> OccupancyGridMessage:
        """The grid as `nav_msgs/OccupancyGrid` data: ARCHITECTURAL and OCCUPIED 100, FREE 0, UNKNOWN -1."""
        states = self.states()
        data = np.full(states.shape, -1, dtype=np.int8)
        data[states == EogState.FREE] = 0
        data[(states == EogState.OCCUPIED) | (states == EogState.ARCHITECTURAL)] = 100
        return OccupancyGridMessage(data, self.resolution, (self.origin[0], self.origin[1], 0.0))

    def to_ros_map(self, yaml_path: str | Path) -> Path:
        """Writes a map_server map (YAML + PGM beside it, trinary: occupied 0, free 254, unknown
        205) that `PlanMap.from_ros_map` and nav2's map_server read. Returns the YAML path."""
        grid = self.to_occupancy_grid()
        return write_ros_map(yaml_path, grid.data[::-1], grid.resolution, grid.origin)

    def to_image(self) -> NDArray[np.uint8]:
        """(rows, cols, 3) RGB image in image order (top row = highest y), one pixel per cell,
        coloured by `STATE_COLOURS`."""
        states = self.states()[::-1]
        palette = np.array([STATE_COLOURS[s] for s in EogState], dtype=np.uint8)
        image: NDArray[np.uint8] = palette[states]
        return image

    def to_png(self, path: str | Path, *, scale: int = 1) -> Path:
        """Writes `to_image()` as a PNG, each cell `scale` x `scale` pixels. Returns the path."""
        import cv2

        scale = whole_number(scale, "scale", 1, 64)
        out = Path(path)
        if out.suffix.lower() != ".png":
            raise ValueError(f"PNG path {out} must end in .png")
        image = self.to_image()
        if scale > 1:
            image = np.repeat(np.repeat(image, scale, axis=0), scale, axis=1)
        out.parent.mkdir(parents=True, exist_ok=True)
        if not cv2.imwrite(str(out), np.ascontiguousarray(image[:, :, ::-1])):
            raise OSError(f"could not write the PNG {out}")
        return out

    def __repr__(self) -> str:
        rows, cols = self.shape
        return (
            f"EnhancedOccupancyGrid({rows} x {cols} cells of {self.resolution:g} m, origin "
            f"({self.origin[0]:.3f}, {self.origin[1]:.3f}), {self.scans} scans)"
        )


class _Serialized:
    """The native grid with every call and attribute read under one reentrant `lock`: the native
    object refuses a second call while one runs ("Already borrowed"; 44 of 400 scans integrated from
    four threads), so threads sharing a grid wait for each other instead."""

    def __init__(self, inner: Any) -> None:
        self._inner = inner
        self.lock = threading.RLock()

    def __getattr__(self, name: str) -> Any:
        with self.lock:
            value = getattr(self._inner, name)
        if not callable(value):
            return value

        def serialized(*args: Any, **kwargs: Any) -> Any:
            with self.lock:
                return value(*args, **kwargs)

        return serialized


def _offset(value: Any) -> tuple[float, float]:
    arr = np.asarray(value, dtype=object)
    if arr.shape not in ((2,), (3,)):
        raise ValueError(f"sensor_offset must be (x, y) or (x, y, yaw), got shape {arr.shape}")
    x, y = (real_number(v, "sensor_offset") for v in arr[:2])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"sensor_offset must be finite, got {value!r}")
    return (x, y)


def _raster_corners(plan: PlanMap) -> NDArray[np.float64]:
    assert plan.raster is not None
    rows, cols = plan.raster.shape
    return plan.raster.pixel_to_map(np.array([0.0, 0.0, rows, rows]), np.array([0.0, cols, 0.0, cols]))


def _wall_samples(plan: PlanMap, resolution: float) -> NDArray[np.float64]:
    """Map-frame points covering the plan's walls densely enough that every grid cell a wall
    overlaps holds one: for a raster, k x k points inside each wall pixel (k = pixel / cell size,
    rounded up); for a plan of points, the points."""
    raster = plan.raster
    if raster is None:
        return plan.points
    rows, cols = np.nonzero(raster.walls)
    k = max(1, math.ceil(raster.resolution / resolution - 1e-9))
    offsets = (np.arange(k) + 0.5) / k
    dr, dc = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
    r = (rows[:, None] + dr[None, :]).ravel().astype(np.float64)
    c = (cols[:, None] + dc[None, :]).ravel().astype(np.float64)
    return raster.pixel_to_map(r, c)


def _rasterise(
    points: NDArray[np.float64], origin: tuple[float, float], shape: tuple[int, int], resolution: float
) -> NDArray[np.bool_]:
    rows, cols = shape
    c = np.floor((points[:, 0] - origin[0]) / resolution).astype(np.int64)
    r = np.floor((points[:, 1] - origin[1]) / resolution).astype(np.int64)
    keep = (c >= 0) & (c < cols) & (r >= 0) & (r < rows)
    out = np.zeros(shape, dtype=bool)
    out[r[keep], c[keep]] = True
    return out


def _dilate(mask: NDArray[np.bool_], cells: int) -> NDArray[np.bool_]:
    """`mask` grown by `cells` in Chebyshev distance."""
    if cells == 0 or not mask.any():
        return mask
    import cv2

    kernel = np.ones((2 * cells + 1, 2 * cells + 1), dtype=np.uint8)
    grown: NDArray[np.bool_] = cv2.dilate(mask.astype(np.uint8), kernel).astype(bool)
    return grown
