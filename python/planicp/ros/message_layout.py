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

from ..se2 import between, quaternion_to_yaw, yaw_to_quaternion

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


def planar_mount(translation: Any, quaternion: Any) -> tuple[tuple[float, float, float], bool]:
    """The 2D mounting pose of a laser from its 3D transform in the base frame (tf's base -> laser).

    Args:
        translation: (x, y, z) metres.
        quaternion: (x, y, z, w) of the laser frame's orientation in the base frame.

    Returns:
        ((x, y, yaw) of the laser in the base plane, flipped): `flipped` is True for a laser
        mounted upside down (its z axis points down), whose beam angles then turn clockwise in the
        base frame: negate `angle_min` and `angle_increment` before using the mount.

    Raises:
        ValueError: a non-finite translation or a non-finite or zero quaternion.
    """
    t = np.asarray(translation, dtype=np.float64).ravel()
    if t.shape != (3,) or not np.isfinite(t).all():
        raise ValueError(f"translation must be 3 finite numbers, got {t.tolist()}")
    qx, qy, qz, qw = (float(v) for v in np.asarray(quaternion, dtype=np.float64).ravel()[:4])
    quaternion_to_yaw(qx, qy, qz, qw)  # validates
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
    # First column of the rotation matrix (the laser's x axis in the base frame) and its z-z entry.
    x_axis = (1.0 - 2.0 * (qy * qy + qz * qz), 2.0 * (qx * qy + qz * qw))
    zz = 1.0 - 2.0 * (qx * qx + qy * qy)
    return (float(t[0]), float(t[1]), math.atan2(x_axis[1], x_axis[0])), zz < 0.0


def set_planar_pose(msg: Any, pose: Any) -> None:
    """Fills a `geometry_msgs/Pose` (ROS 1 or 2) with the planar `pose` (x, y metres; yaw radians)."""
    msg.position.x, msg.position.y = float(pose[0]), float(pose[1])
    o = msg.orientation
    o.x, o.y, o.z, o.w = yaw_to_quaternion(float(pose[2]))


def set_planar_transform(msg: Any, pose: Any) -> None:
    """Fills a `geometry_msgs/Transform` (ROS 1 or 2) with the planar `pose` (x, y metres; yaw radians)."""
    msg.translation.x, msg.translation.y = float(pose[0]), float(pose[1])
    r = msg.rotation
    r.x, r.y, r.z, r.w = yaw_to_quaternion(float(pose[2]))


def fill_odometry(odom: Any, stamp: Any, frames: tuple[str, str], pose: Any, previous: Any, dt: float) -> None:
    """Fills a `nav_msgs/Odometry` (ROS 1 or 2): `stamp`, the (odom, base) `frames`, the planar
    `pose` (T_odom_base) and, over a step of `dt` seconds from `previous`, the body-frame velocity
    (m/s, rad/s; left at zero when `dt` is not positive)."""
    odom.header.stamp = stamp
    odom.header.frame_id, odom.child_frame_id = frames
    set_planar_pose(odom.pose.pose, pose)
    if dt > 0.0:
        step = between(previous, pose)
        odom.twist.twist.linear.x, odom.twist.twist.linear.y = step[0] / dt, step[1] / dt
        odom.twist.twist.angular.z = step[2] / dt


def fill_transform(tf: Any, stamp: Any, frames: tuple[str, str], pose: Any) -> None:
    """Fills a `geometry_msgs/TransformStamped` (ROS 1 or 2): `stamp`, the (parent, child)
    `frames` and the planar `pose` (T_parent_child)."""
    tf.header.stamp = stamp
    tf.header.frame_id, tf.child_frame_id = frames
    set_planar_transform(tf.transform, pose)
