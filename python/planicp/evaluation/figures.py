"""Figures of a localization run, in the style of the thesis (figs 5.9-5.14) plus driven paths.

Every function takes plain arrays (map frame, metres, radians, seconds), returns a matplotlib
`Figure` and never shows it: save it with `fig.savefig(path)`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..se2 import transform_points

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid
    from ..plans.plan_map import PlanMap

COLOURS = {"odometry": "tab:red", "planicp": "tab:green", "truth": "black"}


def _figure(size: tuple[float, float] = (8.0, 4.5)) -> tuple[Figure, Axes]:
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=120)
    return fig, fig.add_subplot()


def _series(ax: Axes, times: NDArray[np.float64], values: Mapping[str, NDArray[np.float64]], scale: float) -> None:
    t = np.asarray(times, dtype=np.float64)
    for label, v in values.items():
        v = np.asarray(v, dtype=np.float64)
        if v.shape != t.shape:
            raise ValueError(f"series {label!r} has shape {v.shape}, times have {t.shape}")
        ax.plot(t, v * scale, label=label, color=COLOURS.get(label), linewidth=1.2)
    ax.set_xlabel("time (s)")
    ax.grid(True, alpha=0.3)
    ax.legend()


def plot_position_error(times: Any, errors: Mapping[str, Any]) -> Figure:
    """Euclidean distance from ground truth over time, one line per source (thesis fig. 5.11).
    `errors` maps a label ("odometry", "planicp", ...) to metres per time."""
    fig, ax = _figure()
    _series(ax, np.asarray(times), {k: np.asarray(v) for k, v in errors.items()}, 1.0)
    ax.set_ylabel("position error (m)")
    ax.set_title("Distance from ground truth")
    fig.tight_layout()
    return fig


def plot_heading_error(times: Any, errors: Mapping[str, Any]) -> Figure:
    """Absolute heading error over time in degrees (thesis fig. 5.12); `errors` in radians."""
    fig, ax = _figure()
    _series(ax, np.asarray(times), {k: np.abs(np.asarray(v)) for k, v in errors.items()}, 180.0 / math.pi)
    ax.set_ylabel("heading error (deg)")
    ax.set_title("Heading deviation from ground truth")
    fig.tight_layout()
    return fig


def _plan_background(ax: Axes, plan: PlanMap, size: float = 1.0) -> None:
    pts = plan.points
    ax.scatter(pts[:, 0], pts[:, 1], s=size, c="tab:blue", linewidths=0, label="plan walls")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def _arrow(ax: Axes, pose: tuple[float, float, float], colour: str, label: str, length: float = 0.6) -> None:
    x, y, yaw = pose
    ax.annotate(
        "",
        xy=(x + length * math.cos(yaw), y + length * math.sin(yaw)),
        xytext=(x, y),
        arrowprops={"arrowstyle": "->", "color": colour, "linewidth": 2.0},
    )
    ax.plot([], [], color=colour, label=label)


def plot_scan_match(
    plan: PlanMap,
    scan_xy: Any,
    pose: tuple[float, float, float],
    inlier_mask: Any | None = None,
    *,
    initial_pose: tuple[float, float, float] | None = None,
    window: float = 8.0,
    title: str | None = None,
) -> Figure:
    """One scan placed at `pose` over the plan (thesis figs. 5.7, 5.9, 5.10): inliers green,
    outliers black (all green when `inlier_mask` is None), the estimate as a green arrow and the
    initial guess (the odometry prediction) as a red one. The view is `window` metres around the pose."""
    scan = np.asarray(scan_xy, dtype=np.float64)
    world = transform_points(pose, scan)
    mask = np.ones(len(scan), dtype=bool) if inlier_mask is None else np.asarray(inlier_mask, dtype=bool)
    if mask.shape != (len(scan),):
        raise ValueError(f"inlier_mask has shape {mask.shape}, the scan has {len(scan)} points")
    fig, ax = _figure((7.0, 7.0))
    _plan_background(ax, plan)
    ax.scatter(world[mask, 0], world[mask, 1], s=4, c="tab:green", linewidths=0, label=f"inliers ({mask.sum()})")
    if (~mask).any():
        ax.scatter(world[~mask, 0], world[~mask, 1], s=4, c="black", linewidths=0, label=f"outliers ({(~mask).sum()})")
    if initial_pose is not None:
        _arrow(ax, initial_pose, "tab:red", "initial guess")
    _arrow(ax, pose, "tab:green", "estimate")
    half = window / 2.0
    ax.set_xlim(pose[0] - half, pose[0] + half)
    ax.set_ylim(pose[1] - half, pose[1] + half)
    ax.legend(loc="upper right", markerscale=3, fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig


def plot_paths(plan: PlanMap, paths: Mapping[str, Any], *, title: str | None = None) -> Figure:
    """Driven paths over the plan: each value an (N, 2) or (N, 3) array of map-frame poses."""
    fig, ax = _figure((8.0, 6.0))
    _plan_background(ax, plan, size=0.5)
    for label, path in paths.items():
        p = np.asarray(path, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] not in (2, 3):
            raise ValueError(f"path {label!r} must be (N, 2) or (N, 3), got {p.shape}")
        ax.plot(p[:, 0], p[:, 1], label=label, color=COLOURS.get(label), linewidth=1.2)
    ax.legend(loc="upper right", fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig


def _draw_eog(ax: Axes, grid: EnhancedOccupancyGrid, title: str | None) -> None:
    from matplotlib.patches import Patch

    from ..mapping.eog_state import STATE_COLOURS, EogState

    xmin, ymin, xmax, ymax = grid.extent
    ax.imshow(grid.to_image(), extent=(xmin, xmax, ymin, ymax), interpolation="nearest")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    handles = []
    for state in EogState:
        r, g, b = STATE_COLOURS[state]
        handles.append(Patch(facecolor=(r / 255.0, g / 255.0, b / 255.0), edgecolor="0.3", label=state.name.lower()))
    ax.legend(handles=handles, loc="upper right", fontsize=7, framealpha=0.9)
    if title:
        ax.set_title(title)


def plot_eog(grid: EnhancedOccupancyGrid, *, title: str | None = None) -> Figure:
    """An enhanced occupancy grid in the thesis's colours (figs 5.13, 5.14), in map coordinates."""
    fig, ax = _figure((8.0, 6.0))
    _draw_eog(ax, grid, title)
    fig.tight_layout()
    return fig


