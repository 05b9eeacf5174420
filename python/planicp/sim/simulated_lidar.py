"""A simulated 2D LIDAR in a `Floor`: ROS ``LaserScan``-style ranges
(`simulate_ranges`), sensor-frame points with their source (`simulate_scan`), and ranges
back to points (`ranges_to_points`).

Walls and clutter occlude, and so do optional moving discs (people). The beams are cast by the native
ray caster (``planicp._core.OccupancyGrid.cast``, the one the simulator's drives use); noise and dropouts
are drawn here from the caller's generator. Invalid readings follow REP-117:
``+inf`` for "no return within ``max_range``" (and dropped beams), ``-inf`` for a return closer than
``min_range``.
"""

from __future__ import annotations

import math
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..laser_scan import scan_to_points
from .argument_checks import finite_float, int_arg, pose_arg
from .floor import Floor

__all__ = ["ranges_to_points", "simulate_ranges", "simulate_scan"]

_TWO_PI: Final = 2.0 * math.pi
_FULL_CIRCLE_TOL: Final = 1e-9


def _beam_angles(beams: Any, fov: Any) -> tuple[int, float, float]:
    beams = int_arg(beams, "beams", 2)
    fov = finite_float(fov, "fov")
    if not 0.0 < fov <= _TWO_PI + _FULL_CIRCLE_TOL:
        raise ValueError(f"fov must be in (0, 2*pi] radians, got {fov}")
    if fov >= _TWO_PI - _FULL_CIRCLE_TOL:
        return beams, -math.pi, _TWO_PI / beams
    return beams, -0.5 * fov, fov / (beams - 1)


def _simulate(
    floor: Floor,
    pose: Any,
    rng: np.random.Generator,
    *,
    beams: int = 1080,
    fov: float = _TWO_PI,
    max_range: float = 30.0,
    min_range: float = 0.1,
    range_sigma: float = 0.015,
    dropout: float = 0.0,
    dynamic_discs: ArrayLike | None = None,
    want_sources: bool = False,
) -> tuple[NDArray[np.float64], float, float, NDArray[np.bool_] | None]:
    if not isinstance(floor, Floor):
        raise ValueError(f"floor must be a Floor, got {type(floor).__name__}")
    x, y, yaw = pose_arg(pose)
    beams, angle_min, angle_increment = _beam_angles(beams, fov)
    max_range = finite_float(max_range, "max_range")
    min_range = finite_float(min_range, "min_range")
    if min_range < 0.0:
        raise ValueError(f"min_range must be >= 0 metres, got {min_range}")
    if max_range <= min_range:
        raise ValueError(f"max_range ({max_range}) must be > min_range ({min_range})")
    range_sigma = finite_float(range_sigma, "range_sigma")
    if range_sigma < 0.0:
        raise ValueError(f"range_sigma must be >= 0 metres, got {range_sigma}")
    dropout = finite_float(dropout, "dropout")
    if not 0.0 <= dropout <= 1.0:
        raise ValueError(f"dropout must be a probability in [0, 1], got {dropout}")
    discs: NDArray[np.float64] | None = None
    if dynamic_discs is not None:
        discs = np.asarray(dynamic_discs, dtype=np.float64)
        if discs.ndim != 2 or discs.shape[1] != 3:
            raise ValueError(f"dynamic_discs must have shape (K, 3) of (x, y, radius), got {discs.shape}")
        if not np.isfinite(discs).all() or (discs[:, 2] <= 0.0).any():
            raise ValueError("dynamic_discs must be finite with radius > 0")
    xmin, ymin, xmax, ymax = floor.extent
    if not (xmin <= x < xmax and ymin <= y < ymax):
        raise ValueError(f"sensor position ({x}, {y}) is outside the floor extent {floor.extent}")

    # Noise-free ranges from the native caster (range_min 0: a sensor inside an occupied cell reads 0);
    # the noise, dropouts and REP-117 limits below are applied here, with the caller's generator.
    pose3 = (x, y, yaw)
    dist = floor._native_grid("occupied").cast(
        pose3,
        angle_min,
        angle_increment,
        beams,
        0.0,
        max_range,
        discs=discs if discs is not None and discs.shape[0] else None,
    )
    from_wall: NDArray[np.bool_] | None = None
    if want_sources:
        from_wall = _from_wall(floor, pose3, angle_min, angle_increment, beams, max_range, dist)
    noise = rng.normal(0.0, range_sigma, beams) if range_sigma > 0.0 else np.zeros(beams)
    dropped = rng.random(beams) < dropout
    ranges = dist + noise
    ranges[~np.isfinite(dist) | (ranges > max_range)] = np.inf
    ranges[np.isfinite(dist) & (ranges < min_range)] = -np.inf
    ranges[dropped] = np.inf
    return ranges, angle_min, angle_increment, from_wall


