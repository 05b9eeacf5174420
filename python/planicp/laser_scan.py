"""LaserScan-style ranges to points."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._validation import as_pose, real_number
from .se2 import transform_points


def scan_to_points(
    ranges: Any,
    angle_min: float,
    angle_increment: float,
    range_min: float,
    range_max: float,
    sensor_pose: Any = (0.0, 0.0, 0.0),
) -> NDArray[np.float64]:
    """Points in the robot (base) frame from ranges as `sensor_msgs/LaserScan` carries them.

    Beam i points at `angle_min + i * angle_increment` (radians, counter-clockwise from the
    laser's x axis). Returns that are NaN, inf, below `range_min` or above `range_max` (metres)
    are dropped, as ROS defines them to be invalid.

    Args:
        ranges: (B,) ranges, metres.
        angle_min: angle of the first beam, radians.
        angle_increment: angle between beams, radians (negative for a laser mounted upside down).
        range_min: lower end of the valid range interval, metres.
        range_max: upper end of the valid range interval, metres.
        sensor_pose: (x, y, yaw) of the laser in the robot frame (its mounting pose).

    Returns:
        (M, 2) float64 points, M <= B, in beam order.
    """
    arr = np.asarray(ranges)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"ranges must hold real numbers, got dtype {arr.dtype}")
    if arr.ndim != 1:
        raise ValueError(f"ranges must be one-dimensional, got shape {arr.shape}")
    a0 = real_number(angle_min, "angle_min")
    da = real_number(angle_increment, "angle_increment")
    lo = real_number(range_min, "range_min")
    hi = real_number(range_max, "range_max")
    if not (math.isfinite(a0) and math.isfinite(da)):
        raise ValueError(f"angle_min and angle_increment must be finite, got {a0!r}, {da!r}")
    if not (lo >= 0.0 and hi > lo) or math.isnan(hi):
        raise ValueError(f"need 0 <= range_min < range_max, got range_min={lo!r}, range_max={hi!r}")
    mount = as_pose(sensor_pose, "sensor_pose")
    r = arr.astype(np.float64, copy=False)
    angles = a0 + da * np.arange(len(r))
    with np.errstate(invalid="ignore"):
        keep = np.isfinite(r) & (r >= lo) & (r <= hi)
    r, angles = r[keep], angles[keep]
    pts = np.column_stack([r * np.cos(angles), r * np.sin(angles)])
    if mount != (0.0, 0.0, 0.0):
        pts = transform_points(mount, pts)
    return np.ascontiguousarray(pts)
