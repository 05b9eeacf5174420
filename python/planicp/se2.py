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


def pose_to_matrix(pose: Pose) -> NDArray[np.float64]:
    """3x3 homogeneous matrix of (x, y, yaw)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def matrix_to_pose(matrix: NDArray[np.float64]) -> Pose:
    """(x, y, yaw) of a 3x3 homogeneous matrix."""
    return (float(matrix[0, 2]), float(matrix[1, 2]), math.atan2(matrix[1, 0], matrix[0, 0]))


def compose(a: Pose, b: Pose) -> Pose:
    """``a * b``: apply `b`, then `a` (T_A_C = T_A_B * T_B_C)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap_angle(a[2] + b[2]))


def inverse(a: Pose) -> Pose:
    """The inverse transform (T_B_A from T_A_B)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-(c * a[0] + s * a[1]), s * a[0] - c * a[1], wrap_angle(-a[2]))


def between(a: Pose, b: Pose) -> Pose:
    """``inverse(a) * b``: `b` expressed in the frame of `a` (the motion from `a` to `b`)."""
    return compose(inverse(a), b)


def transform_points(pose: Pose, points: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 2) points mapped by `pose`."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    moved: NDArray[np.float64] = points @ rot.T + np.array(pose[:2])
    return moved
