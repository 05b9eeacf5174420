"""The numpy reference of the simulated LIDAR: an exact grid ray caster that the native one
(`planicp._core.OccupancyGrid.cast`, behind `planicp.sim.simulate_ranges`) must agree with.

This was `planicp.synthetic`'s own caster before the package used the native one; it lives here as
the independent oracle of tests/test_ray_casting.py. `simulate_ranges` takes the same arguments,
makes the same random draws and returns the same ranges as `planicp.sim.simulate_ranges`.
"""

from __future__ import annotations

import math
import numbers
import weakref
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

# Cell classes of the ray-casting grid and return sources.
FREE: Final = 0
WALL: Final = 1
CLUTTER: Final = 2
DYNAMIC: Final = 3

_TWO_PI: Final = 2.0 * math.pi
# Grid-line crossings closer than this (in cells along the ray) are one corner crossing: the ray passes
# diagonally and does not hit the two cells it only grazes at the corner (makes rays through exact grid
# corners independent of 1-ulp rounding).
_CORNER_TIE: Final = 1e-9
_FULL_CIRCLE_TOL: Final = 1e-9

# Per floor (floors are immutable, hashed by identity): what the caster derives from it.
_DERIVED: weakref.WeakKeyDictionary[Any, dict[str, NDArray[Any]]] = weakref.WeakKeyDictionary()


def _derived(floor: Any) -> dict[str, NDArray[Any]]:
    got = _DERIVED.get(floor)
    if got is None:
        cls = np.zeros(floor.shape, dtype=np.uint8)
        cls[floor.clutter] = CLUTTER
        cls[floor.walls] = WALL  # clutter under a wall counts as wall
        got = {
            "cell_class": cls,
            "padded_class": np.pad(cls, 1, constant_values=FREE).ravel(),
            "skip_levels": box_clearance_levels(floor.occupied()),
        }
        _DERIVED[floor] = got
    return got


def _cell_class(floor: Any) -> NDArray[np.uint8]:
    """``uint8`` grid: 0 free, 1 wall, 2 clutter (clutter under a wall counts as wall)."""
    return _derived(floor)["cell_class"]


def _padded_class_flat(floor: Any) -> NDArray[np.uint8]:
    """Flattened cell classes with one free cell of padding around the raster (ray-casting lookups)."""
    return _derived(floor)["padded_class"]


def _skip_levels(floor: Any) -> NDArray[np.uint8]:
    """Box-clearance levels used for exact empty-space skipping in the ray caster."""
    return _derived(floor)["skip_levels"]


