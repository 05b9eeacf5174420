"""Seeded, furnished synthetic floors in three layouts (``"office"``, ``"hall"``, ``"diagonal"``):
`generate_floor` returns a `Floor` whose walls are the plan and whose
clutter is furniture the plan does not show. All randomness comes from ``np.random.default_rng(seed)``.
"""

from __future__ import annotations

import math
import numbers
from typing import Final

import numpy as np
from numpy.typing import NDArray

from .argument_checks import finite_float, int_arg
from .floor import Floor
from .floor_canvas import Canvas, Placement

__all__ = ["LAYOUTS", "generate_floor"]

#: Layout names accepted by `generate_floor`.
LAYOUTS: Final[tuple[str, ...]] = ("office", "hall", "diagonal")

# Generator constants (metres).
_MARGIN: Final = 1.0  # minimum free margin between the building and the raster border
_T_OUTER: Final = 0.25  # outer wall thickness
_T_MIN: Final = 0.15  # interior wall thickness range
_T_MAX: Final = 0.25
_ROOM_MIN_WIDTH: Final = 4.0  # clear width between wall faces
_ROOM_MIN_DEPTH: Final = 3.0
_CORRIDOR_WIDTH: Final = (1.8, 2.4)
_DOOR_WIDTH: Final = (0.8, 1.2)
_HALL_MIN_SIDE: Final = 6.0
_HALL_AREA_PER_ROOM: Final = 16.0
_DIAGONAL_ANGLE: Final = (math.radians(15.0), math.radians(40.0))
_MAX_RESOLUTION: Final = 0.25
_MAX_CELLS: Final = 100_000_000


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


def _to_map(shapes: list[tuple[str, tuple[float, ...]]], placement: Placement) -> list[tuple[str, tuple[float, ...]]]:
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
    canvas: Canvas,
    placement: Placement,
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
    canvas: Canvas,
    placement: Placement,
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
    canvas: Canvas,
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
    _furnish(rng, canvas, Placement(), box, rooms * furniture_per_room)


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
        layout: one of `LAYOUTS`.
        width: width (x) in metres of the map-frame box the building occupies.
        height: height (y) in metres of that box.
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
    width = finite_float(width, "width")
    height = finite_float(height, "height")
    if width <= 0.0 or height <= 0.0:
        raise ValueError(f"width and height must be > 0 metres, got width={width}, height={height}")
    resolution = finite_float(resolution, "resolution")
    if resolution <= 0.0:
        raise ValueError(f"resolution must be > 0 metres per cell, got {resolution}")
    if resolution > _MAX_RESOLUTION:
        raise ValueError(
            f"resolution {resolution} m is too coarse for 0.15 m walls and 0.8 m doors; use <= {_MAX_RESOLUTION}"
        )
    rooms = int_arg(rooms, "rooms", 1)
    furniture_per_room = int_arg(furniture_per_room, "furniture_per_room", 0)

    if layout == "office":
        min_len, min_depth = _office_min_size(rooms)
        if width < min_len or height < min_depth:
            raise ValueError(
                f"an office floor with {rooms} rooms needs width >= {min_len:.2f} m and height >= "
                f"{min_depth:.2f} m, got {width} x {height}"
            )
    elif layout == "hall":
        inner_w, inner_h = width - 2 * _T_OUTER, height - 2 * _T_OUTER
        if inner_w < _HALL_MIN_SIDE or inner_h < _HALL_MIN_SIDE or inner_w * inner_h < _HALL_AREA_PER_ROOM * rooms:
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
    canvas = Canvas(rows, cols, resolution, origin)
    rng = np.random.default_rng(int(seed))

    if layout == "office":
        _build_office(rng, canvas, Placement(), width, height, rooms, furniture_per_room, [0.0] * 4)
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
        _build_office(rng, canvas, Placement(theta, shift), length, depth, rooms, furniture_per_room, chamfers)
    clutter = canvas.clutter & ~canvas.walls
    return Floor(walls=canvas.walls, clutter=clutter, resolution=resolution, origin=origin)
