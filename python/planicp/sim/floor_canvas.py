"""The canvas a floor is generated on: walls, pillars, doorways, the outer shell and furniture drawn
into boolean rasters, in the map frame (a building may be placed rotated and shifted)."""

from __future__ import annotations

import math
from typing import Final

import numpy as np
from numpy.typing import NDArray

DOOR_CLEAR: Final = 1.0  # keep-clear distance on both sides of a doorway (metres)


class Placement:
    """Rigid transform from the building-local frame to the map frame (rotation about the origin + shift)."""

    def __init__(self, angle: float = 0.0, shift: tuple[float, float] = (0.0, 0.0)) -> None:
        self.angle = angle
        self.c = math.cos(angle)
        self.s = math.sin(angle)
        self.tx, self.ty = shift

    def point(self, x: float, y: float) -> tuple[float, float]:
        return self.c * x - self.s * y + self.tx, self.s * x + self.c * y + self.ty


class Canvas:
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
        clear = self.rect(cx, cy, wall_angle, 0.5 * width + 0.3, DOOR_CLEAR + 0.5 * thickness)
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
