"""Input checks shared by the public API: every rejection names the argument and the problem."""

from __future__ import annotations

import math
import reprlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

Pose = tuple[float, float, float]
"""(x, y, yaw): metres, metres, radians (REP-103: yaw counter-clockwise from +x)."""


def as_points(value: Any, name: str, *, allow_empty: bool = False) -> NDArray[np.float64]:
    """`value` as a C-contiguous (N, 2) float64 array of finite coordinates.

    Raises:
        TypeError: the values are not real numbers (bool, complex, strings, objects).
        ValueError: wrong shape, empty (unless `allow_empty`), or a NaN/inf coordinate.
    """
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged nested sequences
        raise ValueError(f"{name} must be an (N, 2) array of numbers: {exc}") from None
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must hold real numbers (float or int), got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2), got {arr.shape}")
    if arr.shape[0] == 0 and not allow_empty:
        raise ValueError(f"{name} is empty: it needs at least one point")
    out = np.ascontiguousarray(arr, dtype=np.float64)
    # The sum is finite exactly when every value is (no overflow at building scales), and costs a
    # seventh of a per-row test; the row is looked for only when one is bad.
    if not np.isfinite(out.sum()):
        finite = np.isfinite(out).all(axis=1)
    else:
        return out
    if not finite.all():
        row = int(np.flatnonzero(~finite)[0])
        raise ValueError(f"{name} has a non-finite coordinate (NaN or inf) at row {row}: {out[row].tolist()}")
    return out


def as_pose(value: Any, name: str) -> Pose:
    """`value` as a finite (x, y, yaw) tuple of floats."""
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{name} must be (x, y, yaw): {exc}") from None
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must hold real numbers (x, y, yaw), got dtype {arr.dtype}")
    if arr.shape != (3,):
        raise ValueError(f"{name} must be (x, y, yaw) with 3 values, got shape {arr.shape}")
    x, y, yaw = (float(v) for v in arr)
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        raise ValueError(f"{name} must be finite, got {(x, y, yaw)}")
    for v in (x, y):
        if abs(v) > MAX_COORDINATE:
            raise ValueError(
                f"{name} has a coordinate of {v:e} m, beyond +-{MAX_COORDINATE:.0e} m; planicp works in "
                f"metres: express poses in a local frame"
            )
    return (x, y, yaw)


MAX_COORDINATE = 1e9
"""Largest |x| or |y| of a pose, metres: the native core's limit for points and poses (beyond it a
pose is no place in a building, and float64 arithmetic loses the millimetres)."""


def positive(value: Any, name: str, unit: str = "") -> float:
    """`value` as a positive finite float."""
    v = real_number(value, name)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be a positive finite number{unit and ' of ' + unit}, got {value!r}")
    return v


def real_number(value: Any, name: str) -> float:
    """`value` as a float; bools and non-numbers are a TypeError."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    return float(value)


def whole_number(value: Any, name: str, minimum: int, maximum: int = 2**31 - 1) -> int:
    """`value` as an int in [`minimum`, `maximum`]; floats and bools are a TypeError."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {value}")
    if value > maximum:
        raise ValueError(f"{name} must be at most {maximum}, got {value}")
    return int(value)


_BRIEF = reprlib.Repr()
_BRIEF.maxlevel, _BRIEF.maxlist, _BRIEF.maxdict, _BRIEF.maxtuple = 3, 6, 6, 6
_BRIEF.maxstring, _BRIEF.maxother, _BRIEF.maxlong = 60, 60, 40


def brief(value: Any) -> str:
    """`repr(value)` cut to a few nested levels, elements and characters (at most 200 characters
    whatever `value` is): how a message quotes input, which may be huge or nested without end."""
    text = _BRIEF.repr(value)
    return text if len(text) <= 200 else text[:197] + "..."


def one_line(text: str, limit: int = 200) -> str:
    """`text` with its white space runs made single spaces, cut to at most `limit` characters: how
    a message quotes another message or a name read from a file."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."
