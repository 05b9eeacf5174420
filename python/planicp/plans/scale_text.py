"""A drawing's scale from the words written in its rooms: dimensions ("322 X 347", '11\\'7" x 15\\'7"')
and areas ("13 m²", "140 sq ft").

Floor plans for sale or rent rarely carry a scale bar, but most write each room's size in it: its
two sides, or its area. Against the room's size in the drawing's own units (pixels, PDF points, SVG
user units) each label gives the metres per unit:

* `parse_dimensions`: two lengths "A x B" in metres. Units as written (m, cm, mm, feet and
  inches: `11'7"`, `11' 7"`, `11 ft 7 in`, `11'-7"`); bare numbers are centimetres when both are
  whole numbers of at least 100 (architects' "322 X 347"), metres when either has a decimal point
  or comma ("3,22 x 3,47") and is below 100, else refused (None).
* `parse_area`: an area in square metres: "13 m²", "13 m2", "13.5 sqm", "13,5 m^2", "140 sq ft",
  "140 ft²", "140 sf".
* `dimension_scale`: metres per unit from a room's two sides and its extent in units (the
  dimension's sides matched to the extent's sorted sides: rooms are labelled width by length in
  either order); `area_scale` from an area and the room's area in square units.
* `combined_scale`: the median of the largest group of labels that agree, with their spread and
  how many agreed.

Each returns the scale and where it came from, as `planicp plan` reports it. Units: metres,
square metres; a drawing's unit is whatever its coordinates count.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = [
    "LabelScale",
    "area_scale",
    "combined_scale",
    "dimension_scale",
    "parse_area",
    "parse_dimensions",
]

FOOT = 0.3048
"""Metres in an international foot."""

INCH = 0.0254
"""Metres in an inch."""

_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
_DECIMAL = r"\d+(?:[.,]\d+)?"
_FEET_INCHES = re.compile(
    r"(?P<feet>\d+(?:\.\d+)?)\s*(?:'|’|′|ft\.?|feet|foot)\s*-?\s*"
    r"(?:(?P<inches>\d+(?:\.\d+)?(?:\s+\d+/\d+)?|\d+/\d+)\s*(?:\"|”|″|''|in\.?|inches|inch))?",
    re.IGNORECASE,
)
_METRIC = re.compile(rf"(?P<number>{_DECIMAL})\s*(?P<unit>mm|cm|m)?(?![a-z²2])", re.IGNORECASE)
_SEPARATOR = re.compile(r"\s*(?:x|×|\*|by)\s*", re.IGNORECASE)
_AREA = re.compile(
    rf"(?P<number>{_DECIMAL})\s*(?P<unit>m\s*(?:²|\^?2)|sq\.?\s*m|sqm|ft\s*(?:²|\^?2)|sq\.?\s*ft|sf)(?![a-z])",
    re.IGNORECASE,
)


def _decimal(text: str) -> float:
    return float(text.replace(",", "."))


def _fraction(text: str) -> float:
    text = text.strip()
    if " " in text:
        whole, frac = text.split(None, 1)
        return float(whole) + _fraction(frac)
    if "/" in text:
        num, den = (float(t) for t in text.split("/"))
        return num / den if den else math.nan
    return float(text)


def _imperial(text: str) -> float | None:
    match = _FEET_INCHES.fullmatch(text.strip())
    if match is None:
        return None
    inches = _fraction(match["inches"]) if match["inches"] else 0.0
    return float(match["feet"]) * FOOT + inches * INCH


def parse_dimensions(text: str) -> tuple[float, float] | None:
    """The two lengths of a room's dimension label, in metres, in the order written; None when
    `text` holds no such label (or its bare numbers say no unit: see the module's docstring).

    >>> parse_dimensions("322 X 347")
    (3.22, 3.47)
    """
    parts = _SEPARATOR.split(text.strip(), maxsplit=1)
    if len(parts) != 2:
        return None
    sides = [_imperial(p) for p in parts]
    if all(s is not None for s in sides):
        a, b = sides
        assert a is not None and b is not None
        return (a, b) if a > 0.0 and b > 0.0 else None
    found = [_METRIC.fullmatch(p.strip()) for p in parts]
    metric = [m for m in found if m is not None]
    if len(metric) != 2:
        return None
    numbers = [_decimal(m["number"]) for m in metric]
    units = [m["unit"].lower() if m["unit"] else None for m in metric]
    unit = units[1] or units[0]  # "3.22 x 3.47 m": the unit written once, after both
    if unit is None:
        whole = all("," not in m["number"] and "." not in m["number"] for m in metric)
        if whole and min(numbers) >= 100:
            unit = "cm"
        elif not whole and max(numbers) < 100:
            unit = "m"
        else:
            return None
    first = _UNITS[units[0] or unit] * numbers[0]
    second = _UNITS[units[1] or unit] * numbers[1]
    return (first, second) if first > 0.0 and second > 0.0 else None


def parse_area(text: str) -> float | None:
    """The area an area label states, in square metres ("13 m²" is 13.0, "140 sq ft" 13.006...),
    or None when `text` states none."""
    match = _AREA.search(text)
    if match is None:
        return None
    value = _decimal(match["number"])
    unit = re.sub(r"[\s.^]", "", match["unit"].lower())
    metres2 = value * (FOOT * FOOT if unit.startswith(("ft", "sqft", "sf")) else 1.0)
    return metres2 if metres2 > 0.0 else None


@dataclass(frozen=True)
class LabelScale:
    """A drawing's scale from its labels.

    Attributes:
        metres_per_unit: metres in the building per unit of the drawing's coordinates.
        spread: relative spread of the labels' scales (1.4826 MAD / median; 0 for one label).
        labels: labels that gave a scale.
        source: where it came from, for a person: the labels' words and how many agreed.
    """

    metres_per_unit: float
    spread: float
    labels: int
    source: str


def dimension_scale(text: str, extent: tuple[float, float]) -> LabelScale | None:
    """Metres per unit from a dimension label and the (width, height) of its room in the drawing's
    units (the free space the label sits in); None when `text` is no dimension label or an
    extent is not positive. The label's sides are matched to the extent's in sorted order."""
    sides = parse_dimensions(text)
    if sides is None or not (extent[0] > 0.0 and extent[1] > 0.0):
        return None
    metres = sorted(sides)
    units = sorted(extent)
    per_unit = math.sqrt((metres[0] / units[0]) * (metres[1] / units[1]))  # geometric mean of the two
    spread = abs(metres[0] / units[0] - metres[1] / units[1]) / per_unit
    return LabelScale(
        per_unit, spread, 1, f"room dimensions {text.strip()!r} over {units[0]:.4g} x {units[1]:.4g} units"
    )


def area_scale(text: str, area_units: float) -> LabelScale | None:
    """Metres per unit from an area label and its room's area in square units; None when `text`
    states no area or `area_units` is not positive."""
    metres2 = parse_area(text)
    if metres2 is None or not area_units > 0.0:
        return None
    return LabelScale(
        math.sqrt(metres2 / area_units), 0.0, 1, f"room area {text.strip()!r} over {area_units:.4g} units^2"
    )


def combined_scale(scales: Sequence[LabelScale], max_spread: float = 0.05) -> LabelScale | None:
    """The labels' consensus: the median of the largest group of labels whose scales lie within
    `max_spread` (relative) of one of them (ties: the group nearest the median of all); labels
    outside it are left out and counted as disagreeing. None without labels."""
    if not scales:
        return None
    values = sorted(s.metres_per_unit for s in scales)
    n = len(values)
    median = values[n // 2] if n % 2 else 0.5 * (values[n // 2 - 1] + values[n // 2])

    def support(centre: float) -> int:
        return sum(abs(v / centre - 1.0) <= max_spread for v in values)

    centre = max(values, key=lambda v: (support(v), -abs(math.log(v / median))))
    agreeing = [s for s in scales if abs(s.metres_per_unit / centre - 1.0) <= max_spread]
    kept = sorted(s.metres_per_unit for s in agreeing)
    k = len(kept)
    middle = kept[k // 2] if k % 2 else 0.5 * (kept[k // 2 - 1] + kept[k // 2])
    deviations = sorted(abs(v / middle - 1.0) for v in kept)
    mad = deviations[k // 2] if k % 2 else 0.5 * (deviations[k // 2 - 1] + deviations[k // 2])
    words = "; ".join(s.source for s in agreeing[:3]) + ("; ..." if k > 3 else "")
    left_out = n - k
    source = f"{k} room label{'s' if k != 1 else ''} agree{'s' if k == 1 else ''} ({words})" + (
        f", {left_out} disagreeing left out" if left_out else ""
    )
    return LabelScale(middle, 1.4826 * mad if k > 1 else 0.0, k, source)
