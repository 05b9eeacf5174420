"""A drawing's print scale, as written on drawings ("1:100", '1"=24\\'', "1/8\\" = 1'-0\\""), as a ratio.

A print scale says how many units of the building one unit on paper stands for: 1:100 is 100,
1" = 24' is 288 (24 feet are 288 inches), 1/8" = 1'-0" is 96. A vector drawing's coordinates are
lengths on paper (a PDF's points are 1/72 inch, an SVG's user units 1/96 inch), so metres in the
building = paper length in metres x ratio (`metres_per_paper_unit`).
"""

from __future__ import annotations

import math
import re

__all__ = ["find_print_scale", "metres_per_paper_unit", "parse_print_scale", "round_print_scale"]

_LENGTH_UNITS = {
    '"': 0.0254,
    "in": 0.0254,
    "inch": 0.0254,
    "inches": 0.0254,
    "'": 0.3048,
    "ft": 0.3048,
    "foot": 0.3048,
    "feet": 0.3048,
    "mm": 1e-3,
    "cm": 1e-2,
    "m": 1.0,
}

_NUMBER = r"\d+(?:\.\d+)?(?:\s*/\s*\d+)?|\d+\s+\d+\s*/\s*\d+"
_UNIT = r"\"|''|'|in(?:ch(?:es)?)?\b|ft\b|feet\b|foot\b|mm\b|cm\b|m\b"
_SIDE = rf"(?:{_NUMBER})\s*(?:{_UNIT})(?:\s*-?\s*(?:{_NUMBER})\s*(?:{_UNIT}))?"
_EQUALS_RE = re.compile(rf"({_SIDE})\s*=\s*({_SIDE})", re.IGNORECASE)
_RATIO_RE = re.compile(r"(?<![\d.])1\s*:\s*(\d+(?:\.\d+)?)(?![\d.:])")
_PART_RE = re.compile(rf"({_NUMBER})\s*({_UNIT})", re.IGNORECASE)


def _number(text: str) -> float:
    text = text.strip()
    if " " in text and "/" in text:  # a mixed number: 1 1/2
        whole, frac = text.split(None, 1)
        return float(whole) + _number(frac)
    if "/" in text:
        num, den = (float(t) for t in text.split("/"))
        if den == 0.0:
            raise ValueError("a fraction with denominator 0")
        return num / den
    return float(text)


def _length(side: str) -> float:
    """Metres of one side of a scale equation ("1'-0\\"", "1/8\\"", "2.5 m")."""
    total = 0.0
    for number, unit in _PART_RE.findall(side):
        key = unit.lower()
        key = '"' if key == "''" else key
        total += _number(number) * _LENGTH_UNITS[key]
    return total


def parse_print_scale(value: str | float) -> float:
    """The ratio (building length / paper length) of a print scale.

    Args:
        value: a number (the ratio itself: 100 for 1:100), or text: "1:100", "1/100",
            '1"=24\\'', "1/8\\" = 1'-0\\"", "1 in = 24 ft", "10 mm = 1 m".

    Raises:
        ValueError: the text is no print scale, or the ratio is not a positive finite number; the
            message shows the forms understood.
    """
    forms = "give a ratio such as 100 or '1:100', or an equation such as '1\"=24\\'' or '1/8\" = 1\\'-0\"'"
    if isinstance(value, bool):
        raise TypeError(f"print scale must be a number or text, got {value!r}")
    if isinstance(value, (int, float)):
        ratio = float(value)
    elif isinstance(value, str):
        text = value.strip()
        ratio = math.nan
        try:
            if re.fullmatch(r"\d+(?:\.\d+)?", text):
                ratio = float(text)
            elif m := re.fullmatch(r"(\d+(?:\.\d+)?)\s*[:/]\s*(\d+(?:\.\d+)?)", text):
                ratio = float(m.group(2)) / float(m.group(1))
            elif m := _EQUALS_RE.fullmatch(text):
                ratio = _length(m.group(2)) / _length(m.group(1))
        except (ValueError, ZeroDivisionError):
            ratio = math.nan
        if math.isnan(ratio):
            raise ValueError(f"print scale {value!r} is not understood: {forms}")
    else:
        raise TypeError(f"print scale must be a number or text, got {type(value).__name__}")
    if not (math.isfinite(ratio) and ratio > 0.0):
        raise ValueError(f"print scale {value!r} gives the ratio {ratio}, which is not positive and finite: {forms}")
    return ratio


