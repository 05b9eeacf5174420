"""Collision-free routes on a synthetic floor: exact clearance inflation, A*, line-of-sight shortening, tours.

Everything is in the map frame of the `Floor` (metres). Walls AND clutter are
obstacles. A cell is *traversable* for a clearance ``c`` when EVERY point of its square is at least ``c``
metres (Euclidean) from every point of every occupied cell square; the route is a polyline whose every point
lies in the closure of a traversable cell, so every point of it keeps the clearance exactly (with respect to
the floor's grid). Cells outside the raster count as free.

numpy, `heapq` and OpenCV (distance transform, connected components); no scipy.
"""

from __future__ import annotations

import heapq
import math
import weakref
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import real_number, whole_number
from .floor import Floor

__all__ = ["Point", "clearance_distance", "plan_route", "reachable", "tour", "traversable"]

Point = tuple[float, float]
"""``(x, y)`` in metres, map frame."""

_SQRT2 = math.sqrt(2.0)
_EPS_T = 1e-12  # segment-parameter intervals shorter than this are exact grid-corner crossings

# Per-floor caches: {clearance: traversable mask}. Floors are immutable and hashed by identity.
_TRAVERSABLE: weakref.WeakKeyDictionary[Floor, dict[float, NDArray[np.bool_]]] = weakref.WeakKeyDictionary()


# ----------------------------------------------------------------------------------------------------------
# Distance transform and inflation
# ----------------------------------------------------------------------------------------------------------


