"""Tests of the native simulated LIDAR, planicp._core.OccupancyGrid: agreement with the numpy reference
caster of numpy_ray_caster.py, noise and dropouts, seeds, and the errors of bad input."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

import numpy_ray_caster
from planicp import sim as synthetic
from planicp._core import OccupancyGrid, PlanicpError

EXACT = 1e-9  # metres
FOV = math.radians(270.0)


@functools.cache
def _floor(layout: str) -> Any:
    return synthetic.generate_floor(3, layout)


def _grid(floor: Any) -> OccupancyGrid:
    return OccupancyGrid(floor.occupied(), floor.resolution, floor.origin)


def _box(
    rows: int = 60, cols: int = 80, res: float = 0.05, origin: tuple[float, float] = (-1.0, -0.5)
) -> tuple[NDArray[np.bool_], float, tuple[float, float]]:
    """A closed one-cell-thick box around the raster's border; free inside."""
    cells = np.zeros((rows, cols), dtype=bool)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = True
    return cells, res, origin


def _agreement(ref: NDArray[np.float64], nat: NDArray[np.float64]) -> tuple[int, int, float]:
    """(beams agreeing to EXACT, beams in total, worst difference of the others where both finite)."""
    with np.errstate(invalid="ignore"):  # inf - inf
        same = (ref == nat) | (np.isfinite(ref) & np.isfinite(nat) & (np.abs(ref - nat) <= EXACT))
    others = ~same
    worst = 0.0
    if others.any():
        both = np.isfinite(ref[others]) & np.isfinite(nat[others])
        worst = float(np.max(np.abs(ref[others] - nat[others]), initial=0.0)) if both.all() else math.inf
    return int(same.sum()), int(ref.size), worst


@pytest.mark.parametrize("layout", synthetic.LAYOUTS)
def test_matches_synthetic_reference(layout: str) -> None:
    """Noise-free native ranges equal numpy_ray_caster.simulate_ranges on generated floors: random poses (some
    snapped to cell corners, some with yaw 0, so beams run along grid lines and through corners), 270 and
    360 degree scans, with and without people (discs)."""
    floor = _floor(layout)
    grid = _grid(floor)
    rng = np.random.default_rng(17)
    ox, oy = floor.origin
    res = floor.resolution
    agree = total = 0
    worst = 0.0
    for k in range(60):
        x, y, yaw = floor.sample_pose(rng, clearance=0.0 if k % 2 else 0.4)
        if k % 3 == 0:  # on a cell corner
            x, y = ox + round((x - ox) / res) * res, oy + round((y - oy) / res) * res
        if k % 5 == 1:
            yaw = 0.0
        discs = None
        if k % 2:
            n = int(rng.integers(0, 6))
            centres = np.array([x, y]) + rng.uniform(-4.0, 4.0, (n, 2))
            discs = np.column_stack([centres, rng.uniform(0.1, 0.4, n)])
        beams, fov = (1081, FOV) if k % 4 else (1440, 2.0 * math.pi)
        kwargs: dict[str, Any] = dict(
            beams=beams, fov=fov, max_range=30.0, min_range=0.1, range_sigma=0.0, dynamic_discs=discs
        )
        ref, angle_min, angle_increment = numpy_ray_caster.simulate_ranges(floor, (x, y, yaw), rng, **kwargs)
        nat = grid.cast((x, y, yaw), angle_min, angle_increment, beams, 0.1, 30.0, discs=discs)
        assert nat.shape == (beams,) and nat.dtype == np.float64
        a, n, w = _agreement(ref, nat)
        agree, total, worst = agree + a, total + n, max(worst, w)
    assert agree >= 0.999 * total, f"{total - agree} of {total} beams differ"
    assert worst <= res, f"a differing beam is off by {worst} m"
    # Both casters compute the same crossings with the same float operations; on this platform they
    # agree on every beam (the margin above is for a numpy whose sin/cos differ in the last bit).
    assert agree == total


