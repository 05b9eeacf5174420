"""The simulated building: the plan's walls plus what the plan does not show.

Furnishing follows the thesis's test room: cabinets along the walls, solid blocks in free space,
single-leg tables (a LIDAR at leg height sees only the leg), and people walking about (moving
discs). Furniture never closes a doorway: an item is placed only if the building's free space stays
one connected region around it. Everything is drawn from a seeded generator.

Frames: map frame, metres. The world's grid is a `planicp.sim.floor.Floor` (rows grow with +y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..plans.plan_raster import PlanRaster
from .floor import Floor


@dataclass(frozen=True)
class Furnishing:
    """How much furniture and how many people (counts per 100 square metres of free floor).

    Attributes:
        cabinets: cabinets against walls (0.35-0.6 m deep, 0.8-2.0 m long).
        blocks: solid blocks standing free (0.5-1.2 m squares).
        tables: single-leg tables (leg radius 4-6 cm).
        people: people walking (discs of 0.18-0.25 m radius, 0.3-1.2 m/s).
    """

    cabinets: float = 3.0
    blocks: float = 0.8
    tables: float = 2.0
    people: float = 1.0

    def __post_init__(self) -> None:
        for name in ("cabinets", "blocks", "tables", "people"):
            value = getattr(self, name)
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not (math.isfinite(value) and value >= 0)
            ):
                raise ValueError(f"Furnishing.{name} must be a finite number >= 0, got {value!r}")


@dataclass
class Person:
    """A walking person: a disc moving straight at constant speed, turning away from obstacles."""

    x: float
    y: float
    heading: float
    speed: float
    radius: float


@dataclass
class World:
    """Walls (the plan) and clutter (furniture) on one grid, plus people.

    Attributes:
        floor: walls and clutter, rows growing with +y.
        people: the walking people, moved by `advance`.
    """

    floor: Floor
    people: list[Person] = field(default_factory=list)

    @classmethod
    def from_raster(cls, raster: PlanRaster, rng: np.random.Generator, furnishing: Furnishing | None = None) -> World:
        """Furnishes the plan raster (image order, origin yaw 0) with seeded furniture and people."""
        if abs(raster.origin[2]) > 1e-12:
            raise ValueError("World.from_raster needs a plan raster with origin yaw 0")
        furnishing = furnishing or Furnishing()
        walls = np.ascontiguousarray(raster.walls[::-1])  # rows grow with +y
        margin = 3
        walls = np.pad(walls, margin, constant_values=False)
        frame = np.pad(np.zeros(raster.walls.shape, dtype=bool), margin, constant_values=True)
        res = raster.resolution
        corner = (raster.origin[0] - margin * res, raster.origin[1] - margin * res)
        # Inside = the largest free region of the plan image not touching the image's edge.
        inside = np.pad(_inside(~np.ascontiguousarray(raster.walls[::-1])), margin, constant_values=False)
        if inside.sum() == 0:
            raise ValueError("the plan has no enclosed free space to furnish (is the building outline closed?)")
        area_100m2 = inside.sum() * res * res / 100.0
        clutter = frame.copy()
        placer = _Placer(walls, clutter, inside, res, rng)
        for _ in range(int(round(furnishing.cabinets * area_100m2))):
            placer.cabinet()
        for _ in range(int(round(furnishing.blocks * area_100m2))):
            placer.block()
        for _ in range(int(round(furnishing.tables * area_100m2))):
            placer.table_leg()
        world = cls(Floor(walls, clutter, res, corner))
        for _ in range(int(round(furnishing.people * area_100m2))):
            x, y, heading = world.floor.sample_pose(rng, clearance=0.5)
            world.people.append(Person(x, y, heading, float(rng.uniform(0.3, 1.2)), float(rng.uniform(0.18, 0.25))))
        return world

    def discs(self) -> NDArray[np.float64]:
        """(K, 3) people as (x, y, radius), metres."""
        return np.array([(p.x, p.y, p.radius) for p in self.people], dtype=np.float64).reshape(-1, 3)

    def advance(self, dt: float, rng: np.random.Generator, keep_clear: tuple[float, float] | None = None) -> None:
        """Moves every person `dt` seconds ahead; a person who would walk into an obstacle (or within
        0.6 m of `keep_clear`, the robot) turns to a random new heading instead."""
        occupied = self.floor.occupied()
        res, (ox, oy) = self.floor.resolution, self.floor.origin
        rows, cols = occupied.shape
        for p in self.people:
            for _ in range(8):
                nx = p.x + math.cos(p.heading) * p.speed * dt
                ny = p.y + math.sin(p.heading) * p.speed * dt
                if _disc_free(occupied, nx, ny, p.radius + 0.05, res, ox, oy, rows, cols) and (
                    keep_clear is None or math.hypot(nx - keep_clear[0], ny - keep_clear[1]) > p.radius + 0.6
                ):
                    p.x, p.y = nx, ny
                    break
                p.heading = float(rng.uniform(-math.pi, math.pi))


def _inside(free_mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    import cv2

    free = free_mask.astype(np.uint8)
    count, labels = cv2.connectedComponents(free, connectivity=4)
    border = set(np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])).tolist())
    sizes = [(int((labels == k).sum()), k) for k in range(1, count) if k not in border]
    if not sizes:
        return np.zeros(free.shape, dtype=bool)
    return np.asarray(labels == max(sizes)[1], dtype=bool)


def _disc_free(
    occ: NDArray[np.bool_], x: float, y: float, r: float, res: float, ox: float, oy: float, rows: int, cols: int
) -> bool:
    c0, c1 = int((x - r - ox) / res), int((x + r - ox) / res)
    r0, r1 = int((y - r - oy) / res), int((y + r - oy) / res)
    if c0 < 0 or r0 < 0 or c1 >= cols or r1 >= rows:
        return False
    return not bool(occ[r0 : r1 + 1, c0 : c1 + 1].any())


class _Placer:
    """Places furniture into `clutter` while the inside stays one connected region."""

    def __init__(
        self,
        walls: NDArray[np.bool_],
        clutter: NDArray[np.bool_],
        inside: NDArray[np.bool_],
        res: float,
        rng: np.random.Generator,
    ) -> None:
        self.walls, self.clutter, self.inside, self.res, self.rng = walls, clutter, inside, res, rng
        self.cells = int(inside.sum())

    def _try(self, mask: NDArray[np.bool_]) -> bool:
        import cv2

        if not (mask & self.inside).sum() == mask.sum() or mask.sum() == 0:
            return False  # must lie entirely in the free interior
        free = (self.inside & ~self.clutter & ~mask).astype(np.uint8)
        count, _ = cv2.connectedComponents(free, connectivity=4)
        if count - 1 != 1:  # would split the building (closes a door or a corridor)
            return False
        self.clutter |= mask
        return True

    def _rect(self, r0: int, c0: int, h: int, w: int) -> NDArray[np.bool_] | None:
        rows, cols = self.walls.shape
        if r0 < 0 or c0 < 0 or r0 + h > rows or c0 + w > cols:
            return None
        mask = np.zeros_like(self.walls)
        mask[r0 : r0 + h, c0 : c0 + w] = True
        return mask

    def cabinet(self) -> bool:
        w = self.walls
        touching = np.zeros_like(w)
        touching[:-1] |= w[1:]
        touching[1:] |= w[:-1]
        touching[:, :-1] |= w[:, 1:]
        touching[:, 1:] |= w[:, :-1]
        rr, cc = np.nonzero(self.inside & ~self.clutter & touching)
        if len(rr) == 0:
            return False
        for _ in range(20):
            k = int(self.rng.integers(len(rr)))
            r, c = int(rr[k]), int(cc[k])
            depth = max(1, int(self.rng.uniform(0.35, 0.6) / self.res))
            length = max(1, int(self.rng.uniform(0.8, 2.0) / self.res))
            for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                nr, nc = r + dr, c + dc
                if not (0 <= nr < self.walls.shape[0] and 0 <= nc < self.walls.shape[1]) or not self.walls[nr, nc]:
                    continue
                # Against the wall on side (dr, dc): extend away from it by `depth`, along it by `length`.
                if dr != 0:
                    r0 = r - depth + 1 if dr == 1 else r
                    mask = self._rect(r0, c - length // 2, depth, length)
                else:
                    c0 = c - depth + 1 if dc == 1 else c
                    mask = self._rect(r - length // 2, c0, length, depth)
                if mask is not None and self._try(mask):
                    return True
        return False

    def block(self) -> bool:
        rr, cc = np.nonzero(self.inside & ~self.clutter)
        for _ in range(20):
            k = int(self.rng.integers(len(rr)))
            size = max(1, int(self.rng.uniform(0.5, 1.2) / self.res))
            mask = self._rect(int(rr[k]) - size // 2, int(cc[k]) - size // 2, size, size)
            if mask is not None and self._try(mask):
                return True
        return False

    def table_leg(self) -> bool:
        rr, cc = np.nonzero(self.inside & ~self.clutter)
        for _ in range(20):
            k = int(self.rng.integers(len(rr)))
            radius = self.rng.uniform(0.04, 0.06) / self.res
            r, c = int(rr[k]), int(cc[k])
            span = int(math.ceil(radius))
            yy, xx = np.mgrid[-span : span + 1, -span : span + 1]
            disc = yy * yy + xx * xx <= radius * radius
            mask = self._rect(r - span, c - span, 2 * span + 1, 2 * span + 1)
            if mask is None:
                continue
            mask[r - span : r + span + 1, c - span : c + span + 1] = disc
            if self._try(mask):
                return True
        return False