def _finite_float(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {out}")
    return out


def _int_arg(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    out = int(value)
    if out < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {out}")
    return out


def _pose_arg(pose: Any, name: str = "pose") -> tuple[float, float, float]:
    values = [float(v) for v in pose]
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{name} must be three finite floats (x, y, yaw), got {pose!r}")
    return values[0], values[1], values[2]


def box_clearance_levels(occ: NDArray[np.bool_]) -> NDArray[np.uint8]:
    """For each cell the largest ``h`` in (0, 1, 2, 4, ..., 64) such that the ``(2h+1) x (2h+1)`` box of cells
    centred on it contains no occupied cell (cells outside the raster count as free); 0 for occupied cells."""
    out = np.zeros(occ.shape, dtype=np.uint8)
    for h in (1, 2, 4, 8, 16, 32, 64):
        box_occ = _box_any(_box_any(occ, h, axis=1), h, axis=0)
        if box_occ.all():
            break
        out[~box_occ] = h
    return out


def _box_any(a: NDArray[np.bool_], h: int, axis: int) -> NDArray[np.bool_]:
    """``out[i] = any(a[i-h : i+h+1])`` along ``axis`` (clipped at the raster edges), via prefix sums."""
    work = a if axis == 1 else a.T
    rows, n = work.shape
    # ext[:, q] = number of True in work[:, :q - h] (0 for q <= h, the total for q >= n + h)
    ext = np.zeros((rows, n + 2 * h + 1), dtype=np.int32)
    np.cumsum(work, axis=1, out=ext[:, h + 1 : h + 1 + n])
    ext[:, h + 1 + n :] = ext[:, h + n : h + n + 1]
    out = (ext[:, 2 * h + 1 : 2 * h + 1 + n] - ext[:, :n]) > 0
    return out if axis == 1 else out.T


def _cast_grid(
    floor: Any,
    x: float,
    y: float,
    angles: NDArray[np.float64],
    max_range: float,
) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """Exact first-hit distance (metres) and hit class along rays from (x, y) (inside the raster).

    Amanatides-Woo traversal, vectorised over beams: a ray enters a new cell at each crossing of a vertical
    grid line (x event ``i`` at ``t = (fx + i) / |dx|`` cells) or horizontal grid line (y event ``j``). The
    cell entered at an x event is ``(cy0 + sy * #{y events at t' <= t}, cx0 + sx * (i + 1))`` and
    symmetrically for y events, so the cells along the ray are enumerated in closed form without merging the
    two event sequences. Crossings less than ``_CORNER_TIE`` cells apart count as one corner crossing: both
    events name the diagonal cell and the two cells touched only at the corner are not hit. Events are
    generated in windows of t for the beams still travelling; before each window the beams skip empty space
    using a cached box-clearance map (a beam whose cell is the centre of an occupied-free ``(2h+1)^2`` box
    can advance ``h - 1`` cells without entering an occupied cell; one cell is kept as a rounding guard), so
    the result is still exact. Returns ``inf``/``FREE`` where nothing is hit within ``max_range`` before the
    ray leaves the raster.
    """
    cls = _cell_class(floor)
    rows, cols = cls.shape
    padded = _padded_class_flat(floor)  # (rows + 2) * (cols + 2), one free cell around the raster
    stride = cols + 2
    skip = _skip_levels(floor)
    res = floor.resolution
    ox, oy = floor.origin
    n = angles.size
    dist = np.full(n, np.inf)
    hit_cls = np.zeros(n, dtype=np.uint8)
    gx = (x - ox) / res
    gy = (y - oy) / res
    cx0 = min(max(math.floor(gx), 0), cols - 1)
    cy0 = min(max(math.floor(gy), 0), rows - 1)
    start = int(cls[cy0, cx0])
    if start != FREE:
        dist[:] = 0.0
        hit_cls[:] = start
        return dist, hit_cls

    dx, dy = np.cos(angles), np.sin(angles)
    adx, ady = np.abs(dx), np.abs(dy)
    sx = np.where(dx > 0.0, 1.0, -1.0)
    sy = np.where(dy > 0.0, 1.0, -1.0)
    fx = np.where(dx > 0.0, cx0 + 1 - gx, gx - cx0)  # distance (cells) to the first vertical grid line
    fy = np.where(dy > 0.0, cy0 + 1 - gy, gy - cy0)
    inv_x = np.full(n, np.inf)
    inv_y = np.full(n, np.inf)
    np.divide(1.0, adx, out=inv_x, where=adx > 0.0)
    np.divide(1.0, ady, out=inv_y, where=ady > 0.0)
    fx = np.where(adx > 0.0, fx, 1.0)
    fy = np.where(ady > 0.0, fy, 1.0)
    # parameter (cells) at which the ray leaves the raster: nothing beyond can be hit
    # (an axis the ray does not move along never bounds it: 0 * inf would give NaN on an edge)
    with np.errstate(invalid="ignore"):
        t_exit = np.minimum(
            np.where(adx > 0.0, np.where(dx > 0.0, cols - gx, gx) * inv_x, np.inf),
            np.where(ady > 0.0, np.where(dy > 0.0, rows - gy, gy) * inv_y, np.inf),
        )
    t_max = max_range / res
    t_end = np.minimum(t_exit, t_max)
    per_axis = ((fx, inv_x, adx, sx), (fy, inv_y, ady, sy))

    t_cur = np.zeros(n)
    active = np.arange(n)
    window = 16.0
    while active.size:
        # empty-space skipping (exact lower bound on the first hit)
        tc = t_cur[active]
        ddx, ddy = dx[active], dy[active]
        for _ in range(4):
            ci = np.clip(np.floor(gx + tc * ddx), 0, cols - 1).astype(np.intp)
            ri = np.clip(np.floor(gy + tc * ddy), 0, rows - 1).astype(np.intp)
            tc += np.maximum(skip[ri, ci].astype(np.float64) - 1.0, 0.0)
        going = tc < t_end[active]
        active, tc = active[going], tc[going]
        if not active.size:
            break
        t1 = tc + window
        t_hi = np.minimum(t1, t_exit[active])[:, None]
        steps = np.arange(math.ceil(window) + 4, dtype=np.float64)
        best_t = np.full(active.size, np.inf)
        best_c = np.zeros(active.size, dtype=np.uint8)
        for axis in (0, 1):
            f_a, inv_a, a_a, s_a = (v[active][:, None] for v in per_axis[axis])
            f_b, inv_b, a_b, s_b = (v[active][:, None] for v in per_axis[1 - axis])
            idx = np.maximum(np.floor(tc[:, None] * a_a - f_a) - 1.0, 0.0) + steps  # event indices
            t = (f_a + idx) * inv_a
            ok = (t >= tc[:, None]) & (t < t_hi) & (t <= t_max)
            ts = np.where(ok, t, 0.0) + _CORNER_TIE
            # crossings of the other axis at parameter <= t (+ the corner tie tolerance): floor estimate,
            # then a fix-up with the same float comparisons, so that both event sequences agree on the order
            m = np.maximum(np.floor(ts * a_b - f_b) + 1.0, 0.0)
            with np.errstate(invalid="ignore"):  # 0 * inf for beams parallel to the other axis
                m += (f_b + m) * inv_b <= ts
                m -= (m > 0.0) & ((f_b + m - 1.0) * inv_b > ts)
            main = s_a * (idx + 1.0)
            other = s_b * m
            if axis == 0:
                flat = (cy0 + 1.0 + other) * stride + (cx0 + 1.0 + main)
            else:
                flat = (cy0 + 1.0 + main) * stride + (cx0 + 1.0 + other)
            c_hit = np.take(padded, flat.astype(np.intp), mode="clip")
            th = np.where(ok & (c_hit != FREE), t, np.inf)
            first = th.min(axis=1)
            better = first < best_t
            if better.any():
                rows_b = np.flatnonzero(better)
                best_t[rows_b] = first[rows_b]
                best_c[rows_b] = c_hit[rows_b, np.argmin(th[rows_b], axis=1)]
        found = np.isfinite(best_t)
        dist[active[found]] = best_t[found] * res
        hit_cls[active[found]] = best_c[found]
        keep = ~found & (t_end[active] >= t1)
        t_cur[active[keep]] = t1[keep]
        active = active[keep]
        window = min(window * 2.0, 64.0)
    return dist, hit_cls


def _cast_discs(x: float, y: float, angles: NDArray[np.float64], discs: NDArray[np.float64]) -> NDArray[np.float64]:
    """Exact ray-circle first-hit distance (metres) from (x, y); 0 if the origin is inside a disc."""
    dx, dy = np.cos(angles)[:, None], np.sin(angles)[:, None]
    wx, wy = x - discs[None, :, 0], y - discs[None, :, 1]
    b = dx * wx + dy * wy
    c = wx * wx + wy * wy - discs[None, :, 2] ** 2
    disc = b * b - c
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(np.where(disc >= 0.0, disc, 0.0))
    t = np.where((disc >= 0.0) & (t >= 0.0), t, np.inf)
    t = np.where(c <= 0.0, 0.0, t)
    out: NDArray[np.float64] = t.min(axis=1)
    return out


def _beam_angles(beams: Any, fov: Any) -> tuple[int, float, float]:
    beams = _int_arg(beams, "beams", 2)
    fov = _finite_float(fov, "fov")
    if not 0.0 < fov <= _TWO_PI + _FULL_CIRCLE_TOL:
        raise ValueError(f"fov must be in (0, 2*pi] radians, got {fov}")
    if fov >= _TWO_PI - _FULL_CIRCLE_TOL:
        return beams, -math.pi, _TWO_PI / beams
    return beams, -0.5 * fov, fov / (beams - 1)


def _simulate(
    floor: Any,
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
) -> tuple[NDArray[np.float64], float, float, NDArray[np.uint8]]:
    x, y, yaw = _pose_arg(pose)
    beams, angle_min, angle_increment = _beam_angles(beams, fov)
    max_range = _finite_float(max_range, "max_range")
    min_range = _finite_float(min_range, "min_range")
    if min_range < 0.0:
        raise ValueError(f"min_range must be >= 0 metres, got {min_range}")
    if max_range <= min_range:
        raise ValueError(f"max_range ({max_range}) must be > min_range ({min_range})")
    range_sigma = _finite_float(range_sigma, "range_sigma")
    if range_sigma < 0.0:
        raise ValueError(f"range_sigma must be >= 0 metres, got {range_sigma}")
    dropout = _finite_float(dropout, "dropout")
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

    world = yaw + angle_min + angle_increment * np.arange(beams, dtype=np.float64)
    dist, source = _cast_grid(floor, x, y, world, max_range)
    if discs is not None and discs.shape[0]:
        t_disc = _cast_discs(x, y, world, discs)
        closer = (t_disc <= max_range) & (t_disc < dist)
        dist = np.where(closer, t_disc, dist)
        source = np.where(closer, np.uint8(DYNAMIC), source).astype(np.uint8)
    noise = rng.normal(0.0, range_sigma, beams) if range_sigma > 0.0 else np.zeros(beams)
    dropped = rng.random(beams) < dropout
    ranges = dist + noise
    ranges[~np.isfinite(dist) | (ranges > max_range)] = np.inf
    ranges[np.isfinite(dist) & (ranges < min_range)] = -np.inf
    ranges[dropped] = np.inf
    source = np.where(np.isfinite(ranges), source, np.uint8(FREE)).astype(np.uint8)
    return ranges, angle_min, angle_increment, source


def simulate_ranges(
    floor: Any, pose: Any, rng: np.random.Generator, **kwargs: Any
) -> tuple[NDArray[np.float64], float, float]:
    """`planicp.sim.simulate_ranges`, cast in numpy."""
    ranges, angle_min, angle_increment, _ = _simulate(floor, pose, rng, **kwargs)
    return ranges, angle_min, angle_increment


def simulate_scan(
    floor: Any, pose: Any, rng: np.random.Generator, **kwargs: Any
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """`planicp.sim.simulate_scan`, cast in numpy: sensor-frame points and whether each came from
    clutter or a disc rather than a wall."""
    ranges, angle_min, angle_increment, source = _simulate(floor, pose, rng, **kwargs)
    valid = np.isfinite(ranges)
    a = angle_min + angle_increment * np.flatnonzero(valid)
    r = ranges[valid]
    return np.column_stack([r * np.cos(a), r * np.sin(a)]), source[valid] != WALL
