"""One scan aligned to the plan."""

from __future__ import annotations

from typing import Any

from .. import _core
from .._validation import as_points, as_pose
from ..plans.plan_map import PlanMap
from .icp_config import IcpConfig
from .icp_result import IcpResult


def localize(
    scan_xy: Any,
    plan: PlanMap,
    initial_pose: Any,
    config: IcpConfig | None = None,
    *,
    view: _core.WallView | None = None,
) -> IcpResult:
    """Aligns a scan to the plan by trimmed, coarse-to-fine point-to-point ICP.

    Args:
        scan_xy: (N, 2) scan points in the robot (base) frame, metres; see `scan_to_points`.
        plan: the plan to align to.
        initial_pose: (x, y, yaw) guess of the robot in the map frame (e.g. last pose plus
            odometry motion), metres and radians.
        config: ICP settings; None uses `IcpConfig()`.
        view: the plan as seen from `initial_pose` (`plan.view_from(initial_pose, ...)`), cast
            far enough for the scan (`max_range` at least the farthest scan point plus the
            largest stage distance). The KD-tree search with visibility matches against its
            visible points instead of casting them again; other searches ignore it. A view cast
            from another pose is refused.

    Returns:
        The refined pose with its quality (inliers, RMSE, covariance, convergence).

    Raises:
        TypeError: an argument of the wrong type.
        ValueError: a malformed scan (shape, NaN/inf, fewer than 3 points) or pose.

    The GIL is released while the alignment runs; it looks for Python signals every 50 ms, so
    that Ctrl-C stops even a huge `max_iterations` with KeyboardInterrupt.
    """
    if not isinstance(plan, PlanMap):
        raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
    if config is None:
        config = _default_config()
    elif not isinstance(config, IcpConfig):
        raise TypeError(f"config must be a planicp.IcpConfig, got {type(config).__name__}")
    points = as_points(scan_xy, "scan_xy")
    pose = as_pose(initial_pose, "initial_pose")
    if view is not None:
        if not isinstance(view, _core.WallView):
            raise TypeError(f"view must be a planicp.WallView, got {type(view).__name__}")
        if view.pose[:2] != pose[:2]:
            raise ValueError(f"view was cast from {view.pose}, not from the initial pose {pose}")
    raw = _core.align(plan._native, points, pose, config._native, view)
    return IcpResult.from_alignment(raw, config.covariance_scale)


_DEFAULT: IcpConfig | None = None


def _default_config() -> IcpConfig:
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = IcpConfig()
    return _DEFAULT