@pytest.mark.parametrize("layout", synthetic.LAYOUTS)
def test_package_scans_match_the_numpy_reference(layout: str) -> None:
    """planicp.sim.simulate_scan and simulate_ranges (the native caster, noise drawn in Python) give the
    numpy reference's ranges, points and clutter flags bit for bit, with noise, dropouts and people,
    from random poses, poses on cell corners and yaw 0."""
    floor = _floor(layout)
    rng = np.random.default_rng(23)
    ox, oy = floor.origin
    res = floor.resolution
    for k in range(20):
        x, y, yaw = floor.sample_pose(rng, clearance=0.0 if k % 3 else 0.3)
        if k % 4 == 0:
            x, y, yaw = ox + round((x - ox) / res) * res, oy + round((y - oy) / res) * res, 0.0
        discs = np.column_stack([np.array([x, y]) + rng.uniform(-3.0, 3.0, (4, 2)), rng.uniform(0.1, 0.4, 4)])
        kwargs: dict[str, Any] = dict(
            beams=1081, fov=FOV, max_range=12.0, range_sigma=0.01, dropout=0.05, dynamic_discs=discs
        )
        got = synthetic.simulate_ranges(floor, (x, y, yaw), np.random.default_rng(k), **kwargs)
        want = numpy_ray_caster.simulate_ranges(floor, (x, y, yaw), np.random.default_rng(k), **kwargs)
        assert np.array_equal(got[0], want[0]) and got[1:] == want[1:]
        points, clutter = synthetic.simulate_scan(floor, (x, y, yaw), np.random.default_rng(k), **kwargs)
        ref_points, ref_clutter = numpy_ray_caster.simulate_scan(floor, (x, y, yaw), np.random.default_rng(k), **kwargs)
        assert np.array_equal(points, ref_points) and np.array_equal(clutter, ref_clutter)
        assert 0 < clutter.sum() < clutter.size


def test_rows_grow_with_y_and_origin_is_the_lower_left_corner() -> None:
    cells = np.zeros((40, 30), dtype=bool)
    cells[-1, :] = True  # the top row: highest y
    grid = OccupancyGrid(cells, 0.1, (2.0, -1.0))
    assert grid.shape == (40, 30) and grid.resolution == 0.1 and grid.origin == (2.0, -1.0)
    # The top row spans y in [2.9, 3.0): a beam up from y = 1.0 hits it 1.9 m away.
    up = grid.cast((3.0, 1.0, math.pi / 2), 0.0, 0.0, 1, 0.0, 10.0)
    down = grid.cast((3.0, 1.0, -math.pi / 2), 0.0, 0.0, 1, 0.0, 10.0)
    assert abs(up[0] - 1.9) < EXACT and down[0] == math.inf


def test_box_analytic_ranges_doorway_and_limits() -> None:
    cells, res, origin = _box()
    # Inner faces: x in [-0.95, 2.95], y in [-0.45, 2.45].
    cells[30:40, -1] = False  # a doorway in the right wall, y in [1.0, 1.5)
    grid = OccupancyGrid(cells, res, origin)
    x, y = 0.3, 0.2
    beams = 3600
    r = grid.cast((x, y, 0.0), -math.pi, 2 * math.pi / beams, beams, 0.0, 50.0)
    a = -math.pi + 2 * math.pi / beams * np.arange(beams)
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 0, (2.95 - x) / c, np.where(c < 0, (-0.95 - x) / c, np.inf))
        ty = np.where(s > 0, (2.45 - y) / s, np.where(s < 0, (-0.45 - y) / s, np.inf))
        expected = np.minimum(tx, ty)
        # Through the doorway: inside it from the inner face x = 2.95 to the raster's edge x = 3.0.
        y_in, y_out = y + (2.95 - x) / c * s, y + (3.0 - x) / c * s
    door = (c > 0) & (tx <= ty) & (np.minimum(y_in, y_out) >= 1.0) & (np.maximum(y_in, y_out) < 1.5)
    # Into the doorway, then out through its side into the wall: a hit beyond the inner face.
    door_side = (c > 0) & (tx <= ty) & (y_in > 1.0) & (y_in < 1.5) & ~door
    assert door.sum() > 10 and door_side.sum() > 0
    assert np.all(r[door] == math.inf)
    assert np.all((r[door_side] > expected[door_side]) & (r[door_side] < expected[door_side] + 0.1))
    plain = ~door & ~door_side
    assert np.allclose(r[plain], expected[plain], atol=EXACT, rtol=0)
    # range_max just below a hit: +inf; range_min above it: -inf.
    assert grid.cast((x, y, 0.0), 0.0, 0.0, 1, 0.0, 2.6)[0] == math.inf
    assert grid.cast((x, y, 0.0), 0.0, 0.0, 1, 2.7, 30.0)[0] == -math.inf
    # Inside a wall the range is 0: -inf with range_min > 0.
    assert grid.cast((-0.98, 0.0, 0.0), 0.0, 0.1, 5, 0.05, 30.0).tolist() == [-math.inf] * 5


