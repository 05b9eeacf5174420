"""The scale of a raster drawing read from its own room labels (OCR): metres per pixel.

1. The drawing's text is read by OCR (`drawing_text`: RapidOCR, installed by hand); only
   dimension and area labels count ("10'1\\" x 11'1\\"", "13 m²": `scale_text`).
2. A first scale from its ink (every dark pixel, the text's boxes erased), no resolution needed:
   `label_scale` measures each labelled room with the gaps up to a door's width closed.
3. The walls are extracted at that scale (`wall_extraction`: furniture, door swings, hatching
   dropped, which need a scale to be told from walls) and the rooms measured again, until the
   scale changes by less than `TOLERANCE` (at most `MAX_ROUNDS` rounds): the walls the plan is
   made of are the ones the rooms are measured in.

The scale found, with the labels that agreed, is what `planicp plan` reports.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .drawing_text import drawing_text
from .label_scale import RoomLabel, label_scale
from .scale_text import LabelScale, parse_area, parse_dimensions

__all__ = ["MAX_ROUNDS", "TOLERANCE", "RasterScale", "raster_label_scale"]

TOLERANCE = 0.002
"""Relative change of the scale between two rounds below which it is taken."""

MAX_ROUNDS = 4
"""Wall extractions at most (each at the previous round's scale)."""

TEXT_MARGIN = 2
"""Pixels around each OCR box erased from the ink with the text."""


@dataclass(frozen=True)
class RasterScale:
    """What a raster drawing's labels say of its scale.

    Attributes:
        scale: metres per pixel with the labels that agreed (`LabelScale`), or None when no
            dimension or area label sits in a room that could be measured.
        text: every line of text OCR read (pixels, image order).
        rounds: wall extractions done to reach `scale`.
    """

    scale: LabelScale | None
    text: tuple[RoomLabel, ...]
    rounds: int

    def describe(self) -> str:
        """One line for `planicp plan`: the scale and where it came from, or why there is none."""
        if self.scale is not None:
            return (
                f"{self.scale.metres_per_unit:.5g} m per pixel from the drawing's room labels read by OCR: "
                f"{self.scale.source}"
            )
        labels = [t.text for t in self.text if parse_dimensions(t.text) or parse_area(t.text)]
        if labels:
            words = ", ".join(repr(t) for t in labels[:4])
            return f"OCR read room labels ({words}) but no room they sit in was enclosed"
        read = ", ".join(repr(t.text) for t in self.text[:4]) + (", ..." if len(self.text) > 4 else "")
        return "OCR read no room dimensions or areas" + (f" (it read {read})" if read else " (no text)")


def _erase_text(ink: NDArray[np.bool_], text: tuple[RoomLabel, ...]) -> NDArray[np.bool_]:
    erased = ink.copy()
    rows, cols = ink.shape
    for label in text:
        if label.box is None:
            continue
        x0, y0, x1, y1 = label.box
        r0, c0 = max(0, int(y0) - TEXT_MARGIN), max(0, int(x0) - TEXT_MARGIN)
        r1, c1 = min(rows, int(np.ceil(y1)) + TEXT_MARGIN + 1), min(cols, int(np.ceil(x1)) + TEXT_MARGIN + 1)
        erased[r0:r1, c0:c1] = False
    return erased


def raster_label_scale(
    source: str | Path | NDArray[Any],
    *,
    threshold: int | None = None,
    open_px: int = 0,
    close_px: int = 0,
    walls: str = "drawing",
    wall_extraction: Any = None,
) -> RasterScale:
    """Metres per pixel of a raster drawing from its room labels (see the module's steps); the
    options are `PlanMap.from_image`'s, so that the rooms are measured in the walls the plan gets.

    Raises:
        ImportError: RapidOCR or ONNX Runtime is not installed (the message says how to install them).
        ValueError: an unreadable image, or one without ink.
    """
    from .plan_raster import load_gray_and_chroma, load_rgb, wall_mask
    from .wall_extraction import check_walls_option, extract_walls

    extraction = check_walls_option(walls, wall_extraction)
    what = f"plan image {source}" if isinstance(source, (str, Path)) else "plan image"
    text = tuple(drawing_text(load_rgb(source, what)))
    if not any(parse_dimensions(t.text) or parse_area(t.text) for t in text):
        return RasterScale(None, text, 0)
    gray, chroma = load_gray_and_chroma(source, what)
    ink = wall_mask(gray, threshold, open_px=open_px, close_px=close_px, what=what)
    found = label_scale(_erase_text(ink, text), text)
    rounds = 0
    if found is None or extraction is None:
        return RasterScale(found, text, rounds)
    while rounds < MAX_ROUNDS:
        rounds += 1
        try:
            extracted = extract_walls(ink, found.metres_per_unit, extraction, chroma, gray).walls
        except ValueError:  # nothing wall-like at this scale: keep the ink's
            break
        again = label_scale(extracted, text)
        if again is None:
            break
        change = abs(again.metres_per_unit / found.metres_per_unit - 1.0)
        found = again
        if change < TOLERANCE:
            break
    return RasterScale(found, text, rounds)
