"""Figures of a plan: the extracted wall points over the plan's raster, in metres."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .plan_map import PlanMap


def plot_plan_overlay(plan: PlanMap, *, title: str | None = None, point_size: float = 1.0) -> Figure:
    """The wall points (blue) over the plan's wall raster (grey), map frame, metres.

    For a plan built from points there is no raster; only the points are drawn. Returns a
    matplotlib Figure (never shown; save it with `fig.savefig(path)`).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 8), dpi=120)
    ax = fig.add_subplot()
    raster = plan.raster
    if raster is not None:
        rows, cols = raster.shape
        ox, oy, yaw = raster.origin
        image = np.where(raster.walls, 0.35, 1.0)
        if abs(yaw) < 1e-12:
            extent = (ox, ox + cols * raster.resolution, oy, oy + rows * raster.resolution)
            ax.imshow(image, cmap="gray", vmin=0.0, vmax=1.0, extent=extent, interpolation="nearest", origin="upper")
        else:  # a rotated origin: draw wall pixel centres instead of an axis-aligned image
            r, c = np.nonzero(raster.walls)
            centres = raster.pixel_to_map(r.astype(np.float64) + 0.5, c.astype(np.float64) + 0.5)
            ax.scatter(centres[:, 0], centres[:, 1], s=point_size * 4, c="0.6", marker="s", linewidths=0)
            ax.set_title(f"origin yaw {math.degrees(yaw):.1f} deg")
    pts = plan.points
    ax.scatter(pts[:, 0], pts[:, 1], s=point_size, c="tab:blue", linewidths=0, label=f"{len(plan)} wall points")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", markerscale=4)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig
