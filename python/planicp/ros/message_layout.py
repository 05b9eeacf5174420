"""Planar poses and covariances in the layout of ROS messages (geometry_msgs), without ROS.

`geometry_msgs/PoseWithCovariance.covariance` is a row-major 6x6 matrix over
(x, y, z, rotation about X, rotation about Y, rotation about Z): metres and radians, in the
message's frame (REP-103). A planar (x, y, yaw) covariance occupies the rows and columns 0, 1 and 5,
so its nine entries go to the flat indices 0, 1, 5, 6, 7, 11, 30, 31, 35; every other entry is 0.
Orientations are unit quaternions (x, y, z, w) about +z.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

PLANAR_INDICES = (0, 1, 5)
"""Rows/columns of x, y and yaw in the 6x6 covariance of geometry_msgs."""

FLAT_INDICES = tuple(6 * r + c for r in PLANAR_INDICES for c in PLANAR_INDICES)
"""Flat (row-major) indices of the planar entries: (0, 1, 5, 6, 7, 11, 30, 31, 35)."""


def covariance_to_6x6(covariance: Any) -> list[float]:
    """The 36 row-major values of a 6x6 message covariance from a 3x3 over (x, y, yaw).

    Units: m^2 for x/y, m rad for the cross terms, rad^2 for yaw.

    Raises:
        ValueError: not a finite 3x3 array.
    """
    cov = np.asarray(covariance, dtype=np.float64)
    if cov.shape != (3, 3):
        raise ValueError(f"covariance must be 3x3 over (x, y, yaw), got shape {cov.shape}")
    if not np.isfinite(cov).all():
        raise ValueError(f"covariance must be finite, got {cov.tolist()}")
    out = [0.0] * 36
    for flat, value in zip(FLAT_INDICES, cov.ravel()):
        out[flat] = float(value)
    return out


def covariance_from_6x6(values: Any) -> NDArray[np.float64]:
    """The 3x3 (x, y, yaw) block of a 6x6 message covariance (36 values, row-major).

    Raises:
        ValueError: not 36 finite numbers.
    """
    try:
        flat = np.asarray(values, dtype=np.float64).ravel()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"covariance must be 36 numbers: {exc}") from None
    if flat.shape != (36,):
        raise ValueError(f"covariance must have 36 values (6x6, row-major), got {flat.shape[0]}")
    if not np.isfinite(flat).all():
        raise ValueError("covariance has a non-finite value (NaN or inf)")
    return flat.reshape(6, 6)[np.ix_(PLANAR_INDICES, PLANAR_INDICES)].copy()


def yaw_to_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by `yaw` radians about +z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def quaternion_to_yaw(x: float, y: float, z: float, w: float) -> float:
    """Yaw (radians, about +z, in (-pi, pi]) of a quaternion; its roll and pitch are ignored.

    Raises:
        ValueError: a non-finite or zero-length quaternion.
    """
    values = (float(x), float(y), float(z), float(w))
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"orientation must be a finite quaternion, got {values}")
    if math.fsum(v * v for v in values) < 1e-12:
        raise ValueError("orientation is a zero quaternion (all four components 0)")
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