def plot_eog_comparison(grids: Mapping[str, EnhancedOccupancyGrid]) -> Figure:
    """Several grids side by side on shared axes (e.g. built from odometry and from planicp)."""
    from matplotlib.figure import Figure

    if not grids:
        raise ValueError("plot_eog_comparison needs at least one grid")
    fig = Figure(figsize=(6.0 * len(grids), 5.5), dpi=120)
    axes = fig.subplots(1, len(grids), squeeze=False)[0]
    for ax, (label, grid) in zip(axes, grids.items()):
        _draw_eog(ax, grid, label)
    fig.tight_layout()
    return fig


def plot_quality(times: Any, inlier_ratio: Any, rmse: Any, accepted: Any) -> Figure:
    """Estimate quality over time: ICP inlier ratio and RMSE per scan, rejected scans marked."""
    from matplotlib.figure import Figure

    t = np.asarray(times, dtype=np.float64)
    ratio = np.asarray(inlier_ratio, dtype=np.float64)
    error = np.asarray(rmse, dtype=np.float64)
    ok = np.asarray(accepted, dtype=bool)
    if not (ratio.shape == error.shape == ok.shape == t.shape):
        raise ValueError(
            f"times, inlier_ratio, rmse and accepted must have one shape, got "
            f"{t.shape}, {ratio.shape}, {error.shape}, {ok.shape}"
        )
    fig = Figure(figsize=(8.0, 5.0), dpi=120)
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.plot(t, ratio, color="tab:green", linewidth=1.0, label="inlier ratio")
    if (~ok).any():
        top.scatter(
            t[~ok],
            np.nan_to_num(ratio[~ok], nan=0.0),
            color="tab:red",
            s=10,
            zorder=3,
            label=f"rejected ({int((~ok).sum())})",
        )
    top.set_ylabel("inlier ratio")
    top.set_ylim(0.0, 1.05)
    top.legend(loc="lower right", fontsize=8)
    top.grid(True, alpha=0.3)
    bottom.plot(t, error * 100.0, color="tab:blue", linewidth=1.0)
    bottom.set_ylabel("ICP RMSE (cm)")
    bottom.set_xlabel("time (s)")
    bottom.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig
