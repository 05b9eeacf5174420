"""A PDF drawing's scale from its legend: the areas it lists against the colours the rooms are
filled with.

Space-planning drawings (a university's or a company's floor plans) colour each room by who
occupies it and list, in a legend, each colour's swatch beside the total area it covers
("270410 - ROBOTICS ADMINISTRATION, 6,178 USF"). The page draws those rooms as filled shapes of
the swatch's colour, so the area the legend states and the area the page fills give the scale:
metres per point = sqrt(stated area in m² / filled area in points²).

`legend_scale` reads page `page` with pdfminer's layout analysis:

* a legend ENTRY is a line of text with one area and its unit: square feet (USF, RSF, NSF, GSF,
  ASF, SF, sq ft, ft², square feet; commas are thousands separators) or square metres (m², m2,
  sqm, qm; a comma is the decimal mark);
* its SWATCH is the filled shape just left of the line (its vertical extent holding the line's
  middle, its right edge at most three line heights left of the line's start), the nearest one;
* its ROOMS are the other filled shapes of the swatch's colour (each channel within 0.01),
  legend swatches excepted; their area is the sum of their subpaths' areas (curves flattened);
* each entry gives metres per point; the scale is their median, and it is only given when at
  least `MIN_AGREEING` entries agree with it within `AGREEMENT` (a legend whose areas count
  something else than the filled shapes, or a colour also used for another purpose, disagrees);
* the drawing was printed at a round scale: when exactly one round print scale of the areas'
  units (`print_scale.round_print_scale`: 1:100, 1/8" = 1'-0", 1" = 24' ...) lies between the
  least and the largest of the agreeing entries, each widened by `ROUND_TOLERANCE`, the scale is
  that one. The rooms as filled never cover exactly the area the legend states (their outlines
  are drawn a stroke's width in or out of the faces the areas were measured to, the stated areas
  are rounded), so the median is a few tenths of a percent off, which over a building 70 m across
  moves the far walls by 10 cm or more; the round scale the entries allow is exact. Where none,
  or more than one, is allowed, the median stands.

What the stated areas measure (usable, net or gross area) is the drawing's convention: usable
areas leave out walls and shafts, as the filled rooms do when they are drawn to the walls' inner
faces. Needs the `pdf` extra (pdfminer.six).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from .pdf_plan import POINT_METRES as POINT
from .print_scale import round_print_scale

__all__ = ["LegendEntry", "LegendScale", "legend_scale"]

SQUARE_FOOT = 0.09290304
"""Square metres per square foot (exact)."""

AGREEMENT = 0.02
"""Largest relative difference of an entry's metres per point from the median for it to agree."""

MIN_AGREEING = 2
"""How many legend entries must agree on the scale for it to be given."""

ROUND_TOLERANCE = 0.005
"""How far (relative) one entry's scale may be from the drawing's round print scale: the rooms as
filled are drawn a stroke's width in or out of the faces their stated areas were measured to."""

_AREA = re.compile(
    r"(?<![\d.,])(\d{1,3}(?:,\d{3})+|\d+(?:[.,]\d+)?)\s*"
    r"(usf|rsf|nsf|gsf|asf|sf|sq\.?\s?ft\.?|ft²|ft2|square\s+feet|m²|m2|sqm|qm)(?![a-z0-9])",
    re.IGNORECASE,
)


@dataclass(frozen=True)
class LegendEntry:
    """One legend line: its text, the area it states (m²), its swatch's colour (RGB 0..1), how many
    shapes the page fills in that colour and their area (points²), and the metres per point that
    gives."""

    text: str
    area_m2: float
    colour: tuple[float, float, float]
    rooms: int
    area_pt2: float
    metres_per_point: float


@dataclass(frozen=True)
class LegendScale:
    """The scale the legend gives: `metres_per_point` (the round print scale the agreeing entries
    bracket, else their median), the entries read, how many agree within `AGREEMENT`, their
    median, and the round print scale as written ("" when the median stands)."""

    metres_per_point: float
    entries: tuple[LegendEntry, ...]
    agreeing: int
    median: float = math.nan
    round_scale: str = ""

    def describe(self) -> str:
        """One line for the notes: the scale, and the entries that disagree with it."""
        median = self.metres_per_point if math.isnan(self.median) else self.median
        others = [
            f"{e.text!r} ({e.metres_per_point / median - 1.0:+.1%})"
            for e in self.entries
            if abs(e.metres_per_point / median - 1.0) > AGREEMENT
        ]
        said = (
            f"{self.agreeing} of {len(self.entries)} entries agree within {AGREEMENT:.0%} on "
            f"{median:.5g} m per point (1:{median / POINT:.0f} at print size)"
        )
        if self.round_scale:
            said += (
                f"; the one round print scale they allow, {self.round_scale}, taken: "
                f"{self.metres_per_point:.5g} m per point ({self.metres_per_point / median - 1.0:+.2%})"
            )
        return f"the legend's areas against the rooms filled in their colours: {said}" + (
            f"; disagreeing: {', '.join(others)}" if others else ""
        )


