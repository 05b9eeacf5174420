"""The simulated building: the plan's walls plus what the plan does not show.

Furnishing follows the thesis's test room: cabinets along the walls, solid blocks in free space,
single-leg tables (a LIDAR at leg height sees only the leg), and people walking about (moving
discs). Furniture never closes a doorway: an item is placed only if the building's free space stays
one connected region around it. Everything is drawn from a seeded generator.

Frames: map frame, metres. The world's grid is a `planicp.sim.floor.Floor` (rows grow with +y).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..plans.plan_map import PlanMap
from ..plans.plan_raster import PlanRaster
from .building_outline import MAX_GAP, OpenOutlineWarning, building_outline, largest_enclosed_region
from .diff_drive import DiffDriveLimits
from .floor import Floor

DRAWING_RESOLUTION = 0.01
"""Metres per cell at which a plan made of points (a drawing) is rasterised for the simulation."""

PERSONAL_SPACE = 0.3
"""Metres a walking person keeps between their disc and the robot's footprint, and the distance at
which the robot's path ahead makes them give way."""

GIVE_WAY_SPEED = 1.0
"""Least walking speed of a person giving way to the robot, m/s (the robot drives at 0.5 m/s)."""

GIVE_WAY_HEADINGS = 16
"""Directions, evenly spaced, a person giving way to the robot considers."""

GIVE_WAY_HORIZON = 2.0
"""Seconds of the robot's path ahead that the people see coming (`World.advance`)."""

MAX_DRAWING_CELLS = 8_000_000
"""Most cells of a drawing's simulated building (a larger one is rasterised coarser): furnishing
checks the building's connectivity for every piece of furniture."""


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
        notes: what the simulation did to the plan's building (an open outline closed).
    """

    floor: Floor
    people: list[Person] = field(default_factory=list)
    notes: tuple[str, ...] = ()

    @classmethod
    def from_raster(
        cls,
        raster: PlanRaster,
        rng: np.random.Generator,
        furnishing: Furnishing | None = None,
        *,
        max_gap: float = MAX_GAP,
    ) -> World:
        """Furnishes the plan raster (image order, origin yaw 0) with seeded furniture and people.

        The building is found by `building_outline`: an outline the drawing left open (gaps up to
        `max_gap` metres) is closed with cells the plan does not show (shut doors), with an
        `OpenOutlineWarning` and a line in `notes`; the robot, furniture and people are placed
        only inside it. A plan that encloses no building even so is refused (ValueError naming
        the fix)."""
        if abs(raster.origin[2]) > 1e-12:
            raise ValueError("World.from_raster needs a plan raster with origin yaw 0")
        furnishing = furnishing or Furnishing()
        image_walls = np.ascontiguousarray(raster.walls[::-1])  # rows grow with +y
        res = raster.resolution
        outline = building_outline(image_walls, res, max_gap)
        notes: tuple[str, ...] = ()
        if outline.note:
            warnings.warn(OpenOutlineWarning(outline.note), stacklevel=2)
            notes = (outline.note,)
        margin = 3
        walls = np.pad(image_walls, margin, constant_values=False)
        frame = np.pad(np.zeros(raster.walls.shape, dtype=bool), margin, constant_values=True)
        corner = (raster.origin[0] - margin * res, raster.origin[1] - margin * res)
        inside = np.pad(outline.inside, margin, constant_values=False)
        area_100m2 = inside.sum() * res * res / 100.0
        clutter = frame | np.pad(outline.sealed, margin, constant_values=False)
        # The robot and the people start in the floor's largest enclosed free region: when the
        # paper around the building is larger than the building, that is outside it, so it is
        # made solid (it is never seen from inside a closed building).
        enclosed = largest_enclosed_region(~(walls | clutter))
        if not (enclosed & inside).any():
            clutter |= np.pad(~image_walls & ~outline.inside, margin, constant_values=False)
        placer = _Placer(walls, clutter, inside, res, rng)
        for _ in range(int(round(furnishing.cabinets * area_100m2))):
            placer.cabinet()
        for _ in range(int(round(furnishing.blocks * area_100m2))):
            placer.block()
        for _ in range(int(round(furnishing.tables * area_100m2))):
            placer.table_leg()
        world = cls(Floor(walls, clutter, res, corner), notes=notes)
        for _ in range(int(round(furnishing.people * area_100m2))):
            x, y, heading = world.floor.sample_pose(rng, clearance=0.5)
            world.people.append(Person(x, y, heading, float(rng.uniform(0.3, 1.2)), float(rng.uniform(0.18, 0.25))))
        return world

    @classmethod
    def from_plan(
        cls,
        plan: PlanMap,
        rng: np.random.Generator,
        furnishing: Furnishing | None = None,
        *,
        resolution: float = DRAWING_RESOLUTION,
        max_gap: float = MAX_GAP,
    ) -> World:
        """The plan's building furnished: its own raster (an image, a ROS map) or, for a plan made
        of points (a DXF, PDF, SVG or IFC drawing, a HouseExpo outline, segments), its wall points
        rasterised (`drawing_raster`). See `from_raster`."""
        raster = plan.raster
        if raster is None or abs(raster.origin[2]) > 1e-12:
            raster = drawing_raster(plan, resolution)
        return cls.from_raster(raster, rng, furnishing, max_gap=max_gap)

    def discs(self) -> NDArray[np.float64]:
        """(K, 3) people as (x, y, radius), metres."""
        return np.array([(p.x, p.y, p.radius) for p in self.people], dtype=np.float64).reshape(-1, 3)

    def advance(
        self,
        dt: float,
        rng: np.random.Generator,
        keep_clear: tuple[float, float] | None = None,
        *,
        robot_radius: float = DiffDriveLimits.radius,
        robot_ahead: NDArray[np.float64] | None = None,
    ) -> None:
        """Moves every person `dt` seconds ahead, as a body that walls, furniture and the robot stop.

        A person walks straight on and turns to a random new heading when the next step would
        touch a wall or furniture (with 5 cm to spare) or come within `PERSONAL_SPACE` of the
        robot's footprint: the disc of `robot_radius` metres about `keep_clear` (the robot's true
        (x, y) in the map frame, metres; None: no robot). The robot does not steer round people, so
        a person it is about to reach gives way: when `robot_ahead` ((M, 2) map-frame positions
        the robot will pass through next, metres, e.g. its planned path over `GIVE_WAY_HORIZON`
        seconds) comes within `PERSONAL_SPACE` of the person, the person steps, at
        `GIVE_WAY_SPEED` at least, to the free place of `GIVE_WAY_HEADINGS` that keeps farthest
        from that path. A person never steps onto the robot's footprint; one cornered (no free place
        to step) stands still."""
        occupied = self.floor.occupied()
        res, (ox, oy) = self.floor.resolution, self.floor.origin
        rows, cols = occupied.shape
        ahead = None
        if keep_clear is not None:
            here = np.array([keep_clear], dtype=np.float64)
            ahead = here if robot_ahead is None or len(robot_ahead) == 0 else np.vstack([here, robot_ahead[:, :2]])

        def free(x: float, y: float, p: Person) -> bool:
            return _disc_free(occupied, x, y, p.radius + 0.05, res, ox, oy, rows, cols)

        for p in self.people:
            if keep_clear is not None and ahead is not None:
                touching = p.radius + robot_radius
                path_gap = float(np.min(np.hypot(ahead[:, 0] - p.x, ahead[:, 1] - p.y))) - touching
                if path_gap < PERSONAL_SPACE:
                    self._give_way(p, dt, ahead, touching, keep_clear, free)
                    continue
            for _ in range(8):
                nx = p.x + math.cos(p.heading) * p.speed * dt
                ny = p.y + math.sin(p.heading) * p.speed * dt
                if free(nx, ny, p) and (
                    keep_clear is None
                    or math.hypot(nx - keep_clear[0], ny - keep_clear[1]) > p.radius + robot_radius + PERSONAL_SPACE
                ):
                    p.x, p.y = nx, ny
                    break
                p.heading = float(rng.uniform(-math.pi, math.pi))

    @staticmethod
    def _give_way(
        p: Person,
        dt: float,
        ahead: NDArray[np.float64],
        touching: float,
        robot: tuple[float, float],
        free: Callable[[float, float, Person], bool],
    ) -> None:
        """Steps `p` to the free place (or stays) that keeps farthest from the robot's path `ahead`
        and does not overlap the robot at `robot` (centres `touching` metres apart touch)."""
        step = max(p.speed, GIVE_WAY_SPEED) * dt
        best: tuple[float, float, float, float] | None = None
        headings = [p.heading + 2.0 * math.pi * k / GIVE_WAY_HEADINGS for k in range(GIVE_WAY_HEADINGS)]
        candidates = [(p.x, p.y, p.heading)] + [
            (p.x + math.cos(h) * step * share, p.y + math.sin(h) * step * share, h)
            for share in (1.0, 0.5, 0.25)  # shorter steps out of a niche
            for h in headings
        ]
        for nx, ny, heading in candidates:
            if math.hypot(nx - robot[0], ny - robot[1]) <= touching or not free(nx, ny, p):
                continue
            gap = float(np.min(np.hypot(ahead[:, 0] - nx, ahead[:, 1] - ny)))
            if best is None or gap > best[0] + 1e-9:
                best = (gap, nx, ny, heading)
        if best is None:
            return  # cornered: nowhere free to step (`Recording.person_gap` shows if the robot reaches them)
        _, p.x, p.y, p.heading = best
        p.heading = math.atan2(math.sin(p.heading), math.cos(p.heading))

    def clear_start(
        self, position: tuple[float, float], rng: np.random.Generator, robot_radius: float = DiffDriveLimits.radius
    ) -> None:
        """Places anew (as `from_raster` does) every person standing within `PERSONAL_SPACE` of the
        robot's footprint at `position` (map frame, metres): the world is furnished before the
        robot's start is drawn."""
        for p in self.people:
            for _ in range(100):
                if math.hypot(p.x - position[0], p.y - position[1]) > p.radius + robot_radius + PERSONAL_SPACE:
                    break
                p.x, p.y, p.heading = self.floor.sample_pose(rng, clearance=0.5)


def drawing_raster(plan: PlanMap, resolution: float = DRAWING_RESOLUTION) -> PlanRaster:
    """The simulated building's walls for a plan made of points: each wall point's cell and its 8
    neighbours at `resolution` metres per cell (coarser when the plan would need more than
    `MAX_DRAWING_CELLS`), so that points drawn a cell or two apart make a wall no ray passes and
    a LIDAR's returns lie 1 to 2 cells in front of the drawn surface."""
    import cv2

    x0, y0, x1, y1 = plan.extent
    area = max(x1 - x0, resolution) * max(y1 - y0, resolution)
    resolution = max(resolution, math.sqrt(area / MAX_DRAWING_CELLS))
    raster = PlanRaster.from_points(plan.points, resolution, margin=4)
    grown = cv2.dilate(raster.walls.astype(np.uint8), np.ones((3, 3), dtype=np.uint8)).astype(bool)
    return PlanRaster(grown, raster.resolution, raster.origin)


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
