"""What `PlanicpNodeCore` takes and gives: plain data shaped like the ROS messages it stands for."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose, as_pose, real_number
from ..tracking.localizer import Estimate
from .message_layout import covariance_to_6x6

BEAM_COUNT_SLACK = 1
"""Beams by which `ranges` may differ from (angle_max - angle_min) / angle_increment + 1: drivers
round that count either way."""


@dataclass(frozen=True, eq=False)
class ScanInput:
    """One `sensor_msgs/LaserScan`, checked.

    Attributes:
        stamp: `header.stamp`, seconds (the time of the first beam, taken as the scan's time).
        ranges: (B,) float64 metres, REP-117: +inf no return, -inf too close, NaN erroneous (all
            three are skipped, as are ranges outside [range_min, range_max]). Read-only.
        angle_min: angle of the first beam in the laser frame, radians (counter-clockwise, REP-103).
        angle_increment: angle between beams, radians (non-zero; negative for an inverted laser).
        range_min, range_max: the valid interval, metres.
        laser_pose: T_base_laser, (x, y, yaw) of the laser frame in the base frame.
        angle_max: angle of the last beam, radians, or None to skip the beam-count check.

    Raises:
        TypeError, ValueError: the message is malformed (named field, and why).
    """

    stamp: float
    ranges: NDArray[np.float64]
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    laser_pose: Pose = (0.0, 0.0, 0.0)
    angle_max: float | None = None

    def __post_init__(self) -> None:
        stamp = real_number(self.stamp, "stamp")
        if not (math.isfinite(stamp) and stamp >= 0.0):
            raise ValueError(f"scan stamp must be a finite time >= 0 s, got {self.stamp!r}")
        object.__setattr__(self, "stamp", stamp)
        try:
            ranges = np.array(self.ranges)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"ranges must be a list of numbers: {exc}") from None
        if ranges.dtype.kind not in "fiu":
            raise TypeError(f"ranges must hold real numbers, got dtype {ranges.dtype}")
        if ranges.ndim != 1:
            raise ValueError(f"ranges must be one-dimensional, got shape {ranges.shape}")
        if ranges.size == 0:
            raise ValueError("the scan is empty: ranges has no beams")
        ranges = ranges.astype(np.float64)
        ranges.setflags(write=False)
        object.__setattr__(self, "ranges", ranges)
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            value = real_number(getattr(self, name), name)
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value!r}")
            object.__setattr__(self, name, value)
        if self.angle_increment == 0.0:
            raise ValueError("angle_increment must not be 0 (every beam would point the same way)")
        if not 0.0 <= self.range_min < self.range_max:
            raise ValueError(
                f"need 0 <= range_min < range_max, got range_min={self.range_min}, range_max={self.range_max}"
            )
        object.__setattr__(self, "laser_pose", as_pose(self.laser_pose, "laser_pose"))
        if self.angle_max is not None:
            angle_max = real_number(self.angle_max, "angle_max")
            if not math.isfinite(angle_max):
                raise ValueError(f"angle_max must be finite, got {angle_max!r}")
            object.__setattr__(self, "angle_max", angle_max)
            expected = (angle_max - self.angle_min) / self.angle_increment + 1.0
            if expected < 1.0 - BEAM_COUNT_SLACK or abs(len(ranges) - expected) > BEAM_COUNT_SLACK + 1e-6:
                raise ValueError(
                    f"ranges has {len(ranges)} beams but angle_min {self.angle_min:.6f} to angle_max "
                    f"{angle_max:.6f} rad at angle_increment {self.angle_increment:.6g} rad makes {expected:.1f}"
                )


@dataclass(frozen=True, eq=False)
class PoseOutput:
    """The node's answer to one scan: what it publishes.

    Attributes:
        stamp: the scan's stamp, seconds (the header stamp of the pose and of map -> odom, to which
            the node adds its `transform_tolerance`).
        pose: T_map_base, (x, y, yaw) metres and radians: `planicp/pose`.
        covariance: 3x3 over (x, y, yaw) of `pose` (m^2, m rad, rad^2).
        map_to_odom: T_map_odom = T_map_base * inv(T_odom_base) (REP-105: odom stays continuous,
            the correction lives in map -> odom).
        odom_pose: T_odom_base at the scan's stamp (interpolated odometry).
        estimate: the localizer's full `Estimate` (quality, rejection reason, lost state).
    """

    stamp: float
    pose: Pose
    covariance: NDArray[np.float64]
    map_to_odom: Pose
    odom_pose: Pose
    estimate: Estimate

    @property
    def covariance_6x6(self) -> list[float]:
        """`covariance` as the 36 row-major values of `PoseWithCovariance.covariance` (x, y, yaw at
        rows/columns 0, 1, 5)."""
        return covariance_to_6x6(self.covariance)

    @property
    def accepted(self) -> bool:
        """ICP's result passed the acceptance gate (else the pose is the odometry prediction)."""
        return self.estimate.accepted

    @property
    def inlier_ratio(self) -> float:
        """Share of the scan's points within the correspondence distance of the plan (NaN: none aligned)."""
        return self.estimate.result.inlier_ratio if self.estimate.result is not None else math.nan


def as_stamp(value: Any, name: str) -> float:
    """`value` as a finite time >= 0, seconds."""
    t = real_number(value, name)
    if not (math.isfinite(t) and t >= 0.0):
        raise ValueError(f"{name} must be a finite time >= 0 s, got {value!r}")
    return t
