"""How far one aligned scan says the plan's scale is off: a similarity fit at the rigid fit's pose.

A plan drawn at a scale `s` times the world's (a raster read at a guessed metres per pixel) is the
world scaled by `s` about the map origin. A scan, which measures the world, fits such a plan
exactly only when it is scaled by `s` too. ICP fits it rigidly: in a room the fit centres the robot
between the walls, and every wall the scan sees is then about `(s - 1)` times half the room's width
away from its return, on the same side (beyond the returns for `s > 1`). The rigid fit explains the
scan well (the issue that asked for this: 100 % of scans accepted at 10 % off), but the residual
pattern, radial and growing with range, is that of a scale.

`scale_fit` measures it: at the fit's pose, each inlier return is paired with the plan's wall
nearest to it (`WallLookup`: a distance transform of the plan's wall points) and its residual along
that wall's normal, `n . (w - m)`, is linearised in the pose (dx, dy, dyaw) and a scale `1 + e` of
the scan about the robot (`w = t + (1 + e) R q`): the Jacobian row is
`(n_x, n_y, n . perp(w - t), n . (w - t))`. One Gauss-Newton step of the four parameters from the
rigid optimum gives `e` and its variance `sigma^2 (J^T J)^-1` (sigma from the residuals of the
fit). `e` is the plan's scale relative to the world minus one: `e = +0.03` means the plan is drawn
3 % larger than the building. Frames: scan points in the base frame, poses T_map_base, metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import Pose
from ..plans.plan_map import PlanMap
from ..plans.plan_raster import PlanRaster

MAX_LOOKUP_CELLS = 1 << 25
"""Most cells of a `WallLookup` grid (32 M cells, 128 MB of labels); a larger plan's grid is coarser."""

LOOKUP_MARGIN = 2.0
"""Metres of grid around the plan's wall points: returns farther out pair with no wall."""


@dataclass(frozen=True)
class ScaleFit:
    """What one scan says about the plan's scale.

    Attributes:
        error: `e`, the plan's scale relative to the world minus one (+0.03: the plan is 3 %
            too large; the world is the plan scaled by 1 / (1 + e)).
        variance: variance of `error` from the fit's residuals and geometry (not inflated for
            the correlation of neighbouring beams).
        pairs: returns paired with a wall.
        mean_range: mean distance of those returns from the robot, metres.
        explained: share of the returns used (at most `MAX_POINTS`) within `EXPLAINED_DISTANCE`
            of their wall once the scan is scaled: how much of the scan the similarity explains
            (a scan mostly of clutter has a fit of its own to a few walls, not a scale).
        explained_rigid: the same share at the rigid fit's pose, unscaled: a scale the scan
            needs explains more of it than that.
    """

    error: float
    variance: float
    pairs: int
    mean_range: float
    explained: float
    explained_rigid: float = math.nan


class WallLookup:
    """The plan's wall point nearest to any map position, to within one grid cell.

    A grid of `cell` metres over the plan's extent (plus `LOOKUP_MARGIN`) marks the cells holding
    a wall point; OpenCV's distance transform labels every cell with its nearest wall cell, which
    names one of its wall points (with its normal). Built once per plan (milliseconds for an
    office floor); a lookup is two array reads per point. A point's residual is taken along the
    normal of the wall point found, so being a cell off along the wall does not change it.
    """

    def __init__(self, plan: PlanMap, cell: float | None = None) -> None:
        import cv2

        points = plan.points
        self.points = points
        self.normals = plan.normals
        x0, y0, x1, y1 = plan.extent
        cell = float(cell if cell is not None else plan.raster_resolution)
        span = max(x1 - x0, y1 - y0) + 2 * LOOKUP_MARGIN
        while (span / cell + 1) ** 2 > MAX_LOOKUP_CELLS:
            cell *= 2.0
        self.cell = cell
        self.origin = (x0 - LOOKUP_MARGIN, y0 - LOOKUP_MARGIN)
        cols = int(math.ceil((x1 - x0 + 2 * LOOKUP_MARGIN) / cell)) + 1
        rows = int(math.ceil((y1 - y0 + 2 * LOOKUP_MARGIN) / cell)) + 1
        self.shape = (rows, cols)
        c = ((points[:, 0] - self.origin[0]) / cell).astype(np.int64)
        r = ((points[:, 1] - self.origin[1]) / cell).astype(np.int64)
        flat = r * cols + c
        # One wall point per wall cell (the first in the plan's order), found by its flat index.
        owner = np.full(rows * cols, -1, dtype=np.int64)
        owner[flat[::-1]] = np.arange(len(points) - 1, -1, -1)
        free = np.ones((rows, cols), dtype=np.uint8)
        free.reshape(-1)[flat] = 0
        _, labels = cv2.distanceTransformWithLabels(free, cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
        # DIST_LABEL_PIXEL numbers the zero (wall) cells from 1 in row-major order.
        wall_cells = np.flatnonzero(free.reshape(-1) == 0)
        label_point = np.empty(len(wall_cells) + 1, dtype=np.int64)
        label_point[0] = -1
        label_point[1:] = owner[wall_cells]
        self.nearest = label_point[labels.reshape(-1)].astype(np.int32)
        raster = plan.raster
        if raster is None or raster.origin[2] != 0.0:
            raster = PlanRaster.from_points(points, plan.raster_resolution)
        # The plan image for the rays (rows growing with +y), as the occlusion rule casts it.
        self.grid = _core.OccupancyGrid(
            np.ascontiguousarray(raster.walls[::-1]), raster.resolution, (raster.origin[0], raster.origin[1])
        )
        self.reach = float(math.hypot(x1 - x0, y1 - y0) + 1.0)

    def nearest_points(self, xy: NDArray[np.float64]) -> NDArray[np.int64]:
        """Index into `points` of the wall point nearest each map position (N, 2), or -1 outside
        the grid."""
        rows, cols = self.shape
        out = np.full(len(xy), -1, dtype=np.int64)
        col = (xy[:, 0] - self.origin[0]) / self.cell
        row = (xy[:, 1] - self.origin[1]) / self.cell
        inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)  # NaN and inf are outside
        out[inside] = self.nearest[row[inside].astype(np.int64) * cols + col[inside].astype(np.int64)]
        return out


CAST_STEP = math.radians(0.25)
"""Angle between the rays cast through the plan from the fitted pose (1440 to the circle, as the
occlusion rule casts)."""


MAX_POINTS = 360
"""Most returns a scan's fit uses (every k-th beyond it): the scale is a single number, and 360
returns over a scan's arc already pin it to a tenth of a percent."""

MAX_SCALE_ERROR = 0.15
"""Largest scale error looked for: a return pairs with its wall up to `max_distance` plus this
share of its range (a far wall of a plan 10 % off is a tenth of its range from its return)."""

MAX_SHIFT = 2.0
"""Metres the similarity may move the robot from the rigid fit: a plan 15 % off centres the robot
at most 15 % of half a 25 m room away; a larger shift is an unconstrained direction."""

MAX_TURN = math.radians(10.0)
"""Radians the similarity may turn the robot from the rigid fit (a scale turns nothing)."""

TUKEY_C = 4.685
"""Tukey's biweight constant (95 % efficiency for Gaussian residuals), in robust sigmas."""

EXPLAINED_DISTANCE = 0.05
"""Metres within which a scaled return counts as explained by its wall (`ScaleFit.explained`)."""

MIN_SPREAD = 0.01
"""Least robust sigma of the residuals, metres (a LIDAR's range noise)."""


def explained_share(lookup: WallLookup, points: NDArray[np.float64], pose: Pose) -> float:
    """Share of `points` (base frame, metres) within `EXPLAINED_DISTANCE` of the wall their ray
    from `pose` (T_map_base) meets, along its normal: how much of a scan the plan explains there."""
    if not len(points):
        return 0.0
    bearing = np.arctan2(points[:, 1], points[:, 0])
    lo, hi = float(bearing.min()), float(bearing.max())
    x, y, yaw = pose
    ranges = lookup.grid.cast((x, y, yaw + lo), 0.0, CAST_STEP, int((hi - lo) / CAST_STEP) + 2, 0.0, lookup.reach)
    wall_range = ranges[np.rint((bearing - lo) / CAST_STEP).astype(np.int64)]
    direction = np.column_stack((np.cos(bearing + yaw), np.sin(bearing + yaw)))
    index = lookup.nearest_points(wall_range[:, None] * direction + (x, y))
    paired = np.isfinite(wall_range) & (wall_range < lookup.reach) & (index >= 0)
    normal = lookup.normals[index[paired]]
    length = np.hypot(points[paired, 0], points[paired, 1])
    # The return and the wall lie on the same ray: their distance along the wall's normal.
    gap = np.abs(np.einsum("ij,ij->i", normal, direction[paired])) * np.abs(length - wall_range[paired])
    return float(np.count_nonzero(gap <= EXPLAINED_DISTANCE)) / len(points)


def scale_fit(
    lookup: WallLookup,
    points: NDArray[np.float64],
    pose: Pose,
    max_distance: float,
    min_pairs: int = 30,
    iterations: int = 5,
) -> ScaleFit | None:
    """The scale error one scan shows at its fitted pose (see the module's docstring).

    Each return is paired with the wall a ray from the pose meets in its direction (cast exactly
    through the plan's raster: the face the laser sees, never the far face of a thin wall, which
    a return beyond a wall of a too small plan is nearer to), along that wall's normal. Gauss-Newton
    over (dx, dy, dyaw, e) from the rigid fit, cast again from the moved pose at each of
    `iterations` steps.

    Args:
        lookup: the plan's `WallLookup`.
        points: (N, 2) returns in the base frame, metres.
        pose: the fitted pose T_map_base (ICP's, not fused with the odometry prediction).
        max_distance: returns farther than this (metres) from their wall are not paired.
        min_pairs: fewer pairs, or walls in too few directions to tell a scale from a shift, give
            None.
        iterations: Gauss-Newton steps (>= 1).
    """
    if len(points) < min_pairs:
        return None
    if len(points) > MAX_POINTS:
        points = points[:: -(-len(points) // MAX_POINTS)]
    bearing = np.arctan2(points[:, 1], points[:, 0])
    lo, hi = float(bearing.min()), float(bearing.max())
    beams = int((hi - lo) / CAST_STEP) + 2
    x, y, yaw = pose
    # The wall each return's ray meets from the pose: its point and normal, found once (the wall
    # lines hold while the similarity moves the returns along them).
    ranges = lookup.grid.cast((x, y, yaw + lo), 0.0, CAST_STEP, beams, 0.0, lookup.reach)
    wall_range = ranges[np.rint((bearing - lo) / CAST_STEP).astype(np.int64)]
    direction = np.column_stack((np.cos(bearing + yaw), np.sin(bearing + yaw)))
    wall = wall_range[:, None] * direction + (x, y)
    index = lookup.nearest_points(wall)
    paired = np.isfinite(wall_range) & (wall_range < lookup.reach) & (index >= 0)
    if int(paired.sum()) < min_pairs:
        return None
    index = index[paired]
    normal = lookup.normals[index]
    offset = np.einsum("ij,ij->i", normal, wall[paired] - (x, y))  # n . (m - t): the wall line
    cos, sin = math.cos(yaw), math.sin(yaw)
    base = points[paired]
    rel0 = np.column_stack((cos * base[:, 0] - sin * base[:, 1], sin * base[:, 0] + cos * base[:, 1]))
    gate = max_distance + MAX_SCALE_ERROR * np.hypot(base[:, 0], base[:, 1])
    state = np.zeros(4)  # dx, dy, dyaw, e: the similarity applied to the scan about the robot
    variance = math.nan
    pairs = 0
    mean_range = 0.0
    for k_step in range(max(1, iterations)):
        c, s = math.cos(state[2]), math.sin(state[2])
        k = 1.0 + state[3]
        rel = k * np.column_stack((c * rel0[:, 0] - s * rel0[:, 1], s * rel0[:, 0] + c * rel0[:, 1]))
        residual = np.einsum("ij,ij->i", normal, rel) + normal @ state[:2] - offset
        near = np.abs(residual) <= gate
        if int(near.sum()) < min_pairs:
            return None
        n_near, rel_p, residual = normal[near], rel[near], residual[near]
        # Tukey's biweight about the residuals' median, after a first plain step has taken the
        # bulk of the scale out: furniture and people in front of the walls (returns a constant
        # distance short of them) then weigh nothing.
        if k_step:
            centre = float(np.median(residual))
            spread = max(1.4826 * float(np.median(np.abs(residual - centre))), MIN_SPREAD)
            u = (residual - centre) / (TUKEY_C * spread)
            weight = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        else:
            weight = np.ones(len(residual))
        pairs = int(np.count_nonzero(weight))
        if pairs < min_pairs:
            return None
        jac = np.column_stack(
            (
                n_near,
                n_near[:, 1] * rel_p[:, 0] - n_near[:, 0] * rel_p[:, 1],
                np.einsum("ij,ij->i", n_near, rel_p) / k,
            )
        )
        wjac = jac * weight[:, None]
        try:
            cov = np.linalg.inv(wjac.T @ jac)
        except np.linalg.LinAlgError:
            return None
        if not np.isfinite(cov).all() or cov[3, 3] <= 0.0:
            return None
        step = -cov @ (wjac.T @ residual)
        state += step
        if not (
            np.isfinite(state).all()
            and abs(state[3]) <= 2 * MAX_SCALE_ERROR
            and math.hypot(state[0], state[1]) <= MAX_SHIFT
            and abs(state[2]) <= MAX_TURN
        ):
            return None  # walls along one direction only (a corridor): no scale to tell from a shift
        after = residual + jac @ step
        sigma2 = float(weight @ (after * after)) / max(float(weight.sum()) - 4.0, 1.0)
        variance = sigma2 * float(cov[3, 3])
        mean_range = float(np.hypot(rel_p[:, 0], rel_p[:, 1]).mean())
        if k_step and abs(step[3]) < 1e-5:
            break
    if not (math.isfinite(variance) and variance > 0.0):
        return None
    # How much of the scan each model explains, every return paired with the wall its ray meets
    # from that model's pose (the rigid fit's pairs are the wrong walls for far returns once the
    # scale moves the robot by decimetres).
    length = np.hypot(points[paired, 0], points[paired, 1])
    facing = np.abs(np.einsum("ij,ij->i", normal, direction[paired]))
    rigid_gap = facing * np.abs(length - wall_range[paired])  # the rigid fit's pairs, cast above
    explained_rigid = float(np.count_nonzero(rigid_gap <= EXPLAINED_DISTANCE)) / len(points)
    explained = explained_share(lookup, (1.0 + state[3]) * points, (x + state[0], y + state[1], yaw + state[2]))
    # `state[3]` is the scale of the scan that fits the plan, minus one: the plan's scale error.
    return ScaleFit(float(state[3]), variance, pairs, mean_range, explained, explained_rigid)
