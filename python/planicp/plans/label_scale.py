"""A drawing's scale from its room labels and the rooms they sit in, measured with the doors shut.

`scale_text` reads what a label says ("322 X 347", "13 m²"); this module finds what it is said of:
the room the label is written in, as the 4-connected free region of the drawing's wall mask that
holds the label's position, whose extent (for dimensions: rooms are rectangles) or area with the
islands inside it (for areas: a column or a piece of furniture drawn inside is floor all the same)
is measured in the drawing's own units. Each label gives metres per unit; `combined_scale` takes
the median of the largest group that agrees and leaves the others out. A label on a wall or outside any enclosed
room (on the paper around the building, in a room open to the edge) gives nothing.

Doors are openings in a drawing's walls, so a room's free region runs through its doors into the
next rooms. The rooms are therefore measured with every gap in the walls up to a door's width
(`DOOR_WIDTH`, metres) closed; a width in metres is a number of pixels only once the scale is
known, which is what is sought. `label_scale` solves both together, label by label: it closes
gaps of increasing widths w (pixels; a morphological closing of the walls by a square of about
w + 1 pixels, computed with two chessboard distance transforms) and takes the scale s(w) a label
gives at the first width where w * s(w) reaches a door's width. While w is narrower than a room's
doors the room leaks into its neighbours, is larger than it is, and w * s(w) stays below the
door's width (s(w) is at most the true scale); once w spans the doors the room is whole and s(w)
is the drawing's scale. A room open to the paper through a window drawn as a gap is enclosed once
w spans the window; one enclosed only by closing gaps wider than `WIDEST_OPENING` (an open-plan
area cut off somewhere) is not measured. The closing bridges every gap that narrow, also
between a wall and an island drawn near it (a table 0.5 m from the wall, in the ink read before
the walls are extracted): that island and the strip beside it count as wall, not floor.

A vector drawing (PDF, SVG) is measured the same way in a mask its wall segments are drawn into
(`segments_label_scale`, `LABEL_CELLS` cells across).

Units: the mask's cells are `unit` drawing units (pixels: 1), the labels' positions are in drawing
units with the mask's row 0 at y = 0 growing downwards (image order), as a PDF's text positions are
once flipped, and an image's pixels are.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .scale_text import LabelScale, area_scale, combined_scale, dimension_scale, parse_area, parse_dimensions

__all__ = [
    "DOOR_WIDTH",
    "LABEL_CELLS",
    "WIDEST_OPENING",
    "RoomLabel",
    "close_gaps",
    "label_scale",
    "room_scales",
    "segments_label_scale",
]

DOOR_WIDTH = 1.0
"""Metres: the widest door opening closed when rooms are measured (doors are 0.7 to 1.0 m)."""

WIDEST_OPENING = 2.5
"""Metres: the widest gap a room's walls may have (a window drawn as an opening, a wide door); a
room enclosed only when wider gaps are closed (an open-plan area) is not measured."""

LABEL_CELLS = 4000
"""Cells along the longer side of a vector drawing's walls when they are drawn into a mask to
measure its rooms (`segments_label_scale`): a 60 m building at 1.5 cm per cell."""

_GROWTH = 1.15
"""Ratio between one closing width tried and the next (the scale's closing is at most this coarse)."""


@dataclass(frozen=True)
class RoomLabel:
    """A piece of text written on the drawing.

    Attributes:
        text: the words ("Bedroom 13 m²", "322 X 347").
        x, y: where it is written (a point inside the text: its centre when known), drawing units,
            in the mask's frame (column, row from the top).
        box: (x0, y0, x1, y1) the text's bounding box in the same frame, when known (OCR), else None.
    """

    text: str
    x: float
    y: float
    box: tuple[float, float, float, float] | None = None


def _cv2() -> Any:
    import cv2

    return cv2


def close_gaps(walls: NDArray[np.bool_], width: int, distance: NDArray[np.float32] | None = None) -> NDArray[np.bool_]:
    """`walls` with every gap up to `width` cells wide closed: the morphological closing by a
    square of 2 * ceil(width / 2) + 1 cells. `distance`: the chessboard distance of each cell to
    the nearest wall (`cv2.distanceTransform` of the free cells, DIST_C), when already computed."""
    cv2 = _cv2()
    radius = int(math.ceil(width / 2))
    if radius <= 0:
        return walls
    if distance is None:
        distance = cv2.distanceTransform((~walls).astype(np.uint8), cv2.DIST_C, 3)
    dilated = distance <= radius  # walls grown by the square
    shrunk = cv2.distanceTransform(dilated.astype(np.uint8), cv2.DIST_C, 3) > radius  # and shrunk back
    return np.asarray(shrunk, dtype=np.bool_)


def _filled_area(region: NDArray[np.bool_]) -> int:
    """Cells of `region` plus the cells it encloses (its holes: islands inside a room)."""
    cv2 = _cv2()
    padded = np.pad(region, 1).astype(np.uint8)
    outside = padded.copy()
    mask = np.zeros((padded.shape[0] + 2, padded.shape[1] + 2), np.uint8)
    cv2.floodFill(outside, mask, (0, 0), 2)
    return int((outside != 2).sum())


def room_scales(walls: NDArray[np.bool_], labels: Sequence[RoomLabel], unit: float = 1.0) -> list[LabelScale | None]:
    """The scale each label gives from the room it sits in, in `walls` as it is (no gap closed):
    metres per drawing unit, or None for a label that is no dimension or area label, or that sits
    on a wall or outside every enclosed room (see the module's docstring for units and frames)."""
    cv2 = _cv2()
    count, regions, stats, _ = cv2.connectedComponentsWithStats((~walls).astype(np.uint8), connectivity=4)
    rows, cols = walls.shape
    border = set(np.unique(np.concatenate([regions[0], regions[-1], regions[:, 0], regions[:, -1]])).tolist())
    found: list[LabelScale | None] = []
    for label in labels:
        c, r = int(label.x / unit), int(label.y / unit)
        room = int(regions[r, c]) if 0 <= r < rows and 0 <= c < cols and not walls[r, c] else 0
        if room in border or room == 0:
            found.append(None)
            continue
        width = float(stats[room, cv2.CC_STAT_WIDTH]) * unit
        height = float(stats[room, cv2.CC_STAT_HEIGHT]) * unit
        scale = dimension_scale(label.text, (width, height))
        if scale is None and parse_area(label.text) is not None:
            x0, y0 = int(stats[room, cv2.CC_STAT_LEFT]), int(stats[room, cv2.CC_STAT_TOP])
            box = regions[y0 : y0 + int(stats[room, cv2.CC_STAT_HEIGHT]), x0 : x0 + int(stats[room, cv2.CC_STAT_WIDTH])]
            scale = area_scale(label.text, _filled_area(box == room) * unit * unit)
        found.append(scale)
    return found


def label_scale(
    walls: NDArray[np.bool_],
    labels: Sequence[RoomLabel],
    unit: float = 1.0,
    door_width: float = DOOR_WIDTH,
    widest_opening: float = WIDEST_OPENING,
    max_spread: float = 0.05,
) -> LabelScale | None:
    """Metres per drawing unit from the labels of the rooms they are written in, each room
    measured with the gaps in its walls up to a door's width closed (see the module's docstring);
    None when no label is a dimension or area label inside a room so enclosed.

    Args:
        walls: (rows, cols) bool in image order, True on walls (and everything that bounds a room).
        labels: the drawing's text with its positions.
        unit: drawing units per cell of `walls` (1 for a raster's own pixels).
        door_width: metres: the widest door closed (`DOOR_WIDTH`).
        widest_opening: metres: a room enclosed only by closing wider gaps than this (`WIDEST_OPENING`)
            is not measured.
        max_spread: labels further than this (relative) from the labels' consensus are left out.
    """
    cv2 = _cv2()
    useful = [label for label in labels if parse_dimensions(label.text) or parse_area(label.text)]
    if not useful or walls.size == 0:
        return None
    distance = cv2.distanceTransform((~walls).astype(np.uint8), cv2.DIST_C, 3)
    settled: dict[int, tuple[LabelScale, int]] = {}
    width = 2
    largest = max(walls.shape) // 2
    while width <= largest and len(settled) < len(useful):
        open_ = [i for i in range(len(useful)) if i not in settled]
        closed = close_gaps(walls, width, distance)
        for i, scale in zip(open_, room_scales(closed, [useful[i] for i in open_], unit)):
            if scale is not None and width * unit * scale.metres_per_unit >= door_width:
                settled[i] = (scale, width)
        width = max(width + 1, int(round(width * _GROWTH)))
    kept = []
    for scale, closing in (settled[i] for i in sorted(settled)):
        metres = closing * unit * scale.metres_per_unit
        if metres <= widest_opening:
            note = f"{scale.source}, gaps up to {metres:.2f} m closed"
            kept.append(LabelScale(scale.metres_per_unit, scale.spread, 1, note))
    return combined_scale(kept, max_spread)


def segments_label_scale(
    segments: NDArray[np.float64], labels: Sequence[RoomLabel], cells: int = LABEL_CELLS
) -> LabelScale | None:
    """Metres per drawing unit of a vector drawing (PDF points, SVG pixels) from its room labels:
    the wall segments ((N, 2, 2), drawing units, y down as in an image) drawn as one-cell lines into
    a mask `cells` cells across their longer extent, and `label_scale` run on it; the labels'
    positions are in the segments' frame. None without segments or when no label gives a scale."""
    cv2 = _cv2()
    segs = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    if len(segs) == 0 or not labels:
        return None
    ends = segs.reshape(-1, 2)
    lo, hi = ends.min(axis=0), ends.max(axis=0)
    cell = max(float((hi - lo).max()) / cells, 1e-9)  # drawing units per cell
    margin = 2
    cols, rows = (np.ceil((hi - lo) / cell)).astype(np.int64) + 2 * margin + 1
    mask = np.zeros((int(rows), int(cols)), np.uint8)
    pixels = np.round((segs - lo) / cell + margin).astype(np.int32)
    # 8-connected one-cell lines: 4-connected free space cannot cross them.
    cv2.polylines(mask, list(pixels), False, 1, thickness=1, lineType=cv2.LINE_8)
    shifted = [RoomLabel(t.text, t.x - lo[0] + margin * cell, t.y - lo[1] + margin * cell) for t in labels]
    return label_scale(mask > 0, shifted, unit=cell)
