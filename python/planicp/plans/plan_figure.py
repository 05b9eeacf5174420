"""Figures of a plan: the extracted wall points over the plan's raster, in metres; a drawing's
wall extraction over the drawing itself."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .plan_map import PlanMap
    from .plan_raster import PlanRaster
    from .wall_extraction import ExtractedWalls


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


CLASS_COLOURS: dict[int, tuple[float, float, float]] = {
    1: (0.0, 0.35, 1.0),  # walls kept: blue
    2: (1.0, 0.55, 0.0),  # thin strokes: orange
    3: (0.85, 0.0, 0.85),  # small shapes: magenta
    4: (0.55, 0.3, 0.1),  # fills: brown
    5: (0.9, 0.0, 0.0),  # short or curved strokes: red
    6: (0.55, 0.0, 0.75),  # detached shapes: purple
    7: (0.0, 0.7, 0.2),  # coloured ink: green
    8: (0.0, 0.75, 0.75),  # another tone: cyan
    9: (0.6, 0.6, 0.0),  # unpaired lines: olive
}
"""Colour of each class of `wall_extraction` labels in the drawing overlay."""


def plot_drawing_overlay(
    drawing: NDArray[np.uint8],
    extracted: ExtractedWalls,
    raster: PlanRaster | None = None,
    *,
    title: str | None = None,
) -> Figure:
    """The drawing itself (faded), each of its ink pixels coloured by what the wall extraction
    decided: kept walls blue, each dropped class in its own colour, with a legend and pixel counts.

    `drawing` is the (H, W, 3) RGB image (`plan_raster.load_rgb`); `raster`, the plan's, gives
    the axes in metres of the map frame (when its origin is not rotated; pixels otherwise).
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    from .wall_extraction import DROPPED_CLASSES, WALL

    rows, cols = extracted.labels.shape
    fig = Figure(figsize=(10, 10 * rows / max(cols, 1) + 1.5), dpi=150)
    ax = fig.add_subplot()
    image = 0.45 * drawing.astype(np.float64) / 255.0 + 0.55
    labels = extracted.labels
    counts = np.bincount(labels.ravel(), minlength=256)
    handles = []
    for label, colour in CLASS_COLOURS.items():
        if counts[label]:
            image[labels == label] = colour
            name = "walls kept" if label == WALL else f"dropped: {DROPPED_CLASSES[label]}"
            handles.append(Patch(color=colour, label=f"{name} ({int(counts[label])} px)"))
    extent = None
    if raster is not None and abs(raster.origin[2]) < 1e-12:
        ox, oy, _ = raster.origin
        extent = (ox, ox + cols * raster.resolution, oy, oy + rows * raster.resolution)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    else:
        ax.set_xlabel("column (px)")
        ax.set_ylabel("row (px)")
    ax.imshow(image, extent=extent, interpolation="nearest", origin="upper")
    ax.set_aspect("equal")
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, fontsize=8, frameon=False)
    style = {"thick": "thick-wall drawing", "line": "line drawing", "all-dark": "every dark pixel a wall"}
    ax.set_title(f"{title + ': ' if title else ''}{style.get(extracted.style, extracted.style)}, walls in blue")
    fig.tight_layout()
    return fig