def _rgb(value: Any) -> tuple[float, float, float] | None:
    if isinstance(value, (int, float)):
        return (float(value),) * 3
    if isinstance(value, (tuple, list)):
        if len(value) == 1:
            return (float(value[0]),) * 3
        if len(value) == 3:
            return (float(value[0]), float(value[1]), float(value[2]))
        if len(value) == 4:  # CMYK
            c, m, y, k = (float(v) for v in value)
            return ((1 - c) * (1 - k), (1 - m) * (1 - k), (1 - y) * (1 - k))
    return None


_METRIC_AREAS = ("m²", "m2", "sqm", "qm")
"""The area units of `_AREA` that are square metres (the others are square feet)."""


def _is_metric(text: str) -> bool:
    """Whether a legend line (one `_area_m2` reads) states its area in square metres."""
    return _AREA.findall(text)[0][1].casefold() in _METRIC_AREAS


def _area_m2(text: str) -> float | None:
    found = _AREA.findall(text)
    if len(found) != 1:
        return None
    number, unit = found[0]
    metric = unit.casefold() in _METRIC_AREAS
    value = float(number.replace(",", ".") if metric else number.replace(",", ""))
    return value if metric else value * SQUARE_FOOT


def _shoelace(points: list[tuple[float, float]]) -> float:
    if len(points) < 3:
        return 0.0
    p = np.asarray(points, np.float64)
    x, y = p[:, 0], p[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _filled_area(shape: Any) -> float:
    """The area of a filled pdfminer shape, points²: its subpaths' areas summed, curves flattened."""
    path = shape.original_path
    if not path:
        return _shoelace([(float(x), float(y)) for x, y in shape.pts])
    total, current = 0.0, list[tuple[float, float]]()
    for op, *pts in path:
        xy = [(float(x), float(y)) for x, y in pts]
        if op == "m":
            total += _shoelace(current)
            current = xy
        elif op == "l":
            current.extend(xy)
        elif op == "c" and current:
            p0 = np.array(current[-1])
            q = np.array(xy)
            for t in np.linspace(0.0, 1.0, 17)[1:]:
                b = (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * q[0] + 3 * (1 - t) * t**2 * q[1] + t**3 * q[2]
                current.append((float(b[0]), float(b[1])))
        elif op in ("v", "y") and current:
            current.append(xy[-1])
    return total + _shoelace(current)


def legend_scale(path: str | PathLike[str], *, page: int = 1) -> LegendScale | None:
    """The scale page `page` of a PDF gives by its legend's areas (see the module's description),
    metres per PDF point; None when it has no legend entries that agree."""
    from pdfminer.high_level import extract_pages
    from pdfminer.layout import LTCurve, LTTextLine

    lines: list[Any] = []
    fills: list[tuple[Any, tuple[float, float, float]]] = []

    def walk(obj: Any) -> None:
        if isinstance(obj, LTTextLine):
            lines.append(obj)
            return
        if isinstance(obj, LTCurve) and obj.fill:
            colour = _rgb(obj.non_stroking_color)
            if colour is not None:
                fills.append((obj, colour))
        for child in getattr(obj, "_objs", None) or []:
            walk(child)

    for layout in extract_pages(str(Path(path)), page_numbers=[page - 1]):
        walk(layout)
    legend: list[tuple[str, float, Any, tuple[float, float, float]]] = []
    for line in lines:
        text = " ".join(line.get_text().split())
        area = _area_m2(text)
        if area is None or area <= 0.0:
            continue
        middle, height = (line.y0 + line.y1) / 2.0, max(line.y1 - line.y0, 1e-6)
        beside = [
            (line.x0 - shape.x1, shape, colour)
            for shape, colour in fills
            if shape.y0 <= middle <= shape.y1 and -1.0 <= line.x0 - shape.x1 <= 3.0 * height
        ]
        if beside:
            _, swatch, colour = min(beside, key=lambda b: b[0])
            legend.append((text, area, swatch, colour))
    swatches = {id(swatch) for _, _, swatch, _ in legend}
    entries = []
    for text, area, _, colour in legend:
        rooms = [
            shape
            for shape, c in fills
            if id(shape) not in swatches and max(abs(a - b) for a, b in zip(c, colour)) <= 0.01
        ]
        area_pt2 = sum(_filled_area(shape) for shape in rooms)
        if area_pt2 > 0.0:
            entries.append(LegendEntry(text, area, colour, len(rooms), area_pt2, math.sqrt(area / area_pt2)))
    if not entries:
        return None
    median = float(np.median([e.metres_per_point for e in entries]))
    agreeing = [e for e in entries if abs(e.metres_per_point / median - 1.0) <= AGREEMENT]
    if len(agreeing) < MIN_AGREEING:
        return None
    scales = [e.metres_per_point for e in agreeing]
    median = float(np.median(scales))
    metric = [_is_metric(e.text) for e in agreeing]
    low, high = min(scales) * (1.0 - ROUND_TOLERANCE) / POINT, max(scales) * (1.0 + ROUND_TOLERANCE) / POINT
    found = round_print_scale(low, high, metric=any(metric), imperial=not all(metric))
    if found is None:
        return LegendScale(median, tuple(entries), len(agreeing), median)
    return LegendScale(found[0] * POINT, tuple(entries), len(agreeing), median, found[1])