def find_print_scale(text: str) -> tuple[float, str] | None:
    """The first print scale stated in a drawing's text, as (ratio, the words that state it), or
    None. Looked for: "SCALE: 1:100" / "1:100" and equations such as '1/8" = 1\\'-0"'."""
    for match in _EQUALS_RE.finditer(text):
        try:
            ratio = parse_print_scale(match.group(0))
        except ValueError:
            continue
        if ratio > 1.0:
            return ratio, match.group(0)
    ratio_match = _RATIO_RE.search(text)
    if ratio_match is not None and float(ratio_match.group(1)) > 1.0:
        return float(ratio_match.group(1)), ratio_match.group(0)
    return None


_METRIC_MANTISSAS = (1.0, 1.25, 2.0, 2.5, 5.0)
"""The metric print scales drawn at (1:1, 1:1.25, 1:2, 1:2.5, 1:5 times a power of ten: 1:50,
1:100, 1:125, 1:200, 1:250, 1:500; ISO 5455's series and the scales offices add to it)."""

_INCH_FRACTIONS = (1 / 64, 1 / 32, 1 / 16, 3 / 32, 1 / 8, 3 / 16, 1 / 4, 3 / 8, 1 / 2, 3 / 4, 1.0, 1.5, 3.0)
"""The inches to a foot of the US architect's scales (1/8" = 1'-0" ...)."""


def _round_ratios(metric: bool, imperial: bool) -> list[tuple[float, str]]:
    """The round print scales of a family, as (ratio, how they are written)."""
    ratios: list[tuple[float, str]] = []
    if metric:
        for power in range(5):
            for mantissa in _METRIC_MANTISSAS:
                ratio = mantissa * 10.0**power
                ratios.append((ratio, f"1:{ratio:g}"))
    if imperial:
        ratios += [(12.0 / inches, f'{_inch_text(inches)}" = 1\'-0"') for inches in _INCH_FRACTIONS]
        ratios += [(12.0 * feet, f"1\" = {feet}'") for feet in range(1, 1001)]  # the engineer's scales
    return ratios


def _inch_text(inches: float) -> str:
    for denominator in (1, 2, 4, 8, 16, 32, 64):
        numerator = inches * denominator
        if abs(numerator - round(numerator)) < 1e-9:
            whole, rest = divmod(round(numerator), denominator)
            if rest == 0:
                return f"{whole}"
            return f"{whole} {rest}/{denominator}" if whole else f"{rest}/{denominator}"
    return f"{inches:g}"


def round_print_scale(low: float, high: float, *, metric: bool, imperial: bool) -> tuple[float, str] | None:
    """The round print scale a measured one stands for, when the measurement says which.

    A drawing is drawn and printed at a round scale (1:100, 1/8" = 1'-0", 1" = 24'), so a scale
    measured from what the drawing states (its areas, its room dimensions) to within [low, high]
    is that round scale when exactly one lies in the interval, and nothing when none or several
    do. The round scales are those of the drawing's units: metric (1, 1.25, 2, 2.5, 5 times a
    power of ten) for areas in square metres, imperial (a fraction of an inch to a foot, or an
    inch to a whole number of feet) for areas in square feet.

    Args:
        low: the least ratio (building length / paper length) the measurement allows.
        high: the largest.
        metric: consider the metric round scales.
        imperial: consider the imperial ones.

    Returns:
        (ratio, how it is written), or None.
    """
    if not (math.isfinite(low) and math.isfinite(high) and 0.0 < low <= high):
        return None
    inside: dict[float, str] = {}
    for ratio, text in _round_ratios(metric, imperial):
        if low <= ratio <= high:
            inside.setdefault(round(ratio, 9), text)  # 1" = 8' is 1/8" = 1'-0": one scale
    if len(inside) != 1:
        return None
    ((ratio, text),) = inside.items()
    return ratio, text


def metres_per_paper_unit(ratio: float, paper_unit_metres: float) -> float:
    """Metres in the building per drawing unit: the drawing unit's length on paper (a PDF point:
    0.0254 / 72) times the print scale's ratio."""
    return paper_unit_metres * ratio
