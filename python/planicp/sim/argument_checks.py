"""Checks of the arguments of the synthetic floors and the simulated LIDAR; each error names the argument."""

from __future__ import annotations

import math
import numbers
from typing import Any

Pose = tuple[float, float, float]


def finite_float(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {out}")
    return out


def int_arg(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    out = int(value)
    if out < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {out}")
    return out


def pose_arg(pose: Any, name: str = "pose") -> Pose:
    try:
        values = [float(v) for v in pose]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a sequence (x, y, yaw) of floats, got {pose!r}") from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{name} must be three finite floats (x, y, yaw), got {pose!r}")
    return values[0], values[1], values[2]
