"""Where the building is on a plan raster, with its outline closed where the drawing left it open.

The simulation furnishes the building and starts the robot inside it. "Inside" was the largest free
region of the plan image that does not reach the image's edge: on a drawing whose outer walls have
a gap (a door or window drawn as an opening, a wall the extraction lost), the building's rooms
reach the edge through it, and the largest enclosed region is a closet, or nothing, while the
robot could be started on the paper around the building.

`building_outline` finds the building's footprint instead: what a disc as wide as a gap, coming in
from the image's edge, cannot reach without overlapping a wall (it passes no narrower gap), for
gaps of `GAPS` metres up to `max_gap`. The building is the largest
4-connected region of the plan's own free cells within the footprint (its doors stay open, since
the disc only draws the footprint), once the free cells on the footprint's edge at the gaps are
sealed: those `sealed` cells (a straight line across each gap, between the wall ends: the disc's
edge there is an arc bulging into the rooms) are the shut door or window the simulation puts in each gap (a
LIDAR sees them; the plan does not show them, as it does not show a closed door). The smallest gap
that encloses a region at least `OPEN_RATIO` times the largest one enclosed without closing, and
at least `BOX_SHARE` of the free space within the walls' bounding box (not a room shut off at its
door), is taken. A plan whose outline is closed keeps its enclosed region unchanged. A plan that no gap up to
`max_gap` closes is refused, naming the gap and the fix.

Rasters here are in the `Floor`'s order: rows grow with +y. Metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

GAPS = (0.25, 0.5, 1.0, 1.5, 2.0, 3.0)
"""Gap widths tried, metres: the smallest that closes the outline is used."""

MAX_GAP = 3.0
"""Widest gap in a building's outline the simulation closes by default, metres (a double door or a
glass front drawn as an opening; a wider one is more likely a plan that is not a building's)."""

OPEN_RATIO = 1.5
"""The outline counts as open when closing a gap encloses a region this many times larger than the
largest one enclosed without closing."""

BOX_SHARE = 0.5
"""A closed-up building must hold at least this share of the free cells within the walls' bounding
box: closing a gap that only shuts one room off (its door, when the outline's own gap is wider
than `max_gap`) does not find the building."""

REFUSE_SHARE = 0.2
"""A building whose walls enclose, even closed up, less than this share of the free space within
their extent (the hollows inside thick walls drawn as outlines, a closet) is refused: its outline is
open wider than `max_gap`."""

MIN_AREA = 1.0
"""Square metres a building must enclose at least."""


class OpenOutlineWarning(UserWarning):
    """The plan's building outline was open: the simulation closed it (see `BuildingOutline`)."""


@dataclass(frozen=True)
class BuildingOutline:
    """The building on a plan raster (rows growing with +y).

    Attributes:
        inside: (rows, cols) bool: the building's free cells (where furniture, people and the robot
            go).
        sealed: (rows, cols) bool: free cells made solid to close the outline's gaps (none when
            it was closed).
        gap: width of the widest gap closed, metres (0.0: the outline was closed).
        note: one sentence on what was found or done ("" for a closed outline).
    """

    inside: NDArray[np.bool_]
    sealed: NDArray[np.bool_]
    gap: float
    note: str

    @property
    def closed_by_sealing(self) -> bool:
        """The outline was open and the simulation sealed its gaps."""
        return self.gap > 0.0


def building_outline(walls: NDArray[np.bool_], resolution: float, max_gap: float = MAX_GAP) -> BuildingOutline:
    """The building on a plan's wall raster (rows growing with +y), its outline closed if need be.

    Args:
        walls: (rows, cols) bool, True on walls.
        resolution: metres per cell.
        max_gap: widest gap in the outline to close, metres (>= 0; 0 closes none).

    Raises:
        ValueError: no region of at least `MIN_AREA` is enclosed, even with gaps up to `max_gap`
            closed; the message says how to fix the plan.
    """
    free = ~walls
    enclosed = largest_enclosed_region(free)
    cells_min = MIN_AREA / (resolution * resolution)
    base = int(enclosed.sum())
    rows, cols = np.nonzero(walls)
    box_free = int(free[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1].sum()) if len(rows) else 0
    for gap in GAPS:
        if gap > max_gap + 1e-9:
            break
        radius = int(math.ceil(gap / (2.0 * resolution)))
        if radius < 1:
            continue
        footprint, outside = _footprint(walls, radius)
        sealed = free & footprint & _grow(outside)
        candidate = largest_region(free & footprint & ~sealed)
        area = int(candidate.sum())
        if area >= max(OPEN_RATIO * base, cells_min, BOX_SHARE * box_free) and area > base:
            sealed, candidate = _straighten(walls, sealed & _grow(candidate), candidate)
            area = int(candidate.sum())
            note = (
                f"the building's outline is open (gaps up to {gap:g} m lead out of it); the simulation closed "
                f"them with {int((sealed & _grow(candidate)).sum())} cells the plan does not show (shut doors): "
                f"{area * resolution**2:.0f} m^2 inside, against {base * resolution**2:.0f} m^2 enclosed by the "
                "plan alone. Draw the missing outer walls to simulate the building as drawn"
            )
            return BuildingOutline(candidate, sealed, gap, note)
    if base < cells_min or base < REFUSE_SHARE * box_free:
        if base >= cells_min:
            raise ValueError(
                "the plan's building outline is open: the largest region its walls enclose is "
                f"{base * resolution**2:.1f} m^2, {100.0 * base / box_free:.0f} % of the free space within their "
                f"extent, and gaps wider than {max_gap:g} m lead out of the rest. Draw its outer walls closed "
                "(a door or window as a wall), crop the plan to the building, or close wider gaps (max_gap)"
            )
        raise ValueError(
            f"the plan has no enclosed free space of {MIN_AREA:g} m^2 or more to furnish, even with gaps up to "
            f"{max_gap:g} m in its outline closed: the building's outline is open or missing. Draw its outer "
            "walls closed (a door or window as a wall), or crop the plan to the building"
        )
    return BuildingOutline(enclosed, np.zeros_like(walls), 0.0, "")