def test_discs_occlude_and_a_sensor_outside_the_grid() -> None:
    cells, res, origin = _box()
    grid = OccupancyGrid(cells, res, origin)
    discs = np.array([[1.5, 0.2, 0.25], [0.8, 0.2, 0.1]])
    r = grid.cast((0.3, 0.2, 0.0), 0.0, 0.0, 1, 0.0, 30.0, discs=discs)
    assert abs(r[0] - 0.4) < EXACT
    no_discs = grid.cast((0.3, 0.2, 0.0), 0.0, 0.0, 1, 0.0, 30.0, discs=np.zeros((0, 3)))
    assert no_discs[0] == pytest.approx(2.65)
    # Outside the raster (synthetic refuses this): the outer face x = 3.0 of the box, 2 m away.
    assert abs(grid.cast((5.0, 1.0, math.pi), 0.0, 0.0, 1, 0.0, 30.0)[0] - 2.0) < EXACT
    assert grid.cast((5.0, 1.0, 0.0), 0.0, 0.0, 1, 0.0, 30.0)[0] == math.inf


def test_noise_and_dropout_statistics() -> None:
    cells, res, origin = _box()
    grid = OccupancyGrid(cells, res, origin)
    beams, sigma = 100_000, 0.02
    args = ((0.3, 0.2, 0.1), -math.pi, 2 * math.pi / beams, beams, 0.0, 50.0)
    clean = grid.cast(*args)
    assert np.isfinite(clean).all()
    noisy = grid.cast(*args, range_sigma=sigma, seed=1)
    err = noisy - clean
    assert abs(err.mean()) < 3 * sigma / math.sqrt(beams)
    assert abs(err.std() / sigma - 1.0) < 0.02
    for p in (0.05, 0.3):
        dropped = grid.cast(*args, dropout=p, seed=2)
        assert np.all((dropped == clean) | (dropped == math.inf))
        assert abs(np.mean(dropped == math.inf) - p) < 0.005
    assert np.all(grid.cast(*args, dropout=1.0, seed=3) == math.inf)
    # A noisy range beyond range_max is +inf, below range_min -inf.
    near = grid.cast((0.3, 0.2, 0.0), 0.0, 0.0, 1, 0.0, 30.0)[0]
    limits = ((0.3, 0.2, 0.0), 0.0, 0.0, 1, near - 1e-3, near + 1e-3)
    outcomes = {float(grid.cast(*limits, range_sigma=0.05, seed=s)[0]) for s in range(40)}
    assert math.inf in outcomes and -math.inf in outcomes


def test_seeds_make_scans_reproducible() -> None:
    floor = _floor("office")
    grid = _grid(floor)
    pose = floor.sample_pose(np.random.default_rng(0))
    args = (pose, -FOV / 2, FOV / 1080, 1081, 0.1, 30.0)
    kwargs: dict[str, Any] = dict(range_sigma=0.015, dropout=0.1)
    a = grid.cast(*args, seed=5, **kwargs)
    assert np.array_equal(a, grid.cast(*args, seed=5, **kwargs))
    assert np.array_equal(a, grid.cast(*args, seed=np.uint64(5), **kwargs))  # type: ignore[arg-type]
    assert not np.array_equal(a, grid.cast(*args, seed=6, **kwargs))
    assert not np.array_equal(grid.cast(*args, **kwargs), grid.cast(*args, **kwargs))  # from OS entropy
    # Without noise the seed plays no part.
    assert np.array_equal(grid.cast(*args), grid.cast(*args, seed=9))


_GRID = OccupancyGrid(np.zeros((10, 20), dtype=bool), 0.05, (0.0, 0.0))
_CAST = ((0.5, 0.25, 0.0), 0.0, 0.01, 10, 0.1, 30.0)


