"""Tracking a recorded log: every scan of a `ScanLog` through a `Localizer`, as the robot would have.

The localizer gets each scan's points (base frame) and its odometry pose T_odom_base. A scan
without odometry (before the odometry starts, or a log without any) reuses the previous odometry
pose, so the prediction is "no motion" and ICP alone moves the pose. The start pose T_map_base is
given, or else the first scan's reference pose.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose, as_pose
from ..io.scan_log import ScanFrame
from ..mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid
from ..plans.plan_map import PlanMap
from ..se2 import between, compose
from ..tracking.acceptance_gate import AcceptanceGate
from ..tracking.icp_config import IcpConfig
from ..tracking.localizer import Localizer
from .trajectory_metrics import error_summary


@dataclass(eq=False)
class TrackedLog:
    """The localizer's output over a log, one row per scan.

    Attributes:
        times: (N,) scan times, seconds.
        estimate: (N, 3) T_map_base estimates.
        accepted: (N,) whether ICP's result passed the acceptance gate.
        inlier_ratio, rmse: (N,) quality of the ICP result (NaN where there was none).
        reasons: why each rejected scan was rejected ("" when accepted).
        odometry: (N, 3) the odometry in the map frame, anchored at the start pose (NaN before the
            first scan with odometry).
        reference: (N, 3) T_map_base reference poses (NaN rows where a scan has none), or None.
        seconds: wall time spent in `Localizer.update`, seconds.
        covariance: (N, 3, 3) covariance of each estimate over map-frame (x, y, yaw): m^2, m rad,
            rad^2 (empty (0, 3, 3) for a `TrackedLog` made by hand).
        odom_pose: (N, 3) the odometry pose T_odom_base (odom frame) each update received: the
            scan's own, else the last one before it, else (0, 0, 0) before the first (empty (0, 3)
            for a `TrackedLog` made by hand). T_map_odom = estimate * inverse(odom_pose).
    """

    times: NDArray[np.float64]
    estimate: NDArray[np.float64]
    accepted: NDArray[np.bool_]
    inlier_ratio: NDArray[np.float64]
    rmse: NDArray[np.float64]
    reasons: list[str]
    odometry: NDArray[np.float64]
    reference: NDArray[np.float64] | None
    seconds: float
    covariance: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3, 3)))
    odom_pose: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))

    def metrics(self) -> dict[str, Any]:
        """Acceptance, speed and, when a reference exists, the errors of planicp and of odometry."""
        out: dict[str, Any] = {
            "scans": len(self.times),
            "accepted_share": float(self.accepted.mean()) if len(self.times) else math.nan,
            "median_inlier_ratio": float(np.nanmedian(self.inlier_ratio))
            if np.isfinite(self.inlier_ratio).any()
            else math.nan,
            "scans_per_second": len(self.times) / self.seconds if self.seconds > 0 else math.nan,
        }
        if self.reference is not None and np.isfinite(self.reference).all(axis=1).any():
            out["planicp"] = error_summary(self.estimate, self.reference)
            if np.isfinite(self.odometry).all(axis=1).any():
                out["odometry"] = error_summary(self.odometry, self.reference)
        return out


def track_log(
    frames: Sequence[ScanFrame],
    plan: PlanMap,
    *,
    initial_pose: Any = None,
    config: IcpConfig | None = None,
    gate: AcceptanceGate | None = None,
    grid: EnhancedOccupancyGrid | None = None,
    progress: Callable[[float], None] | None = None,
) -> TrackedLog:
    """Runs a `Localizer` over `frames` (e.g. a `ScanLog`).

    Args:
        frames: the scans in time order.
        plan: the plan to localize in.
        initial_pose: T_map_base (x, y, yaw) at the first scan; None takes the first scan's reference.
        config: the localizer's ICP settings (defaults when None).
        gate: the localizer's acceptance gate (defaults when None).
        grid: when given, every scan is integrated into it at its estimated pose.
        progress: called with the number of scans done after each one.

    Raises:
        ValueError: no scans, or no initial pose and the first scan has no reference.
    """
    if len(frames) == 0:
        raise ValueError("the log has no scans to track")
    first = frames[0]
    if initial_pose is None:
        if first.reference is None:
            raise ValueError(
                "the log's first scan has no reference pose: give the start pose "
                "(initial_pose, or --initial-pose X Y YAW)"
            )
        start: Pose = first.reference
    else:
        start = as_pose(initial_pose, "initial_pose")
    localizer = Localizer(plan, start, config, gate=gate)
    n = len(frames)
    estimate = np.zeros((n, 3))
    covariance = np.zeros((n, 3, 3))
    odom_pose = np.zeros((n, 3))
    odometry = np.full((n, 3), np.nan)
    accepted = np.zeros(n, dtype=bool)
    ratio = np.full(n, np.nan)
    rmse = np.full(n, np.nan)
    reasons: list[str] = []
    last_odom: Pose = (0.0, 0.0, 0.0)
    odom_origin: Pose | None = None
    spent = 0.0
    for k, frame in enumerate(frames):
        if frame.odometry is not None:
            last_odom = frame.odometry
            if odom_origin is None:
                odom_origin = frame.odometry
        if odom_origin is not None:
            odometry[k] = compose(start, between(odom_origin, last_odom))
        scan = frame.points()
        began = time.perf_counter()
        est = localizer.update(scan, last_odom)
        spent += time.perf_counter() - began
        estimate[k] = est.pose
        covariance[k] = est.covariance
        odom_pose[k] = est.odom_pose
        accepted[k] = est.accepted
        reasons.append(est.reason)
        if est.result is not None:
            ratio[k] = est.result.inlier_ratio
            rmse[k] = est.result.rmse
        if grid is not None:
            grid.integrate_ranges(
                frame.ranges,
                frame.angle_min,
                frame.angle_increment,
                est.pose,
                range_min=frame.range_min,
                range_max=frame.range_max,
                laser_pose=frame.laser_pose,
            )
        if progress is not None:
            progress(k + 1)
    has_reference = any(f.reference is not None for f in frames)
    reference = None
    if has_reference:
        reference = np.array(
            [f.reference if f.reference is not None else (np.nan,) * 3 for f in frames], dtype=np.float64
        )
    times = np.array([f.time for f in frames], dtype=np.float64)
    return TrackedLog(
        times, estimate, accepted, ratio, rmse, reasons, odometry, reference, spent, covariance, odom_pose
    )
