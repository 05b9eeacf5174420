"""SE(2) helpers on (x, y, yaw) tuples and 3x3 homogeneous matrices.

A pose ``T_A_B`` of frame B in frame A maps points given in B into A:
``p_A = R(yaw) p_B + (x, y)``. Metres and radians, yaw counter-clockwise (REP-103).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ._validation import Pose


def wrap_angle(angle: float) -> float:
    """`angle` wrapped to (-pi, pi], as the native core does."""
    return -((math.pi - angle) % (2.0 * math.pi) - math.pi)


def wrap_angles(angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """[`wrap_angle`][planicp.se2.wrap_angle] of every element: radians wrapped to (-pi, pi]."""
    wrapped: NDArray[np.float64] = -((math.pi - np.asarray(angles, dtype=np.float64)) % (2.0 * math.pi) - math.pi)
    return wrapped


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
    x, y, z, w = values
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def pose_to_matrix(pose: Pose) -> NDArray[np.float64]:
    """3x3 homogeneous matrix of (x, y, yaw)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def matrix_to_pose(matrix: NDArray[np.float64]) -> Pose:
    """(x, y, yaw) of a 3x3 homogeneous matrix."""
    return (float(matrix[0, 2]), float(matrix[1, 2]), math.atan2(matrix[1, 0], matrix[0, 0]))


def _triple(pose: Pose, name: str) -> Pose:
    """`pose` unpacked; TypeError (not IndexError) for anything that is not three values."""
    try:
        x, y, yaw = pose
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an (x, y, yaw) triple, got {pose!r:.80}") from None
    return x, y, yaw


def compose(a: Pose, b: Pose) -> Pose:
    """``a * b``: apply `b`, then `a` (T_A_C = T_A_B * T_B_C)."""
    ax, ay, ayaw = _triple(a, "a")
    bx, by, byaw = _triple(b, "b")
    c, s = math.cos(ayaw), math.sin(ayaw)
    return (ax + c * bx - s * by, ay + s * bx + c * by, wrap_angle(ayaw + byaw))


def inverse(a: Pose) -> Pose:
    """The inverse transform (T_B_A from T_A_B)."""
    x, y, yaw = _triple(a, "a")
    c, s = math.cos(yaw), math.sin(yaw)
    return (-(c * x + s * y), s * x - c * y, wrap_angle(-yaw))


def between(a: Pose, b: Pose) -> Pose:
    """``inverse(a) * b``: `b` expressed in the frame of `a` (the motion from `a` to `b`)."""
    return compose(inverse(a), b)


def transform_points(pose: Pose, points: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 2) points mapped by `pose`."""
    x, y, yaw = _triple(pose, "pose")
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    moved: NDArray[np.float64] = points @ rot.T + np.array([x, y])
    return moved
