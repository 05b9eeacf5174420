"""What the ROS 1 and ROS 2 live tests share: stopping a process group, a message's planar pose,
the position errors of the published poses against the ground truth."""

from __future__ import annotations

import math
import os
import signal
import subprocess
from collections.abc import Hashable, Mapping, Sequence
from typing import Any

import numpy as np


def stop_process_group(process: subprocess.Popen[bytes], timeout: float) -> None:
    """SIGINT to the process group (a launcher shuts its children down), then SIGKILL."""
    if process.poll() is not None:
        return
    for sig, wait in ((signal.SIGINT, timeout), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(wait)
            return
        except subprocess.TimeoutExpired:
            continue


def pose2d(pose: Any) -> tuple[float, float, float]:
    """(x, y, yaw) of a `geometry_msgs/Pose`: metres, radians."""
    from planicp.ros import quaternion_to_yaw

    o = pose.orientation
    return (pose.position.x, pose.position.y, quaternion_to_yaw(o.x, o.y, o.z, o.w))


def position_errors(
    poses: Mapping[Any, tuple[tuple[float, float, float], Any]],
    truth: Mapping[Any, Sequence[float]],
    keys: Sequence[Hashable],
) -> np.ndarray:
    """Metres between each published pose (`poses[key][0]`, x y yaw) and the true one at `keys`."""
    return np.array([math.hypot(poses[k][0][0] - truth[k][0], poses[k][0][1] - truth[k][1]) for k in keys])
