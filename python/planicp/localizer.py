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
from .degeneracy import Degeneracy, DegeneracyRule, fuse_along_weak_axis
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .localize import localize
from .lost_detection import LostDetector, LostRule
from .motion_noise import MotionNoise
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
        covariance: 3x3 over (x, y, yaw) of `pose` (m^2, m rad, rad^2): ICP's when accepted, the
            odometry prediction's otherwise, and along the weak axis of a degenerate fit.
        degeneracy: the weak axis of an accepted fit that does not fix the position along it
            (along which `pose` kept the odometry motion, corrected only as far as ICP's variance
            there allows), or None.
        lost: the plan no longer explains the scans (see `LostRule`).
        score: mean match score (inlier ratio) over the `LostRule` window.
    """

    pose: Pose
    accepted: bool
    result: IcpResult | None
    predicted_pose: Pose
    odom_pose: Pose
    reason: str
    covariance: NDArray[np.float64]
    degeneracy: Degeneracy | None
    lost: bool
    score: float

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

    Along the weak axis of a degenerate fit (`DegeneracyRule`: a long corridor) the pose keeps the
    odometry motion. A covariance is carried along: propagated through each motion with
    `MotionNoise`, replaced by ICP's when a fit is accepted. `LostRule` decides when the scans no
    longer match the plan (`Estimate.lost`).

    Thread-safe: updates are serialised by a lock.
    """

    def __init__(
        self,
        plan: PlanMap,
        initial_pose: Any,
        config: IcpConfig | None = None,
        *,
        gate: AcceptanceGate | None = None,
        motion_noise: MotionNoise | None = None,
        degeneracy: DegeneracyRule | None = None,
        lost_rule: LostRule | None = None,
        initial_covariance: Any = None,
    ) -> None:
        """
        Args:
            plan: the plan to localize in.
            initial_pose: (x, y, yaw) of the robot in the map at the first update.
            config: ICP settings (None: `IcpConfig.for_tracking()`).
            gate: acceptance rules (None: `AcceptanceGate()`).
            motion_noise: odometry uncertainty for the covariance (None: `MotionNoise()`).
            degeneracy: when a fit is degenerate (None: `DegeneracyRule()`).
            lost_rule: when the localizer is lost (None: `LostRule()`).
            initial_covariance: 3x3 covariance of `initial_pose` (None: 10 cm and 5 degrees).
        """
        if not isinstance(plan, PlanMap):
            raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
        if config is not None and not isinstance(config, IcpConfig):
            raise TypeError(f"config must be a planicp.IcpConfig, got {type(config).__name__}")
        if gate is not None and not isinstance(gate, AcceptanceGate):
            raise TypeError(f"gate must be a planicp.AcceptanceGate, got {type(gate).__name__}")
        self.plan = plan
        self.config = config if config is not None else IcpConfig.for_tracking()
        self.gate = gate if gate is not None else AcceptanceGate()
        self.motion_noise = motion_noise if motion_noise is not None else MotionNoise()
        self.degeneracy = degeneracy if degeneracy is not None else DegeneracyRule()
        self._detector = LostDetector(lost_rule if lost_rule is not None else LostRule())
        self._pose: Pose = as_pose(initial_pose, "initial_pose")
        self._covariance = _covariance(initial_covariance)
        self._last_odom: Pose | None = None
        self._lock = threading.Lock()

    @property
    def pose(self) -> Pose:
        """Current (x, y, yaw) of the robot in the map."""
        return self._pose

    @property
    def covariance(self) -> NDArray[np.float64]:
        """Current 3x3 covariance of `pose` (m^2, m rad, rad^2)."""
        return self._covariance.copy()

    @property
    def lost(self) -> bool:
        """Whether the last updates say the plan no longer explains the scans."""
        return self._detector.lost

    def reset(self, pose: Any, covariance: Any = None) -> None:
        """Sets the pose (e.g. from RViz's initial pose) and its covariance (None: 10 cm and 5
        degrees); the next update's odometry pairs with it, and the lost state is cleared."""
        new_pose = as_pose(pose, "pose")
        new_covariance = _covariance(covariance)
        with self._lock:
            self._pose = new_pose
            self._covariance = new_covariance
            self._last_odom = None
            self._detector.reset()

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
            predicted_covariance = self.motion_noise.propagate(self._covariance, self._pose, motion)
            result: IcpResult | None = None
            usable = -(-len(points) // self.config.subsample)
            if usable < _core.MIN_SCAN_POINTS:
                reason = f"scan has {usable} usable points (need {_core.MIN_SCAN_POINTS})"
            else:
                result = localize(points, self.plan, predicted, self.config)
                reason = self.gate.rejection(result, predicted)
            degeneracy: Degeneracy | None = None
            if result is not None and reason == "":
                degeneracy = self.degeneracy.check(result)
                if degeneracy is not None:
                    pose, covariance = fuse_along_weak_axis(degeneracy, result, predicted, predicted_covariance)
                elif np.isfinite(result.covariance).all():
                    pose, covariance = result.pose, np.array(result.covariance, dtype=np.float64)
                else:
                    pose, covariance = result.pose, predicted_covariance
            else:
                pose, covariance = predicted, predicted_covariance
            accepted = result is not None and reason == ""
            lost = self._detector.update(result.inlier_ratio if result is not None else 0.0, accepted)
            self._pose = pose
            self._covariance = covariance
            self._last_odom = odom
            return Estimate(pose, accepted, result, predicted, odom, reason, covariance.copy(), degeneracy, lost,
                            self._detector.score)


DEFAULT_INITIAL_STD = (0.1, 0.1, math.radians(5.0))
"""Standard deviations (m, m, rad) of a start or reset pose given without a covariance."""


def _covariance(value: Any) -> NDArray[np.float64]:
    """A validated 3x3 covariance (None: `DEFAULT_INITIAL_STD` squared on the diagonal)."""
    if value is None:
        return np.diag(np.square(DEFAULT_INITIAL_STD))
    cov = np.asarray(value)
    if cov.dtype.kind not in "fiu":
        raise TypeError(f"covariance must hold real numbers, got dtype {cov.dtype}")
    cov = cov.astype(np.float64)
    if cov.shape != (3, 3):
        raise ValueError(f"covariance must be 3x3 over (x, y, yaw), got shape {cov.shape}")
    if not np.isfinite(cov).all() or not np.allclose(cov, cov.T, atol=1e-12) or np.linalg.eigvalsh(cov).min() < 0:
        raise ValueError(f"covariance must be finite, symmetric and positive semi-definite, got {cov.tolist()}")
    return cov