def _from_wall(
    floor: Floor,
    pose: tuple[float, float, float],
    angle_min: float,
    angle_increment: float,
    beams: int,
    max_range: float,
    dist: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """Per beam, whether its return (at ``dist``) ends on a plan wall rather than on clutter or a disc.

    A beam stops at the first occupied cell it enters; cast through the walls alone, it stops at the same
    distance exactly when that cell is a wall (the cells are entered at the same crossings either way), and
    later when it was clutter or a disc. A sensor inside an occupied cell reads 0 on every beam: its returns
    are the class of that cell."""
    x, y, _ = pose
    rows, cols = floor.shape
    ox, oy = floor.origin
    c0 = min(max(math.floor((x - ox) / floor.resolution), 0), cols - 1)
    r0 = min(max(math.floor((y - oy) / floor.resolution), 0), rows - 1)
    if floor.walls[r0, c0] or floor.clutter[r0, c0]:
        return np.full(beams, bool(floor.walls[r0, c0]))
    walls_only = floor._native_grid("walls").cast(pose, angle_min, angle_increment, beams, 0.0, max_range)
    out: NDArray[np.bool_] = ~(dist < walls_only)
    return out


def simulate_ranges(
    floor: Floor,
    pose: tuple[float, float, float],
    rng: np.random.Generator,
    *,
    beams: int = 1080,
    fov: float = _TWO_PI,
    max_range: float = 30.0,
    min_range: float = 0.1,
    range_sigma: float = 0.015,
    dropout: float = 0.0,
    dynamic_discs: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], float, float]:
    """Simulate a 2D LIDAR at ``pose`` like a ROS ``LaserScan``.

    Args:
        floor: the floor; walls AND clutter occlude.
        pose: sensor pose ``(x, y, yaw)`` in the map frame (metres, radians); the position must lie inside
            ``floor.extent``. A sensor inside an occupied cell or disc measures 0 (reported as ``-inf``).
        rng: source of noise and dropout (``beams`` normal draws if ``range_sigma > 0``, then ``beams``
            uniform draws, regardless of the geometry).
        beams: number of beams, >= 2.
        fov: field of view in radians, in ``(0, 2*pi]``. Beam ``i`` is at
            ``angle_min + i * angle_increment`` in the sensor frame with ``angle_min = -fov/2``; for a full
            circle ``angle_increment = fov/beams`` (the last beam does not duplicate the first), otherwise
            ``fov/(beams-1)`` (the last beam is at ``+fov/2``).
        max_range: metres, ``> min_range``.
        min_range: metres, ``0 <= min_range < max_range``.
        range_sigma: standard deviation (metres) of the additive Gaussian range noise, >= 0.
        dropout: probability in ``[0, 1]`` that a beam returns nothing (``+inf``).
        dynamic_discs: optional ``(K, 3)`` array of ``(x, y, radius)`` (map frame, metres) moving obstacles
            (people) that also occlude, by exact ray-circle intersection.

    Returns:
        ``(ranges, angle_min, angle_increment)``: ``ranges`` is ``(beams,)`` float64 in metres -- the exact
        distance to the first occupied cell boundary (the native caster ``planicp._core.OccupancyGrid.cast``:
        exact grid traversal; a beam passing within 1e-9 cells of a cell corner does not hit the cells it only
        grazes there) or disc, plus noise; ``+inf`` when
        nothing is hit within ``max_range`` (or the noisy range exceeds it) or the beam dropped out; ``-inf``
        when the noisy range is below ``min_range`` (REP-117).

    Raises:
        ValueError: bad ``beams``/``fov``/ranges/``range_sigma``/``dropout``, ``dynamic_discs`` not
            ``(K, 3)`` with positive radii, a non-finite pose or a sensor outside the floor extent.
    """
    ranges, angle_min, angle_increment, _ = _simulate(
        floor, pose, rng, beams=beams, fov=fov, max_range=max_range, min_range=min_range,
        range_sigma=range_sigma, dropout=dropout, dynamic_discs=dynamic_discs,
    )  # fmt: skip
    return ranges, angle_min, angle_increment


def ranges_to_points(
    ranges: ArrayLike,
    angle_min: float,
    angle_increment: float,
    range_min: float = 0.0,
    range_max: float = np.inf,
) -> NDArray[np.float64]:
    """``(M, 2)`` float64 points (metres, sensor frame) of finite ranges within ``[range_min, range_max]``.

    Beam ``i`` points along ``angle_min + i * angle_increment`` (radians, CCW from the sensor's +x axis).
    The same conversion as :func:`planicp.scan_to_points` (which it calls), with the simulator's
    defaults: every finite non-negative range is kept.
    """
    return scan_to_points(np.asarray(ranges, dtype=np.float64), angle_min, angle_increment, range_min, range_max)


def simulate_scan(
    floor: Floor, pose: tuple[float, float, float], rng: np.random.Generator, **kwargs: Any
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Convenience wrapper of `simulate_ranges` (same keyword arguments and random draws).

    Returns:
        ``(points, is_clutter)``: ``points`` ``(M, 2)`` float64 in metres in the sensor frame (valid returns
        only, in beam order) and ``is_clutter`` ``(M,)`` bool, True where the return came from clutter or a
        dynamic disc rather than a plan wall.
    """
    ranges, angle_min, angle_increment, from_wall = _simulate(floor, pose, rng, want_sources=True, **kwargs)
    assert from_wall is not None
    valid = np.isfinite(ranges)
    points = ranges_to_points(ranges, angle_min, angle_increment)
    return points, ~from_wall[valid]
