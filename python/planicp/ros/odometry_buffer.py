"""The recent odometry stream of a node, queried at scan times."""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from .._validation import Pose, as_pose, real_number
from ..io.pose_interpolation import interpolate_poses

MAX_SAMPLES = 20_000
"""Most samples kept whatever their stamps (5 s of odometry at 4 kHz); the oldest go first."""


class OdometryBuffer:
    """Time-stamped T_odom_base poses (REP-105: x, y metres, yaw radians in the odom frame) over the
    last `span` seconds (at most `MAX_SAMPLES` of them; a sample at the newest stamp replaces it),
    so that a scan gets the odometry pose at its own stamp.

    Odometry usually runs faster than the laser (100 Hz against 10 Hz) and its messages arrive
    independently of the scans; `at` interpolates between the two samples around a time (linear in
    position, along the shorter arc in yaw: `planicp.io.pose_interpolation`).
    """

    def __init__(self, span: float = 5.0) -> None:
        """
        Args:
            span: seconds of history kept, counted back from the newest sample.
        """
        value = real_number(span, "span")
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"span must be a positive number of seconds, got {span!r}")
        self.span = value
        self._times: deque[float] = deque()
        self._poses: deque[Pose] = deque()

    def __len__(self) -> int:
        return len(self._times)

    @property
    def oldest(self) -> float | None:
        """Stamp of the oldest sample kept, seconds (None when empty)."""
        return self._times[0] if self._times else None

    @property
    def newest(self) -> float | None:
        """Stamp of the newest sample, seconds (None when empty)."""
        return self._times[-1] if self._times else None

    @property
    def latest_pose(self) -> Pose | None:
        """The newest T_odom_base (None when empty)."""
        return self._poses[-1] if self._poses else None

    def clear(self) -> None:
        """Forgets every sample (e.g. after time jumped back)."""
        self._times.clear()
        self._poses.clear()

    def add(self, stamp: float, pose: Any) -> None:
        """Appends one sample.

        Raises:
            TypeError, ValueError: a non-finite stamp or pose, or a stamp before the newest sample
                (the buffer is left as it was).
        """
        t = real_number(stamp, "odometry stamp")
        if not math.isfinite(t):
            raise ValueError(f"odometry stamp must be finite, got {t!r}")
        p = as_pose(pose, "odometry pose")
        if self._times and t < self._times[-1]:
            raise ValueError(f"odometry stamp {t:.6f} s is older than the previous one ({self._times[-1]:.6f} s)")
        if self._times and t == self._times[-1]:
            # Two readings of one instant: the newer stands (a stream whose stamps do not advance
            # must not grow the buffer).
            self._poses[-1] = p
            return
        self._times.append(t)
        self._poses.append(p)
        while self._times and (self._times[0] < t - self.span or len(self._times) > MAX_SAMPLES):
            self._times.popleft()
            self._poses.popleft()

    def covers(self, stamp: float) -> bool:
        """Whether `stamp` lies within the kept samples (inclusive)."""
        return bool(self._times) and self._times[0] <= stamp <= self._times[-1]

    def at(self, stamp: float) -> Pose | None:
        """T_odom_base at `stamp`, interpolated; None outside the kept samples."""
        if not self.covers(stamp):
            return None
        poses, inside = interpolate_poses(
            np.fromiter(self._times, dtype=np.float64, count=len(self._times)),
            np.array(self._poses, dtype=np.float64),
            np.array([stamp]),
        )
        if not inside[0]:
            return None
        row = poses[0]
        return (float(row[0]), float(row[1]), float(row[2]))