def _straighten(
    walls: NDArray[np.bool_], seals: NDArray[np.bool_], inside: NDArray[np.bool_]
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Each seal (an arc, the edge of the disc that stopped in the gap, bulging into the building:
    a curved wall no drawing has) made a straight line of cells (8-connected: no ray or 4-connected
    region passes it) between the two farthest of its cells that touch a wall: the shut door or
    window in the line of the wall's ends. Returns (seals, inside); the arcs as they were when the
    lines would not enclose the building whole."""
    import cv2

    count, labels = cv2.connectedComponents(seals.astype(np.uint8), connectivity=8)
    touching = _grow(walls) & seals
    lines = np.zeros(walls.shape, dtype=np.uint8)
    for label in range(1, count):
        rows, cols = np.nonzero((labels == label) & touching)
        if len(rows) < 2:
            return seals, inside
        pts = np.column_stack([cols, rows])
        a = pts[int(np.argmax(((pts - pts[0]) ** 2).sum(axis=1)))]
        b = pts[int(np.argmax(((pts - a) ** 2).sum(axis=1)))]
        cv2.line(lines, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), 1, thickness=1, lineType=cv2.LINE_8)
    straight = lines.astype(np.bool_) & ~walls
    region = largest_enclosed_region(~walls & ~straight)
    if int(region.sum()) < int(inside.sum()) or (inside & ~region & ~straight).any():
        return seals, inside
    return straight & _grow(region), region


def largest_enclosed_region(free: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The largest 4-connected region of `free` that does not touch the raster's edge (empty if
    none); ties go to the region found first in row-major order."""
    import cv2

    count, labels, stats, _ = cv2.connectedComponentsWithStats(free.astype(np.uint8), connectivity=4)
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    sizes = stats[:, cv2.CC_STAT_AREA].astype(np.int64)
    sizes[border] = 0
    sizes[0] = 0
    if count <= 1 or sizes.max() <= 0:
        return np.zeros(free.shape, dtype=np.bool_)
    out: NDArray[np.bool_] = labels == int(np.argmax(sizes))
    return out


def largest_region(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The largest 4-connected region of `mask` (empty if none)."""
    import cv2

    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=4)
    if count <= 1:
        return np.zeros(mask.shape, dtype=np.bool_)
    sizes = stats[:, cv2.CC_STAT_AREA].astype(np.int64)
    sizes[0] = 0
    out: NDArray[np.bool_] = labels == int(np.argmax(sizes))
    return out


def _footprint(walls: NDArray[np.bool_], radius: int) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """(footprint, outside): `outside` is where a disc of `radius` cells coming in from the
    raster's edge can reach without overlapping a wall (so it passes no gap narrower than its
    diameter), `footprint` the rest."""
    import cv2

    # The disc's centres: cells farther than `radius` from every wall, on the raster padded by
    # more than `radius` (the disc comes from beyond the edge). Distances (exact Euclidean) rather
    # than a dilation by a disc kernel: a 3 m gap at 5 mm per cell is a kernel of 600 x 600 cells,
    # minutes on a drawing's raster, against a second.
    pad = radius + 1
    padded = np.pad(walls, pad, constant_values=False)
    centres = (_distance_to(padded) > radius).astype(np.uint8)
    _, labels = cv2.connectedComponents(centres, connectivity=4)
    reached = labels == labels[0, 0]
    outside = (_distance_to(reached) <= radius)[pad:-pad, pad:-pad] & ~walls
    return ~outside, outside


def _distance_to(mask: NDArray[np.bool_]) -> NDArray[np.float32]:
    """Euclidean distance of every cell to the nearest True cell of `mask`, cells (0 on it)."""
    import cv2

    distances = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return np.asarray(distances, dtype=np.float32)


def _grow(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """`mask` grown by one cell in the 8 directions."""
    import cv2

    grown = cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), dtype=np.uint8))
    out: NDArray[np.bool_] = grown.astype(np.bool_)
    return out
