"""Scan-by-scan tracking: odometry predicts, ICP against the plan corrects, a gate decides."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import _core
from ._validation import Pose, as_pose, as_points, positive, real_number, whole_number
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .localize import localize
from .plan_map import PlanMap
from .se2 import between, compose, inverse, pose_to_matrix


@dataclass(frozen=True)
class AcceptanceGate:
    """When the `Localizer` trusts an ICP result instead of odometry.

    Attributes:
        require_convergence: reject results whose ICP ran out of iterations. Off by default: a
            result still creeping by more than the tolerances after `max_iterations` is almost
            always closer than the odometry prediction (on the Intel log with synthetic drift,
            requiring convergence rejected 74 % of the scans and lost track); the inlier and jump
            checks judge the fit instead.
        min_inliers: fewest scan points within `max_correspondence_distance` of the plan.
        min_inlier_ratio: smallest share of scan points that are inliers.
        max_translation_jump: largest correction (metres) of the odometry prediction.
        max_rotation_jump: largest correction (radians) of the odometry prediction.
    """

    require_convergence: bool = False
    min_inliers: int = 30
    min_inlier_ratio: float = 0.25
    max_translation_jump: float = 0.5
    max_rotation_jump: float = math.radians(10.0)

    def __post_init__(self) -> None:
        if not isinstance(self.require_convergence, bool):
            raise TypeError(f"require_convergence must be a bool, got {self.require_convergence!r}")
        whole_number(self.min_inliers, "min_inliers", 0)
        ratio = real_number(self.min_inlier_ratio, "min_inlier_ratio")
        if not 0.0 <= ratio <= 1.0:
            raise ValueError(f"min_inlier_ratio must be in [0, 1], got {ratio!r}")
        positive(self.max_translation_jump, "max_translation_jump", "metres")
        positive(self.max_rotation_jump, "max_rotation_jump", "radians")

    def rejection(self, result: IcpResult, predicted: Pose) -> str:
        """Why `result` is not trusted, or "" when it is."""
        if self.require_convergence and not result.converged:
            return f"ICP did not converge in {result.iterations} iterations"
        if result.num_inliers < self.min_inliers:
            return f"only {result.num_inliers} inliers (need {self.min_inliers})"
        if result.inlier_ratio < self.min_inlier_ratio:
            return f"inlier ratio {result.inlier_ratio:.2f} below {self.min_inlier_ratio:.2f}"
        dx, dy, dyaw = between(predicted, result.pose)
        jump = math.hypot(dx, dy)
        if jump > self.max_translation_jump:
            return f"correction of {jump:.3f} m exceeds {self.max_translation_jump:.3f} m"
        if abs(dyaw) > self.max_rotation_jump:
            return (
                f"correction of {math.degrees(abs(dyaw)):.2f} deg exceeds "
                f"{math.degrees(self.max_rotation_jump):.2f} deg"
            )
        return ""


@dataclass(frozen=True)
class Estimate:
    """The outcome of one `Localizer.update`.

    Attributes:
        pose: (x, y, yaw) of the robot in the map (T_map_base) after this update.
        accepted: the ICP result passed the gate; otherwise `pose` is the odometry prediction.
        result: the ICP result (None when the scan had too few points to align at all).
        predicted_pose: last pose plus the odometry motion since then: ICP's initial guess.
        odom_pose: the odometry pose (T_odom_base) this update received.
        reason: why the result was not accepted ("" when it was).
    """

    pose: Pose
    accepted: bool
    result: IcpResult | None
    predicted_pose: Pose
    odom_pose: Pose
    reason: str

    @property
    def T_map_base(self) -> NDArray[np.float64]:  # noqa: N802
        """3x3 transform of `pose`."""
        return pose_to_matrix(self.pose)

    @property
    def T_map_odom(self) -> NDArray[np.float64]:  # noqa: N802
        """The map -> odom correction a ROS node publishes (REP-105): T_map_base * inv(T_odom_base)."""
        return pose_to_matrix(compose(self.pose, inverse(self.odom_pose)))


class Localizer:
    """Tracks the robot's pose in the plan from scans and odometry.

    Each `update` applies the odometry motion since the previous update to the last pose (the
    prediction), aligns the scan from there, and accepts the result only if it passes the
    `AcceptanceGate`; otherwise the pose follows odometry and the estimate says why. A scan
    that is malformed raises and changes nothing; a scan with too few points is not aligned.

    Thread-safe: updates are serialised by a lock.
    """

    def __init__(
        self,
        plan: PlanMap,
        initial_pose: Any,
        config: IcpConfig | None = None,
        *,
        gate: AcceptanceGate | None = None,
    ) -> None:
        """
        Args:
            plan: the plan to localize in.
            initial_pose: (x, y, yaw) of the robot in the map at the first update.
            config: ICP settings (None: `IcpConfig()`).
            gate: acceptance rules (None: `AcceptanceGate()`).
        """
        if not isinstance(plan, PlanMap):
            raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
        if config is not None and not isinstance(config, IcpConfig):
            raise TypeError(f"config must be a planicp.IcpConfig, got {type(config).__name__}")
        if gate is not None and not isinstance(gate, AcceptanceGate):
            raise TypeError(f"gate must be a planicp.AcceptanceGate, got {type(gate).__name__}")
        self.plan = plan
        self.config = config if config is not None else IcpConfig()
        self.gate = gate if gate is not None else AcceptanceGate()
        self._pose: Pose = as_pose(initial_pose, "initial_pose")
        self._last_odom: Pose | None = None
        self._lock = threading.Lock()

    @property
    def pose(self) -> Pose:
        """Current (x, y, yaw) of the robot in the map."""
        return self._pose

    def reset(self, pose: Any) -> None:
        """Sets the pose (e.g. from RViz's initial pose); the next update's odometry pairs with it."""
        new_pose = as_pose(pose, "pose")
        with self._lock:
            self._pose = new_pose
            self._last_odom = None

    def update(self, scan_xy: Any, odom_pose: Any) -> Estimate:
        """One tracking step.

        Args:
            scan_xy: (N, 2) scan points in the robot frame, metres (see `scan_to_points`).
            odom_pose: (x, y, yaw) of the robot in the odom frame at the scan's time.

        Raises:
            TypeError, ValueError: a malformed scan or odometry pose; the state is unchanged.
        """
        points = as_points(scan_xy, "scan_xy", allow_empty=True)
        odom = as_pose(odom_pose, "odom_pose")
        with self._lock:
            motion = (0.0, 0.0, 0.0) if self._last_odom is None else between(self._last_odom, odom)
            predicted = compose(self._pose, motion)
            result: IcpResult | None = None
            usable = -(-len(points) // self.config.subsample)
            if usable < _core.MIN_SCAN_POINTS:
                reason = f"scan has {usable} usable points (need {_core.MIN_SCAN_POINTS})"
            else:
                result = localize(points, self.plan, predicted, self.config)
                reason = self.gate.rejection(result, predicted)
            accepted = result is not None and reason == ""
            pose = result.pose if accepted and result is not None else predicted
            self._pose = pose
            self._last_odom = odom
            return Estimate(pose, accepted, result, predicted, odom, reason)