def _cast(*args: Any, **kwargs: Any) -> Callable[[], object]:
    return lambda: _GRID.cast(*args, **kwargs)


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: OccupancyGrid(np.zeros((4, 4), np.uint8), 0.05, (0, 0)), TypeError, "dtype bool"),
        (
            lambda: OccupancyGrid(np.zeros((4, 4)), 0.05, (0, 0)),  # type: ignore[arg-type]
            TypeError,
            r"dtype bool \(True = occupied\), got float64",
        ),
        (
            lambda: OccupancyGrid([[True, False]], 0.05, (0, 0)),  # type: ignore[arg-type]
            TypeError,
            "numpy bool array",
        ),
        (lambda: OccupancyGrid(np.zeros(4, bool), 0.05, (0, 0)), ValueError, r"2-D.*\(4,\)"),
        (lambda: OccupancyGrid(np.zeros((2, 2, 2), bool), 0.05, (0, 0)), ValueError, "2-D"),
        (lambda: OccupancyGrid(np.zeros((0, 4), bool), 0.05, (0, 0)), ValueError, "at least one row"),
        (lambda: OccupancyGrid(np.zeros((4, 4), bool), -0.05, (0, 0)), ValueError, "resolution"),
        (lambda: OccupancyGrid(np.zeros((4, 4), bool), 0.0, (0, 0)), ValueError, "resolution"),
        (lambda: OccupancyGrid(np.zeros((4, 4), bool), math.nan, (0, 0)), ValueError, "resolution"),
        (lambda: OccupancyGrid(np.zeros((4, 4), bool), 0.05, (math.inf, 0)), ValueError, "origin"),
        (
            lambda: OccupancyGrid(np.zeros((4, 4), bool), 0.05, (0,)),  # type: ignore[arg-type]
            ValueError,
            "tuple of length 2",
        ),
        (_cast(*_CAST[:3], 0, *_CAST[4:]), ValueError, "beams"),
        (_cast(*_CAST[:3], -3, *_CAST[4:]), ValueError, "beams must be a non-negative integer"),
        (_cast(*_CAST[:3], 2.0, *_CAST[4:]), TypeError, "beams must be an int"),
        (_cast(*_CAST[:4], 1.0, 1.0), ValueError, "range_max"),
        (_cast(*_CAST[:4], 2.0, 1.0), ValueError, "range_max"),
        (_cast(*_CAST[:4], -0.1, 1.0), ValueError, "range_min"),
        (_cast(*_CAST[:4], 0.1, math.inf), ValueError, "range_max"),
        (_cast(*_CAST, dropout=1.5), ValueError, "dropout"),
        (_cast(*_CAST, dropout=-0.1), ValueError, "dropout"),
        (_cast(*_CAST, range_sigma=-0.01), ValueError, "range_sigma"),
        (_cast(*_CAST, range_sigma=math.nan), ValueError, "range_sigma"),
        (_cast(*_CAST, seed=-1), ValueError, "seed"),
        (_cast(*_CAST, seed="7"), TypeError, "seed must be an int"),
        (_cast(*_CAST, discs=np.zeros((2, 2))), ValueError, r"\(K, 3\).*\(2, 2\)"),
        (_cast(*_CAST, discs=np.zeros(3)), ValueError, r"\(K, 3\)"),
        (_cast(*_CAST, discs=np.array([[1.0, 1.0, 0.0]])), ValueError, "radius > 0"),
        (_cast(*_CAST, discs=np.array([[math.nan, 1.0, 0.5]])), ValueError, "disc"),
        (_cast((0.5, math.nan, 0.0), *_CAST[1:]), ValueError, "sensor pose"),
        (_cast((0.5, 0.2), *_CAST[1:]), ValueError, "tuple of length 3"),
        (_cast(*_CAST[:1], math.inf, *_CAST[2:]), ValueError, "angle_min"),
    ],
)
def test_bad_input_errors(call: Callable[[], object], error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        call()


def test_errors_are_planicp_errors_and_inputs_convert() -> None:
    with pytest.raises(PlanicpError):
        _GRID.cast(*_CAST, dropout=2.0)
    # Discs as nested lists or integers, numpy integer beams, a non-contiguous grid.
    r = _GRID.cast(*_CAST[:3], np.int64(10), *_CAST[4:], discs=[[1, 0, 1]])  # type: ignore[arg-type]
    assert r.shape == (10,)
    cells = np.zeros((10, 40), dtype=bool)
    cells[:, 30] = True
    strided = OccupancyGrid(cells[:, ::2], 0.05, (0.0, 0.0))
    assert strided.shape == (10, 20)
    assert abs(strided.cast((0.1, 0.2, 0.0), 0.0, 0.0, 1, 0.0, 5.0)[0] - 0.65) < EXACT
