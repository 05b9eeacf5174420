"""The latest transform of each tf frame to its parent, without ROS: what a node that reads `/tf` and
`/tf_static` itself needs to place its laser in the base frame and the base in the odom frame.

Transforms are 3D (tf's): a translation (x, y, z) in metres and a unit quaternion (x, y, z, w), the
child frame's pose in its parent frame (REP-103). No history is kept: a frame's newest transform
stands (the ROS 2 node interpolates odometry itself, `OdometryBuffer`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from .._validation import Pose
from ..se2 import quaternion_to_yaw

Vector = tuple[float, float, float]
Quaternion = tuple[float, float, float, float]
Transform = tuple[Vector, Quaternion]
"""(translation, rotation): a frame's pose in another, metres and a unit quaternion (x, y, z, w)."""

MAX_DEPTH = 64
"""Longest chain of frames followed (a loop in the parent links stops there)."""


def _multiply(a: Quaternion, b: Quaternion) -> Quaternion:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def _rotate(q: Quaternion, v: Vector) -> Vector:
    x, y, z, _ = _multiply(_multiply(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def compose3(a: Transform, b: Transform) -> Transform:
    """T_a * T_b: the pose of b's frame in a's parent frame, when b is given in a's frame."""
    (ta, qa), (tb, qb) = a, b
    r = _rotate(qa, tb)
    return (ta[0] + r[0], ta[1] + r[1], ta[2] + r[2]), _multiply(qa, qb)


def as_transform(translation: Sequence[Any], rotation: Sequence[Any]) -> Transform:
    """A checked transform: three finite metres and a finite, non-zero quaternion (normalised).

    Raises:
        ValueError: a non-finite value, or a zero quaternion.
    """
    t = tuple(float(v) for v in translation)
    q = tuple(float(v) for v in rotation)
    if len(t) != 3 or len(q) != 4 or not all(math.isfinite(v) for v in (*t, *q)):
        raise ValueError(f"a transform needs 3 finite metres and a finite quaternion, got {t}, {q}")
    n = math.sqrt(sum(v * v for v in q))
    if n < 1e-9:
        raise ValueError(f"the transform's quaternion {q} is zero: not a rotation")
    return (t[0], t[1], t[2]), (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def planar(transform: Transform) -> Pose:
    """(x, y, yaw) of a transform in the plane of its parent (REP-103: yaw about +z)."""
    (x, y, _), (qx, qy, qz, qw) = transform
    return (x, y, quaternion_to_yaw(qx, qy, qz, qw))


class TransformTree:
    """Each frame's newest transform to its parent (frame names without a leading '/')."""

    def __init__(self) -> None:
        self._parent: dict[str, tuple[str, Transform]] = {}

    def __len__(self) -> int:
        return len(self._parent)

    def set(self, parent: str, child: str, translation: Sequence[Any], rotation: Sequence[Any]) -> None:
        """Records T_parent_child (see `as_transform`; ValueError for a malformed one, or a frame
        that would be its own parent)."""
        parent, child = parent.lstrip("/"), child.lstrip("/")
        if not parent or not child or parent == child:
            raise ValueError(f"a transform needs two different frames, got {parent!r} -> {child!r}")
        self._parent[child] = (parent, as_transform(translation, rotation))

    def lookup(self, ancestor: str, frame: str) -> Transform | None:
        """T_ancestor_frame, composed along the parent links from `frame` up to `ancestor`; None
        when `ancestor` is not above `frame` (or a link is missing)."""
        ancestor, frame = ancestor.lstrip("/"), frame.lstrip("/")
        result: Transform = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        current = frame
        for _ in range(MAX_DEPTH):
            if current == ancestor:
                return result
            link = self._parent.get(current)
            if link is None:
                return None
            current, transform = link
            result = compose3(transform, result)
        return None
