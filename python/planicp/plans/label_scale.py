"""A drawing's scale from its room labels and the rooms they sit in.

`scale_text` reads what a label says ("322 X 347", "13 m²"); this module finds what it is said of:
the room the label is written in, as the 4-connected free region of the drawing's wall mask that
holds the label's position, whose extent (for dimensions) or area (for areas) is measured in the
drawing's own units. Each label gives metres per unit; `combined_scale` takes their median. A label
outside any enclosed room (on the paper around the building, in a room open to the edge) gives
nothing. Units: the mask's cells are `unit` drawing units (pixels: 1), the labels' positions are
in drawing units with the mask's row 0 at y = 0 growing downwards (image order), as a PDF's text
positions are once flipped, and an image's pixels are.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .scale_text import LabelScale, area_scale, combined_scale, dimension_scale


@dataclass(frozen=True)
class RoomLabel:
    """A piece of text written on the drawing.

    Attributes:
        text: the words ("Bedroom 13 m²", "322 X 347").
        x, y: where it is written, drawing units, in the mask's frame (column, row from the top).
    """

    text: str
    x: float
    y: float


def label_scale(walls: NDArray[np.bool_], labels: Sequence[RoomLabel], unit: float = 1.0) -> LabelScale | None:
    """Metres per drawing unit from the labels of the rooms they are written in (None when no
    label is a dimension or area label inside an enclosed room).

    Args:
        walls: (rows, cols) bool in image order, True on walls (and everything that bounds a room).
        labels: the drawing's text with its positions.
        unit: drawing units per cell of `walls` (1 for a raster's own pixels).
    """
    import cv2

    count, regions, stats, _ = cv2.connectedComponentsWithStats((~walls).astype(np.uint8), connectivity=4)
    rows, cols = walls.shape
    border = set(np.unique(np.concatenate([regions[0], regions[-1], regions[:, 0], regions[:, -1]])).tolist())
    found: list[LabelScale] = []
    for label in labels:
        c, r = int(label.x / unit), int(label.y / unit)
        if not (0 <= r < rows and 0 <= c < cols) or walls[r, c]:
            continue
        room = int(regions[r, c])
        if room in border or room == 0:
            continue
        width = float(stats[room, cv2.CC_STAT_WIDTH]) * unit
        height = float(stats[room, cv2.CC_STAT_HEIGHT]) * unit
        area = float(stats[room, cv2.CC_STAT_AREA]) * unit * unit
        scale = dimension_scale(label.text, (width, height)) or area_scale(label.text, area)
        if scale is not None:
            found.append(scale)
    return combined_scale(found)
