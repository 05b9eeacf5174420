"""One scan aligned to the plan."""

from __future__ import annotations

from typing import Any


from . import _core
from ._validation import as_pose, as_points
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .plan_map import PlanMap


def localize(scan_xy: Any, plan: PlanMap, initial_pose: Any, config: IcpConfig | None = None) -> IcpResult:
    """Aligns a scan to the plan by trimmed, coarse-to-fine point-to-point ICP.

    Args:
        scan_xy: (N, 2) scan points in the robot (base) frame, metres; see `scan_to_points`.
        plan: the plan to align to.
        initial_pose: (x, y, yaw) guess of the robot in the map frame (e.g. last pose plus
            odometry motion), metres and radians.
        config: ICP settings; None uses `IcpConfig()`.

    Returns:
        The refined pose with its quality (inliers, RMSE, covariance, convergence).

    Raises:
        TypeError: an argument of the wrong type.
        ValueError: a malformed scan (shape, NaN/inf, fewer than 3 points) or pose.

    The GIL is released while the alignment runs.
    """
    if not isinstance(plan, PlanMap):
        raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
    if config is None:
        config = _default_config()
    elif not isinstance(config, IcpConfig):
        raise TypeError(f"config must be a planicp.IcpConfig, got {type(config).__name__}")
    points = as_points(scan_xy, "scan_xy")
    pose = as_pose(initial_pose, "initial_pose")
    raw = _core.align(plan._native, points, pose, config._native)
    return IcpResult.from_alignment(raw, config.covariance_scale)


_DEFAULT: IcpConfig | None = None


def _default_config() -> IcpConfig:
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = IcpConfig()
    return _DEFAULT