def clearance_distance(occupied: NDArray[np.bool_], resolution: float, max_distance: float) -> NDArray[np.float64]:
    """Per-cell clearance in metres: the Euclidean gap between the cell's SQUARE and the nearest occupied
    cell square, capped at (at least) ``max_distance``.

    Cells at integer offset ``(dr, dc)`` are ``resolution * hypot(max(|dr|-1, 0), max(|dc|-1, 0))`` apart, so
    an occupied cell and its 8 neighbours have gap 0: the gap is the distance between cell centres to the
    occupied cells grown by one cell, which OpenCV's exact Euclidean distance transform gives. Values up to
    ``max_distance`` are exact; a larger one is the cap ``(ceil(max_distance / resolution) + 2) * resolution``
    when the true gap is larger still, and only says that the true gap is above ``max_distance``.

    Args:
        occupied: ``(rows, cols)`` bool grid (row index growing with +y, as in `Floor`).
        resolution: metres per cell, > 0.
        max_distance: metres, >= 0.
    """
    import cv2

    occ = np.asarray(occupied, dtype=np.bool_)
    if occ.ndim != 2:
        raise ValueError(f"occupied must be a 2-D grid, got shape {occ.shape}")
    k = math.ceil(max_distance / resolution) + 1
    cap = float((k + 1) * (k + 1))
    if not occ.any():
        best = np.full(occ.shape, cap)
    else:
        grown = cv2.dilate(
            occ.astype(np.uint8), np.ones((3, 3), dtype=np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0
        )
        centres = cv2.distanceTransform((grown == 0).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        # The transform's float32 distances are square roots of whole numbers: recover those exactly.
        best = np.minimum(np.rint(centres.astype(np.float64) ** 2), cap)
    out: NDArray[np.float64] = np.sqrt(best) * resolution
    return out


def traversable(floor: Floor, clearance: float) -> NDArray[np.bool_]:
    """``(rows, cols)`` read-only bool mask of the cells whose every point is at least ``clearance`` metres
    from every wall and clutter cell (occupied cells themselves are never traversable).

    Cached per floor and clearance.
    """
    floor = _floor_arg(floor)
    clearance = _clearance_arg(clearance)
    per_floor = _TRAVERSABLE.setdefault(floor, {})
    mask = per_floor.get(clearance)
    if mask is None:
        occ = floor.occupied()
        q = clearance / floor.resolution
        if q > 0.0:
            gap2 = (clearance_distance(occ, floor.resolution, clearance) / floor.resolution) ** 2
            blocked = occ | (gap2 < q * q)
        else:
            blocked = occ
        mask = ~blocked
        mask.flags.writeable = False
        per_floor[clearance] = mask
    return mask


def reachable(floor: Floor, start_xy: Any, clearance: float) -> NDArray[np.bool_]:
    """``(rows, cols)`` bool mask of the traversable cells an 8-connected route from ``start_xy`` reaches.

    Raises:
        ValueError: ``start_xy`` outside the floor or not in a traversable cell.
    """
    floor = _floor_arg(floor)
    free = traversable(floor, clearance)
    cell = _cell_of(floor, _point_arg(start_xy, "start_xy"), "start_xy")
    _require_traversable(free, cell, start_xy, "start_xy", clearance)
    import cv2

    _, labels = cv2.connectedComponents(free.astype(np.uint8), connectivity=8)
    out: NDArray[np.bool_] = labels == labels[cell]
    return out


# ----------------------------------------------------------------------------------------------------------
# Routes
# ----------------------------------------------------------------------------------------------------------


def plan_route(floor: Floor, start_xy: Any, goal_xy: Any, clearance: float) -> list[Point]:
    """Shortest collision-free route from ``start_xy`` to ``goal_xy`` keeping ``clearance`` metres from walls
    and clutter, as a short list of waypoints.

    Method: the occupied cells (walls | clutter) are inflated by ``clearance`` with an exact distance
    transform (`traversable`); A* (8-connected, move costs 1 and sqrt(2) cells; heuristic the exact
    cost-to-go from a vectorised wavefront out of the goal, admissible and consistent, so the grid path is
    optimal and A* expands few cells) runs from the cell of ``start_xy`` to the cell of ``goal_xy``;
    the polyline ``start_xy -> cell centres -> goal_xy`` is then shortened greedily: from each kept waypoint
    the route jumps to the farthest following point whose straight segment only crosses traversable cells
    (exact grid traversal of the segment).

    Args:
        floor: the floor (map frame, metres).
        start_xy: ``(x, y)`` in metres; must lie in a traversable cell.
        goal_xy: ``(x, y)`` in metres; must lie in a traversable cell.
        clearance: metres, >= 0; typically the robot radius plus a margin.

    Returns:
        ``[start_xy, ..., goal_xy]`` as float tuples (metres). Every point of every segment lies in the closure
        of a traversable cell, so it is at least ``clearance`` from every occupied cell square. A start equal
        to the goal cell gives ``[start_xy, goal_xy]``.

    Raises:
        ValueError: bad ``clearance``; a point outside the floor, inside a wall/clutter cell or within
            ``clearance`` of one; or no route (the goal is not connected to the start).
    """
    floor = _floor_arg(floor)
    clearance = _clearance_arg(clearance)
    start = _point_arg(start_xy, "start_xy")
    goal = _point_arg(goal_xy, "goal_xy")
    free = traversable(floor, clearance)
    s_cell = _cell_of(floor, start, "start_xy")
    g_cell = _cell_of(floor, goal, "goal_xy")
    _require_traversable(free, s_cell, start, "start_xy", clearance)
    _require_traversable(free, g_cell, goal, "goal_xy", clearance)
    cols = free.shape[1]
    stride = cols + 2
    padded = _pad(free)
    s, g = _padded_index(s_cell, cols), _padded_index(g_cell, cols)
    cost_to_go = _cost_to_go(padded, stride, g, s)
    if not math.isfinite(cost_to_go[s]):
        raise ValueError(
            f"no route from start_xy {start} to goal_xy {goal} with {clearance} m clearance: the goal is not "
            "connected to the start (closed doors or passages narrower than twice the clearance)"
        )
    cells = _astar(cost_to_go, stride, s, g)
    res = floor.resolution
    ox, oy = floor.origin
    pr, pc = np.divmod(np.asarray(cells, dtype=np.int64), stride)
    centres = np.column_stack([ox + (pc - 1 + 0.5) * res, oy + (pr - 1 + 0.5) * res])
    points = np.vstack([np.array([start]), centres, np.array([goal])])
    keep = _shorten(points, padded, stride, floor)
    route = [(float(points[i, 0]), float(points[i, 1])) for i in keep]
    return _dedupe(route)


def tour(
    floor: Floor,
    rng: np.random.Generator,
    legs: int,
    clearance: float,
    min_leg_length: float = 4.0,
    *,
    start_xy: Any = None,
) -> list[Point]:
    """Waypoints of a tour that drives to ``legs`` random reachable positions, one route after another.

    Each goal is drawn uniformly (by area) among the traversable cells reachable from the start whose centre
    is at least ``min_leg_length`` metres (straight line) from the current position -- in an office floor
    that sends the robot through doorways into different rooms and along the corridor; when no reachable cell
    is that far, the goal is drawn among the farthest 10 % of the reachable cells. The position inside the
    cell is uniform. Consecutive routes (`plan_route`) are chained without repeating the joints.

    Args:
        floor: the floor.
        rng: seeded generator for the start (when ``start_xy`` is None) and the goals.
        legs: number of goals, >= 1.
        clearance: metres, >= 0 (see `plan_route`).
        min_leg_length: metres, >= 0.
        start_xy: ``(x, y)`` start in metres; None draws it with ``floor.sample_pose(rng, clearance)``.

    Returns:
        ``[start, ..., goal_1, ..., goal_legs]`` waypoints (metres, map frame).

    Raises:
        ValueError: bad arguments, a start outside the traversable space, no free position with the
            clearance, or nothing else reachable from the start.
    """
    floor = _floor_arg(floor)
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    legs = whole_number(legs, "legs", 1)
    clearance = _clearance_arg(clearance)
    min_leg_length = real_number(min_leg_length, "min_leg_length")
    if not (math.isfinite(min_leg_length) and min_leg_length >= 0.0):
        raise ValueError(f"min_leg_length must be a finite number >= 0 metres, got {min_leg_length!r}")
    if start_xy is None:
        x, y, _ = floor.sample_pose(rng, clearance)
        start: Point = (x, y)
    else:
        start = _point_arg(start_xy, "start_xy")
    cells = np.flatnonzero(reachable(floor, start, clearance))
    start_cell = _cell_of(floor, start, "start_xy")
    cells = cells[cells != start_cell[0] * floor.shape[1] + start_cell[1]]
    if cells.size == 0:
        raise ValueError(f"no traversable position is reachable from start_xy {start} with {clearance} m clearance")
    res = floor.resolution
    ox, oy = floor.origin
    cr, cc = np.divmod(cells, floor.shape[1])
    cx = ox + (cc + 0.5) * res
    cy = oy + (cr + 0.5) * res
    waypoints: list[Point] = [start]
    here = start
    for _ in range(legs):
        dist = np.hypot(cx - here[0], cy - here[1])
        pool = np.flatnonzero(dist >= min_leg_length)
        if pool.size == 0:
            pool = np.flatnonzero(dist >= np.quantile(dist, 0.9))
        k = int(pool[int(rng.integers(pool.size))])
        u, v = rng.random(2)
        goal = (float(ox + (cc[k] + u) * res), float(oy + (cr[k] + v) * res))
        waypoints.extend(plan_route(floor, here, goal, clearance)[1:])
        here = goal
    return waypoints


# ----------------------------------------------------------------------------------------------------------
# Internals
# ----------------------------------------------------------------------------------------------------------

_OFFSETS_CACHE: dict[int, tuple[NDArray[np.int64], list[tuple[int, float]]]] = {}


def _moves(stride: int) -> tuple[NDArray[np.int64], list[tuple[int, float]]]:
    got = _OFFSETS_CACHE.get(stride)
    if got is None:
        pairs = [(dr * stride + dc, _SQRT2 if dr and dc else 1.0)
                 for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]  # fmt: skip
        got = (np.array([p[0] for p in pairs], dtype=np.int64), pairs)
        _OFFSETS_CACHE[stride] = got
    return got


def _pad(free: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Flattened mask with a ring of non-traversable cells, so neighbours never leave the array."""
    out: NDArray[np.bool_] = np.pad(free, 1, constant_values=False).ravel()
    return out


def _padded_index(cell: tuple[int, int], cols: int) -> int:
    return (cell[0] + 1) * (cols + 2) + cell[1] + 1


def _cost_to_go(free: NDArray[np.bool_], stride: int, goal: int, start: int) -> NDArray[np.float64]:
    """8-connected path cost (cells; moves cost 1 and sqrt(2)) to ``goal`` over the padded flat mask: exact
    (to 1e-9 cells) for every cell whose cost is at most the start's, ``inf`` or an upper bound above the
    start's cost elsewhere; ``dist[start]`` is ``inf`` when the start is not connected to the goal.

    Vectorised label-correcting wavefront (Bellman-Ford restricted to the cells improved in the previous
    round). After round ``k`` every cell whose optimal path has at most ``k`` moves is exact, and a path of
    cost ``c`` has at most ``c`` moves, so the wave stops after the round that exceeds the start's cost.
    """
    offsets, moves = _moves(stride)
    costs = np.array([c for _, c in moves], dtype=np.float64)
    dist = np.full(free.size, np.inf)
    dist[goal] = 0.0
    frontier = np.array([goal], dtype=np.int64)
    rounds = 0
    while frontier.size and rounds <= dist[start]:
        rounds += 1
        nb = (frontier[:, None] + offsets[None, :]).ravel()
        cand = (dist[frontier][:, None] + costs[None, :]).ravel()
        better = free[nb] & (cand < dist[nb] - 1e-9)
        nb, cand = nb[better], cand[better]
        order = np.lexsort((cand, nb))  # per cell, its best candidate first
        nb, cand = nb[order], cand[order]
        first = np.ones(nb.size, dtype=np.bool_)
        first[1:] = nb[1:] != nb[:-1]
        frontier = nb[first]
        dist[frontier] = cand[first]
    return dist


def _astar(cost_to_go: NDArray[np.float64], stride: int, start: int, goal: int) -> list[int]:
    """Optimal 8-connected grid path (padded flat indices, start..goal) among the cells with a finite cost.

    The heuristic is the exact cost-to-go (admissible and consistent where it can matter: cells costlier
    than the start are never expanded), so A* closes little more than the cells of one optimal path; ties in
    ``f`` go to the cell nearer the goal.
    """
    _, moves = _moves(stride)
    h = np.ascontiguousarray(cost_to_go, dtype=np.float64).data  # fast per-item float access
    g_cost: dict[int, float] = {start: 0.0}
    parent: dict[int, int] = {start: -1}
    closed: set[int] = set()
    heap: list[tuple[float, float, int]] = [(h[start], h[start], start)]
    while heap:
        _, _, node = heapq.heappop(heap)
        if node in closed:
            continue
        if node == goal:
            break
        closed.add(node)
        g_node = g_cost[node]
        for off, cost in moves:
            nb = node + off
            h_nb = h[nb]
            if h_nb == math.inf or nb in closed:
                continue
            ng = g_node + cost
            if ng < g_cost.get(nb, math.inf):
                g_cost[nb] = ng
                parent[nb] = node
                heapq.heappush(heap, (ng + h_nb, h_nb, nb))
    path = [goal]
    while path[-1] != start:
        path.append(parent[path[-1]])
    path.reverse()
    return path


def _segment_clear(p0: NDArray[np.float64], p1: NDArray[np.float64], free: NDArray[np.bool_], stride: int,
                   floor: Floor) -> bool:  # fmt: skip
    """Whether every cell the segment p0-p1 passes through (exact traversal) is traversable.

    The segment is cut at every crossing of a grid line; the cell of each piece is the cell of its midpoint.
    Pieces of zero length (the segment passes exactly through a grid corner) are skipped: the corner belongs
    to the closure of the cells before and after it, which are checked.
    """
    res = floor.resolution
    ox, oy = floor.origin
    u0, v0 = (p0[0] - ox) / res + 1.0, (p0[1] - oy) / res + 1.0  # padded grid coordinates
    u1, v1 = (p1[0] - ox) / res + 1.0, (p1[1] - oy) / res + 1.0
    du, dv = u1 - u0, v1 - v0
    parts = [np.array([0.0, 1.0])]
    if du != 0.0:
        ks = np.arange(math.floor(min(u0, u1)) + 1, math.ceil(max(u0, u1)), dtype=np.float64)
        parts.append((ks - u0) / du)
    if dv != 0.0:
        ks = np.arange(math.floor(min(v0, v1)) + 1, math.ceil(max(v0, v1)), dtype=np.float64)
        parts.append((ks - v0) / dv)
    t = np.sort(np.clip(np.concatenate(parts), 0.0, 1.0))
    length = np.diff(t)
    mid = 0.5 * (t[:-1] + t[1:])[length > _EPS_T]
    if mid.size == 0:
        mid = np.array([0.5])
    cu = np.floor(u0 + mid * du).astype(np.int64)
    cv = np.floor(v0 + mid * dv).astype(np.int64)
    rows = free.size // stride
    if (cu < 0).any() or (cu >= stride).any() or (cv < 0).any() or (cv >= rows).any():
        return False
    return bool(free[cv * stride + cu].all())


def _shorten(points: NDArray[np.float64], free: NDArray[np.bool_], stride: int, floor: Floor) -> list[int]:
    """Indices of the kept points.

    First pass: from each kept point, jump to the last point of the run of following points it sees
    (consecutive grid points are always connected). Second pass, repeated until nothing changes: drop every
    kept point whose two kept neighbours see each other (removes the short zig-zags the first pass leaves).
    """
    n = len(points)
    keep = [0]
    i = 0
    while i < n - 1:
        j = i + 1
        while j + 1 < n and _segment_clear(points[i], points[j + 1], free, stride, floor):
            j += 1
        keep.append(j)
        i = j
    changed = True
    while changed and len(keep) > 2:
        changed = False
        k = 1
        while k < len(keep) - 1:
            if _segment_clear(points[keep[k - 1]], points[keep[k + 1]], free, stride, floor):
                del keep[k]
                changed = True
            else:
                k += 1
    return keep


def _dedupe(route: list[Point]) -> list[Point]:
    out = [route[0]]
    for p in route[1:-1]:
        if math.hypot(p[0] - out[-1][0], p[1] - out[-1][1]) > 1e-9:
            out.append(p)
    last = route[-1]
    if len(out) > 1 and math.hypot(last[0] - out[-1][0], last[1] - out[-1][1]) <= 1e-9:
        out[-1] = last
    else:
        out.append(last)
    return out


def _floor_arg(floor: Any) -> Floor:
    if not isinstance(floor, Floor):
        raise TypeError(f"floor must be a planicp.sim.Floor, got {type(floor).__name__}")
    return floor


def _clearance_arg(clearance: Any) -> float:
    value = real_number(clearance, "clearance")
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"clearance must be a finite number >= 0 metres, got {clearance!r}")
    return value


def _point_arg(value: Any, name: str) -> Point:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be (x, y) in metres, got {value!r}") from None
    if arr.shape != (2,) or not np.isfinite(arr).all():
        raise ValueError(f"{name} must be two finite numbers (x, y) in metres, got {value!r}")
    return float(arr[0]), float(arr[1])


def _cell_of(floor: Floor, p: Point, name: str) -> tuple[int, int]:
    xmin, ymin, xmax, ymax = floor.extent
    if not (xmin <= p[0] < xmax and ymin <= p[1] < ymax):
        raise ValueError(f"{name} {p} is outside the floor extent {floor.extent}")
    rows, cols = floor.shape
    c = min(int(math.floor((p[0] - xmin) / floor.resolution)), cols - 1)
    r = min(int(math.floor((p[1] - ymin) / floor.resolution)), rows - 1)
    return r, c


def _require_traversable(free: NDArray[np.bool_], cell: tuple[int, int], p: Any, name: str, clearance: float) -> None:
    if not free[cell]:
        raise ValueError(
            f"{name} {tuple(p)} is inside a wall or furniture or closer than the clearance of {clearance} m to one"
        )
