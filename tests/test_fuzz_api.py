"""Fuzzing the whole public Python API with hypothesis (issue 7).

Every call gets hostile input: arrays of random dtypes (float, int, bool, complex, object, str) and
shapes (scalars, empty, 1-D, (N, 3), 3-D), values that are NaN, inf, huge (1e300), tiny (1e-300,
subnormal), negative zero; garbled text for the log and trajectory readers. Each call must either
succeed with finite, well-formed output or raise TypeError / ValueError (PlanicpError is one) /
FileNotFoundError with a message. PlanicpInternalError (a Rust panic), SystemError, any other
exception, a crash or a hang fails.

`test_properties.py` checks accuracy on random rooms and `test_errors.py` the documented messages of
chosen bad inputs; this file throws random input at every entry point instead.

Profiles: `HYPOTHESIS_PROFILE=long` runs 1000 examples per test (the fuzzing run of issue 7), the
default `ci` profile a few dozen (seconds in all). A process-wide watchdog (faulthandler) turns a hang
into a traceback and a failed run.
"""

from __future__ import annotations

import faulthandler
import math
import os
import tempfile
import warnings
from collections.abc import Callable, Iterator
from datetime import timedelta
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import planicp
import planicp.io
from planicp import (
    AcceptanceGate,
    EnhancedOccupancyGrid,
    IcpConfig,
    IcpResult,
    Localizer,
    PlanicpInternalError,
    PlanMap,
    PlanRaster,
    _core,
    localize,
    scan_to_points,
    se2,
)

settings.register_profile(
    "planicp-fuzz-ci",
    max_examples=25,
    deadline=timedelta(seconds=20),
    derandomize=True,
    database=None,
    suppress_health_check=list(HealthCheck),
)
settings.register_profile(
    "planicp-fuzz-long",
    max_examples=1000,
    deadline=timedelta(seconds=20),
    database=None,
    suppress_health_check=list(HealthCheck),
)
FUZZ = settings.get_profile(
    "planicp-fuzz-long" if os.environ.get("HYPOTHESIS_PROFILE") == "long" else "planicp-fuzz-ci"
)

#: Seconds one test may run before the watchdog dumps every thread's stack and ends the process.
HANG_SECONDS = 1800 if os.environ.get("HYPOTHESIS_PROFILE") == "long" else 300

ALLOWED = (TypeError, ValueError, FileNotFoundError)


@pytest.fixture(autouse=True)
def _hang_watchdog() -> Iterator[None]:
    faulthandler.dump_traceback_later(HANG_SECONDS, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


def call(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> tuple[bool, Any]:
    """(True, result) or (False, exception) for an allowed exception with a message; anything else
    (PlanicpInternalError, SystemError, KeyError, ...) propagates and fails the test."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return True, fn(*args, **kwargs)
    except PlanicpInternalError:
        raise
    except ALLOWED as exc:
        assert str(exc).strip(), f"{type(exc).__name__} without a message from {fn}"
        return False, exc


# --------------------------------------------------------------------------------------------------
# strategies
# --------------------------------------------------------------------------------------------------

SPECIALS = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    math.nan,
    math.inf,
    -math.inf,
    1e9,
    -1e9,
    1.0000000001e9,
    1e18,
    1e300,
    -1e300,
    1e-300,
    5e-324,
    1.7976931348623157e308,
    2.2250738585072014e-308,
    2.0**53,
]

values = st.one_of(
    st.floats(-50.0, 50.0),
    st.sampled_from(SPECIALS),
    st.floats(allow_nan=True, allow_infinity=True),
)

DTYPES = ["float64", "float64", "float32", "int64", "int8", "uint8", "bool", "complex128", "object", "<U4"]


@st.composite
def arrays(draw: Any, n_max: int = 40) -> Any:
    """A random array (or sometimes a list) of a random dtype and shape, filled with hostile values."""
    n = draw(st.integers(0, n_max))
    shape = draw(st.sampled_from([(), (0,), (n,), (n, 2), (n, 2), (n, 2), (n, 3), (0, 2), (2, n, 2), (n, 1)]))
    size = int(np.prod(shape)) if shape else 1
    data = np.array(draw(st.lists(values, min_size=size, max_size=size)), dtype=np.float64).reshape(shape)
    dtype = draw(st.sampled_from(DTYPES))
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if dtype == "object":
            flat = [draw(st.one_of(values, st.none(), st.text(max_size=3))) for _ in range(size)]
            arr = np.empty(size, dtype=object)
            arr[:] = flat
            arr = arr.reshape(shape)
        elif dtype == "<U4":
            arr = data.astype(str).astype("<U4")
        else:
            arr = data.astype(dtype)
    if draw(st.integers(0, 9)) == 0:
        return arr.tolist()
    return arr


def wall_points(draw: Any) -> Any:
    """Mostly a plausible plan (a box room, maybe scaled or shifted), sometimes garbage."""
    if draw(st.integers(0, 3)) == 0:
        return draw(arrays(200))
    w, h = draw(st.floats(0.5, 20.0)), draw(st.floats(0.5, 20.0))
    s = draw(st.sampled_from([0.02, 0.05, 0.2]))
    xs, ys = np.arange(0.0, w, s), np.arange(0.0, h, s)
    pts = np.vstack([np.c_[xs, 0 * xs], np.c_[xs, 0 * xs + h], np.c_[0 * ys, ys], np.c_[0 * ys + w, ys]])
    scale = draw(st.sampled_from([1.0, 1.0, 1.0, 1e-300, 1e-6, 1e6, 1e300]))
    offset = draw(st.sampled_from([0.0, 0.0, 1e9, -1e9 + 1.0, 1e12, 5e-324]))
    with np.errstate(all="ignore"):
        return pts * scale + offset


anything = st.one_of(
    arrays(),
    values,
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.text(max_size=6),
    st.tuples(values, values, values),
    st.lists(values, max_size=4),
    st.dictionaries(st.text(max_size=4), values, max_size=2),
)

poses = st.one_of(
    st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-4, 4)), st.tuples(values, values, values), anything
)

_BOX = None


def box_plan() -> PlanMap:
    global _BOX
    if _BOX is None:
        xs = np.arange(0.0, 6.0, 0.05)
        ys = np.arange(0.0, 4.0, 0.05)
        pts = np.vstack([np.c_[xs, 0 * xs], np.c_[xs, 0 * xs + 4.0], np.c_[0 * ys, ys], np.c_[0 * ys + 6.0, ys]])
        _BOX = PlanMap.from_points(pts)
    return _BOX


def box_scan(pose: tuple[float, float, float] = (3.0, 2.0, 0.3)) -> Any:
    return se2.transform_points(se2.inverse(pose), box_plan().points)


@st.composite
def scans(draw: Any) -> Any:
    """A real scan of the box room from near the truth, maybe corrupted, or garbage."""
    k = draw(st.integers(0, 4))
    if k == 0:
        return draw(arrays(300))
    scan = np.array(box_scan()[:: draw(st.sampled_from([1, 3, 50, 400]))])
    if k == 1 and len(scan):
        i = draw(st.integers(0, len(scan) - 1))
        scan[i, draw(st.integers(0, 1))] = draw(values)
    if k == 2:
        with np.errstate(all="ignore"):
            scan = scan * draw(st.sampled_from([1e-300, 1e6, 1e300, -1.0]))
    return scan


@st.composite
def configs(draw: Any) -> Any:
    """IcpConfig keyword arguments: mostly sensible values, sometimes anything."""
    fields: dict[str, Any] = {
        "max_correspondence_distance": st.one_of(st.sampled_from([0.05, 0.25, 1.0]), values, anything),
        "max_iterations": st.one_of(st.integers(0, 60), st.integers(-5, 2**70), anything),
        "trim_ratio": st.one_of(st.floats(0.0, 1.0), values, anything),
        "translation_tolerance": st.one_of(st.sampled_from([0.0, 1e-4]), values),
        "rotation_tolerance": st.one_of(st.sampled_from([0.0, 1e-4]), values),
        "subsample": st.one_of(st.integers(0, 10), st.integers(-3, 2**66), anything),
        "correspondence_schedule": st.one_of(st.lists(st.floats(0.05, 4.0), max_size=4).map(tuple), anything),
        "use_visibility": st.one_of(st.booleans(), anything),
        "accelerate": st.one_of(st.booleans(), anything),
        "visibility_range": st.one_of(st.none(), st.sampled_from([1.0, 30.0]), values),
    }
    chosen = draw(st.lists(st.sampled_from(sorted(fields)), max_size=3, unique=True))
    return {name: draw(fields[name]) for name in chosen}


# --------------------------------------------------------------------------------------------------
# output checks
# --------------------------------------------------------------------------------------------------


def check_pose(p: Any) -> None:
    assert isinstance(p, tuple) and len(p) == 3, p
    assert all(isinstance(v, float) and math.isfinite(v) for v in p), p
    assert -math.pi <= p[2] <= math.pi, p


def check_result(res: Any, n: int) -> None:
    assert isinstance(res, IcpResult)
    check_pose(res.pose)
    assert res.inlier_mask.shape == (n,) and res.inlier_mask.dtype == np.bool_
    assert res.num_inliers == int(res.inlier_mask.sum())
    assert 0.0 <= res.inlier_ratio <= 1.0
    assert (res.num_inliers == 0 and math.isnan(res.rmse)) or (math.isfinite(res.rmse) and res.rmse >= 0.0)
    cov = res.covariance
    assert cov.shape == (3, 3) and not np.isnan(cov).any(), cov
    if np.isfinite(cov).all():
        np.testing.assert_allclose(cov, cov.T, rtol=1e-9, atol=0)
        assert (np.diag(cov) >= 0).all()
    else:
        assert np.isinf(np.diag(cov)).all(), cov


# --------------------------------------------------------------------------------------------------
# the plan
# --------------------------------------------------------------------------------------------------


@FUZZ
@given(st.data())
def test_plan_from_points(data: Any) -> None:
    xy = wall_points(data.draw)
    resolution = data.draw(st.one_of(st.none(), st.sampled_from([0.05, 0.5, 1e-300, 1e300]), values, anything))
    ok, plan = call(PlanMap.from_points, xy, resolution=resolution)
    if ok:
        pts = plan.points
        assert pts.ndim == 2 and pts.shape[1] == 2 and len(pts) > 0 and np.isfinite(pts).all()
        assert plan.normals.shape == pts.shape and np.isfinite(plan.normals).all()
        x0, y0, x1, y1 = plan.extent
        assert x0 <= x1 and y0 <= y1
        pose = data.draw(poses)
        ok, idx = call(plan.visible_indices, pose, data.draw(st.one_of(st.sampled_from([1.0, 30.0]), values)))
        if ok:
            assert idx.ndim == 1 and (np.diff(idx.astype(np.int64)) > 0).all() and (idx < len(pts)).all()
        directions = data.draw(st.one_of(st.sampled_from([8, 720]), st.integers(-1, 2**70), values, anything))
        ok, view = call(
            plan.view_from,
            pose,
            data.draw(st.one_of(st.sampled_from([1.0, 30.0]), values)),
            directions,
            data.draw(st.one_of(st.none(), scans(), arrays(20))),
        )
        if ok:
            # NaN: a direction outside the scan's arc, not cast.
            assert view.ranges.shape == (directions,) and (np.isnan(view.ranges) | (view.ranges >= 0)).all()
            assert (view.visible_indices < len(pts)).all()
            ok, classes = call(view.classify, data.draw(arrays(50)), data.draw(st.one_of(st.just(0.2), values)))
            if ok:
                assert classes[0].dtype == np.bool_ and classes[0].shape == classes[1].shape
            ok, res = call(localize, data.draw(scans()), plan, pose, view=view)
            if ok:
                assert all(math.isfinite(v) for v in res.pose)


@FUZZ
@given(st.data())
def test_plan_from_segments_and_raster(data: Any) -> None:
    segments = data.draw(st.one_of(arrays(12), st.just([[(0.0, 0.0), (4.0, 0.0)], [(4.0, 0.0), (4.0, 3.0)]])))
    spacing = data.draw(st.one_of(st.sampled_from([0.02, 0.1]), values, anything))
    ok, plan = call(PlanMap.from_segments, segments, spacing)
    if ok:
        assert np.isfinite(plan.points).all() and len(plan.points) > 0
    walls = data.draw(arrays(12))
    if data.draw(st.booleans()):
        walls = np.zeros((data.draw(st.integers(0, 30)), data.draw(st.integers(0, 30))), dtype=bool)
        if walls.size:
            walls[data.draw(st.integers(0, walls.shape[0] - 1)), :] = True
    resolution = data.draw(st.one_of(st.sampled_from([0.05, 1.0]), values, anything))
    origin = data.draw(poses)
    ok, raster = call(PlanRaster, walls, resolution, origin)
    if ok:
        ok, plan = call(PlanMap.from_raster, raster)
        if ok:
            assert np.isfinite(plan.points).all() and len(plan.points) > 0


@FUZZ
@given(st.data())
def test_raster_from_free_polygon(data: Any) -> None:
    vertices = data.draw(st.one_of(arrays(12), st.just([(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (0.0, 3.0)])))
    resolution = data.draw(st.one_of(st.sampled_from([0.05, 0.5]), values, anything))
    thickness = data.draw(st.one_of(st.sampled_from([0.15, 0.01]), values, anything))
    margin = data.draw(st.one_of(st.integers(0, 4), values, anything))
    ok, raster = call(PlanRaster.from_free_polygon, vertices, resolution, thickness, margin)
    if ok:
        assert raster.walls.dtype == np.bool_ and raster.walls.any() and not raster.walls.all()
        ok, plan = call(PlanMap.from_raster, raster)
        if ok:
            assert np.isfinite(plan.points).all() and len(plan.points) > 0


# --------------------------------------------------------------------------------------------------
# alignment
# --------------------------------------------------------------------------------------------------


@FUZZ
@given(scans(), poses, configs())
def test_localize(scan: Any, pose: Any, cfg: dict[str, Any]) -> None:
    ok, config = call(IcpConfig, **cfg)
    if not ok:
        return
    assert IcpConfig.from_dict(config.to_dict()) == config if hasattr(config, "to_dict") else True
    ok, res = call(localize, scan, box_plan(), pose, config)
    if ok:
        check_result(res, len(np.asarray(scan).reshape(-1, 2)))


@FUZZ
@given(st.dictionaries(st.text(max_size=30), anything, max_size=3), configs())
def test_icp_config_from_dict(junk: dict[str, Any], cfg: dict[str, Any]) -> None:
    call(IcpConfig.from_dict, junk)
    ok, config = call(IcpConfig.from_dict, cfg)
    if ok:
        ok2, again = call(config.replace, **cfg)
        assert ok2 and again == config


@FUZZ
@given(st.data())
def test_native_core(data: Any) -> None:
    """The native module directly: the Python layer's checks are not there to help."""
    pts = data.draw(st.one_of(st.just(box_plan().points), arrays(200)))
    res = data.draw(st.one_of(st.none(), values, anything))
    normals = data.draw(st.one_of(st.none(), st.just(box_plan().normals), arrays(20)))
    ok, pm = call(_core.PointMap, pts, res, normals)
    if not ok:
        pm = _core.PointMap(box_plan().points, None, None)
    ok, idx = call(pm.visible_indices, data.draw(values), data.draw(values), data.draw(values))
    if ok:
        assert (idx < len(pm)).all()
    view_pose = data.draw(st.one_of(poses, st.tuples(values, values, values)))
    ok, view = call(pm.view_from, view_pose, data.draw(values), data.draw(st.one_of(st.integers(-1, 2**70), anything)))
    if ok:
        assert (view.visible_indices < len(pm)).all() and len(view.ranges) >= 8
        call(view.classify, data.draw(arrays(50)), data.draw(values))
    else:
        view = None
    # The native settings read these off a planicp.IcpConfig by name; here, off any object.
    kw = [
        data.draw(st.one_of(st.sampled_from([0.25]), values, anything)),
        data.draw(st.one_of(st.sampled_from([30]), st.integers(-1, 2**70), anything)),
        data.draw(st.one_of(st.sampled_from([1.0]), values)),
        data.draw(st.one_of(st.sampled_from([1e-4]), values)),
        data.draw(st.one_of(st.sampled_from([1e-4]), values)),
        data.draw(st.one_of(st.sampled_from([1]), st.integers(-1, 2**70), anything)),  # negative: was OverflowError
        data.draw(st.one_of(st.just([1.0, 0.5]), st.lists(values, max_size=3), anything)),
        data.draw(st.one_of(st.booleans(), anything)),
        data.draw(st.one_of(st.booleans(), anything)),
        data.draw(st.one_of(st.none(), values, anything)),
    ]
    ok, s = call(_core.IcpSettings, icp_fields(*kw))
    if not ok:
        s = _core.IcpSettings(icp_fields(0.25, 30, 1.0, 1e-4, 1e-4, 1, [1.0], True, True, None))
    scan = data.draw(st.one_of(st.just(np.ascontiguousarray(box_scan()[::7])), arrays(100)))
    ok, al = call(_core.align, pm, scan, data.draw(poses), s, view if data.draw(st.booleans()) else None)
    if ok:
        assert all(math.isfinite(v) for v in al.pose)
        assert al.inlier_mask.sum() == al.num_inliers and not np.isnan(al.covariance).any()


@FUZZ
@given(st.data())
def test_native_grids(data: Any) -> None:
    cells = data.draw(st.one_of(arrays(30), st.just(np.eye(40, dtype=bool))))
    ok, grid = call(_core.OccupancyGrid, cells, data.draw(st.one_of(st.just(0.1), values)), data.draw(poses))
    if ok:
        beams = data.draw(st.one_of(st.integers(0, 800), st.integers(-1, 2**70), anything))
        ok, r = call(
            grid.cast,
            data.draw(poses),
            data.draw(values),
            data.draw(st.one_of(st.just(0.01), values)),
            beams,
            data.draw(st.one_of(st.just(0.0), values)),
            data.draw(st.one_of(st.just(30.0), values)),
            data.draw(st.one_of(st.just(0.0), values)),
            data.draw(st.one_of(st.just(0.0), values)),
            data.draw(st.one_of(st.none(), st.integers(-1, 2**70))),
            data.draw(st.one_of(st.none(), arrays(6))),
        )
        if ok:
            assert r.dtype == np.float64 and r.shape == (beams,) and not np.isnan(r).any()
    args = [data.draw(st.one_of(st.integers(0, 50), st.integers(-1, 2**70), anything)) for _ in range(2)]
    args += [data.draw(st.one_of(st.just(0.1), values)), data.draw(st.one_of(st.just((0.0, 0.0)), anything))]
    args += [data.draw(st.one_of(st.just(v), values)) for v in (0.85, -0.4, -2.0, 3.5)]
    args += [data.draw(st.one_of(st.just(1 << 16), st.integers(-1, 2**70), anything))]
    ok, lg = call(_core.LogOddsGrid, *args)
    if ok:
        ok, _ = call(lg.integrate, data.draw(anything), data.draw(arrays(50)), data.draw(arrays(5)), data.draw(values))
        lo = lg.log_odds()
        assert lo.size == lg.shape[0] * lg.shape[1] and np.isfinite(lo).all()


# --------------------------------------------------------------------------------------------------
# tracking
# --------------------------------------------------------------------------------------------------


@FUZZ
@given(st.data())
def test_localizer(data: Any) -> None:
    gate_kw = data.draw(
        st.dictionaries(
            st.sampled_from(
                ["require_convergence", "min_inliers", "min_inlier_ratio", "max_translation_jump", "max_rotation_jump"]
            ),
            st.one_of(values, anything, st.integers(-3, 100)),
            max_size=2,
        )
    )
    ok, gate = call(AcceptanceGate, **gate_kw)
    gate = gate if ok else None
    ok, loc = call(Localizer, box_plan(), data.draw(st.one_of(st.just((3.0, 2.0, 0.3)), poses)), None, gate=gate)
    if not ok:
        return
    for _ in range(data.draw(st.integers(1, 4))):
        if data.draw(st.integers(0, 5)) == 0:
            call(loc.reset, data.draw(poses))
        before = loc.pose
        ok, est = call(loc.update, data.draw(scans()), data.draw(st.one_of(st.just((0.0, 0.0, 0.0)), poses)))
        if ok:
            check_pose(est.pose)
            assert est.pose == loc.pose and isinstance(est.reason, str)
            assert est.accepted == (est.reason == "")
            if est.result is not None:
                check_pose(est.result.pose)
        else:
            assert loc.pose == before, "a refused update must change nothing"


@FUZZ
@given(st.data())
def test_scan_to_points(data: Any) -> None:
    ranges = data.draw(st.one_of(arrays(400), st.just(np.full(360, 2.0))))
    args = [data.draw(st.one_of(st.just(v), values, anything)) for v in (-math.pi, 2 * math.pi / 360, 0.1, 30.0)]
    ok, pts = call(scan_to_points, ranges, *args, sensor_pose=data.draw(st.one_of(st.just((0.0, 0.0, 0.0)), poses)))
    if ok:
        assert pts.ndim == 2 and pts.shape[1] == 2 and pts.dtype == np.float64 and np.isfinite(pts).all()


@FUZZ
@given(poses, poses, values)
def test_se2(a: Any, b: Any, angle: Any) -> None:
    for fn, args in ((se2.compose, (a, b)), (se2.inverse, (a,)), (se2.between, (a, b)), (se2.wrap_angle, (angle,))):
        ok, out = call(fn, *args)
        if ok and fn is not se2.wrap_angle:
            assert len(out) == 3
    ok, out = call(se2.transform_points, a, data_points := np.asarray([[1.0, 2.0], [3.0, 4.0]]))
    if ok:
        assert np.asarray(out).shape == data_points.shape


@FUZZ
@given(st.data())
def test_enhanced_occupancy_grid(data: Any) -> None:
    kw = {
        "resolution": data.draw(st.one_of(st.sampled_from([0.05, 0.2]), values, anything)),
        "margin": data.draw(st.one_of(st.just(1.0), values)),
        "max_range": data.draw(st.one_of(st.just(30.0), values)),
        "max_cells": data.draw(st.one_of(st.just(1 << 20), st.integers(-1, 2**70), anything)),
    }
    chosen = data.draw(st.lists(st.sampled_from(sorted(kw)), max_size=2, unique=True))
    ok, eog = call(EnhancedOccupancyGrid, box_plan(), **{k: kw[k] for k in chosen})
    if not ok:
        return
    for _ in range(data.draw(st.integers(1, 3))):
        before = (eog.shape, eog.scans)
        ok, _ = call(
            eog.integrate,
            data.draw(scans()),
            data.draw(st.one_of(st.just((3.0, 2.0, 0.3)), poses)),
            data.draw(st.one_of(st.just((0.0, 0.0)), anything)),
        )
        if not ok:
            assert (eog.shape, eog.scans) == before
    p = eog.probabilities()  # NaN where never observed (documented)
    seen = p[~np.isnan(p)]
    assert p.shape == eog.shape and ((seen >= 0) & (seen <= 1)).all()
    assert eog.states().shape == eog.shape


# --------------------------------------------------------------------------------------------------
# readers: random and garbled text
# --------------------------------------------------------------------------------------------------

CARMEN_LINES = [
    "FLASER 3 1.0 2.0 3.0 0.0 0.0 0.0 0.0 0.0 0.0 1.0 host 1.0",
    "ODOM 0.0 0.0 0.0 0 0 0 1.0 host 1.0",
    "ROBOTLASER1 0 -1.57 3.14 0.0175 81.9 0.01 0 3 1.0 2.0 3.0 0 0 0 0 0 0 0 0 0 0 0 0 0 1.0 host 1.0",
    "# comment",
    "PARAM robot_front_laser_max 30",
]
G2O_LINES = [
    "VERTEX_SE2 0 0 0 0",
    "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1",
    "ROBOTLASER1 0 -1.57 3.14 0.0175 81.9 0.01 0 2 1 2 0",
]
TRAJ_LINES = ["0 0 0 0 0 0 0 1", "1.0 1 2 0 0 0 0.7071 0.7071", "1 0 0 0 0 1 0 0 0 0 1 0"]


@st.composite
def garbled(draw: Any, lines: list[str]) -> str:
    out = []
    for _ in range(draw(st.integers(0, 8))):
        line = draw(st.sampled_from(lines))
        tokens = line.split()
        for _ in range(draw(st.integers(0, 3))):
            if not tokens:
                break
            i = draw(st.integers(0, len(tokens) - 1))
            tokens[i] = draw(
                st.one_of(
                    st.sampled_from(
                        ["nan", "inf", "-inf", "1e400", "1e-400", "", "x", "-0", "99999999999999999999", "0x10"]
                    ),
                    st.text(max_size=4),
                )
            )
        if draw(st.integers(0, 4)) == 0 and tokens:
            tokens = tokens[: draw(st.integers(0, len(tokens)))]
        out.append(" ".join(tokens))
    if draw(st.integers(0, 5)) == 0:
        out.append(draw(st.text(max_size=40)))
    return "\n".join(out)


READERS: dict[str, tuple[Callable[..., Any], list[str], str]] = {
    "carmen": (planicp.io.read_carmen, CARMEN_LINES, ".log"),
    "g2o": (planicp.io.read_g2o, G2O_LINES, ".g2o"),
    "tum": (planicp.io.read_tum, TRAJ_LINES, ".txt"),
    "kitti": (planicp.io.read_kitti, TRAJ_LINES, ".txt"),
    "open_log": (planicp.io.open_log, CARMEN_LINES + G2O_LINES, ".dat"),
}


@pytest.mark.parametrize("reader", sorted(READERS))
def test_readers_on_garbled_text(reader: str) -> None:
    fn, lines, suffix = READERS[reader]

    @FUZZ
    @given(st.data())
    def run(data: Any) -> None:
        text = data.draw(garbled(lines))
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / f"log{suffix}"
            if data.draw(st.integers(0, 9)) == 0:
                path.write_bytes(data.draw(st.binary(max_size=64)))
            else:
                path.write_text(text, encoding="utf-8")
            kwargs = {"errors": data.draw(st.sampled_from(["skip", "raise"]))} if reader in ("carmen", "g2o") else {}
            call(fn, path, **kwargs)
            call(fn, Path(d) / "missing.log")

    run()


@FUZZ
@given(st.data())
def test_robustness_api(data: Any) -> None:
    """DegeneracyRule, LostRule, FusionRule, PosteriorRefinement, MotionNoise, RecoveryConfig, SearchRegion, relocalize,
    SearchInSteps and Localizer.relocalize/covariance with random settings, scans and poses."""
    number = st.one_of(values, anything, st.integers(-3, 100))
    call(planicp.DegeneracyRule, data.draw(number))
    call(planicp.ContinuityRule, data.draw(number), data.draw(number), data.draw(number))
    call(planicp.OcclusionRule, data.draw(number), data.draw(number), data.draw(number))
    call(planicp.LostRule, data.draw(number), data.draw(number), data.draw(number))
    fusion_ok, fusion = call(planicp.FusionRule, data.draw(number))
    refinement_ok, refinement = call(
        planicp.PosteriorRefinement, data.draw(st.one_of(st.booleans(), anything)), data.draw(number), data.draw(number)
    )
    ok, noise = call(planicp.MotionNoise, *[data.draw(number) for _ in range(5)])
    if ok:
        ok, cov = call(noise.propagate, np.diag([0.01, 0.01, 0.001]), data.draw(poses), data.draw(poses))
        if ok:
            assert cov.shape == (3, 3) and not np.isnan(cov).any()
    call(
        planicp.RecoveryConfig,
        min_inlier_ratio=data.draw(number),
        confirmations=data.draw(number),
        margin=data.draw(number),
        local_radius=data.draw(number),
        max_beyond=data.draw(number),
    )
    ok, region = call(planicp.SearchRegion, data.draw(poses), data.draw(number), data.draw(number))
    plan = box_plan()
    ok_found, found = call(
        planicp.relocalize,
        data.draw(scans()),
        plan,
        region=region if ok else None,
        max_candidates=data.draw(st.one_of(st.integers(-1, 6), anything)),
    )
    if ok_found:
        for c in found.candidates:
            check_pose(c.pose)
            assert 0.0 <= c.inlier_ratio <= 1.0
    ok_steps, steps = call(planicp.SearchInSteps, data.draw(scans()), plan, region=region if ok else None)
    if ok_steps:
        for _ in range(3):
            ok_step, stepped = call(steps.advance, data.draw(st.one_of(st.integers(-1, 50_000), anything)))
            if ok_step and stepped is not None:
                for c in stepped.candidates:
                    check_pose(c.pose)
                break
    call(planicp.RecoveryConfig, search_nodes=data.draw(st.one_of(st.none(), number)))
    ok, loc = call(
        Localizer,
        plan,
        data.draw(st.one_of(st.just((3.0, 2.0, 0.3)), poses)),
        None,
        initial_covariance=data.draw(st.one_of(st.none(), st.just(np.eye(3) * 0.01), anything)),
        fusion=fusion if fusion_ok else data.draw(st.one_of(st.none(), anything)),
        refinement=refinement if refinement_ok else data.draw(st.one_of(st.none(), anything)),
    )
    if ok:
        ok, estimate = call(loc.update, data.draw(scans()), data.draw(poses))
        if ok:
            check_pose(estimate.pose)
            assert np.isfinite(estimate.covariance).all()
        before = loc.pose
        ok, _ = call(loc.relocalize, data.draw(scans()))
        if not ok:
            assert loc.pose == before, "a refused relocalize must change nothing"
        check_pose(loc.pose)
        assert np.isfinite(loc.covariance).all()


@FUZZ
@given(st.data())
def test_scale_api(data: Any) -> None:
    """ScaleRule with random settings; estimate_scale with random scans, odometry, start pose and
    ratios: a result with a finite positive factor, or TypeError/ValueError with a message."""
    number = st.one_of(values, anything, st.integers(-3, 100))
    call(planicp.ScaleRule, every=data.draw(number), tolerance=data.draw(number), agreement=data.draw(number))
    plan = box_plan()
    n = data.draw(st.integers(0, 4))
    odometry = data.draw(st.one_of(st.just(np.zeros((n, 3))), anything))
    ratios = data.draw(st.one_of(st.just((1.0,)), st.lists(values, max_size=2), anything))
    ok, found = call(
        planicp.estimate_scale, plan, [data.draw(scans()) for _ in range(n)], odometry, data.draw(poses), ratios=ratios
    )
    if ok:
        assert math.isfinite(found.factor) and found.factor > 0


def test_every_public_name_is_fuzzed() -> None:
    """A new public name must be added to this file (or here, with a reason)."""
    covered = {
        "AcceptanceGate",
        "EnhancedOccupancyGrid",
        "IcpConfig",
        "IcpResult",
        "Localizer",
        "PlanMap",
        "PlanRaster",
        "PlanicpError",
        "PlanicpInternalError",
        "localize",
        "scan_to_points",
        "se2",
        "__version__",
        "Estimate",
        "OccupancyModel",
        "RosMap",
        "compare_grids",
        "read_ros_map",
        "resolution_from_pixels",
        "DegeneracyRule",
        "LostRule",
        "MotionNoise",
        "RecoveryConfig",
        "SearchRegion",
        "SearchInSteps",
        "relocalize",
        "ContinuityRule",
        "OcclusionRule",
        "FusionRule",
        "PosteriorRefinement",
        "WallView",
        "ScaleRule",
        "estimate_scale",
    }
    # Outputs and containers (EogState, GridAgreement, OccupancyGridMessage), and the modules with tests
    # of their own (synthetic: test_synthetic.py, vector_plan: test_vector_plan.py, WallExtraction:
    # test_drawing_walls.py).
    elsewhere = {
        "WallExtraction",
        "EogState",
        "GridAgreement",
        "OccupancyGridMessage",
        "synthetic",
        "vector_plan",
        "Degeneracy",
        "Candidate",
        "Relocalization",
        "RelocalizationConfig",
        # The scale check's records and warning: tests/test_plan_scale.py.
        "PlanScaleWarning",
        "ScaleEstimate",
        "ScaleCandidate",
        "ScaleSearch",
    }
    assert set(planicp.__all__) <= covered | elsewhere, set(planicp.__all__) - covered - elsewhere


@FUZZ
@given(st.data())
def test_small_helpers(data: Any) -> None:
    """resolution_from_pixels, OccupancyModel, read_ros_map on garbled YAML, compare_grids."""
    ok, r = call(
        planicp.resolution_from_pixels, data.draw(poses), data.draw(poses), data.draw(st.one_of(values, anything))
    )
    if ok:
        assert isinstance(r, float) and math.isfinite(r) and r > 0
    names = ["p_hit", "p_miss", "p_min", "p_max", "free_threshold", "occupied_threshold"]
    kw = data.draw(st.dictionaries(st.sampled_from(names), st.one_of(st.floats(0, 1), values, anything), max_size=2))
    call(planicp.OccupancyModel, **kw)
    yaml_text = data.draw(
        st.one_of(
            st.text(max_size=60),
            st.builds(
                "image: {}\nresolution: {}\norigin: {}\nnegate: {}\noccupied_thresh: {}\nfree_thresh: {}\n".format,
                st.sampled_from(["map.pgm", "", "missing.png", "/dev/null"]),
                st.one_of(values, st.text(max_size=4)),
                st.sampled_from(["[0, 0, 0]", "[nan, 0, 0]", "[1e400, 0, 0]", "[0, 0]", "x"]),
                st.sampled_from(["0", "1", "2", "x"]),
                values,
                values,
            ),
        )
    )
    with tempfile.TemporaryDirectory() as d:
        pgm = Path(d) / "map.pgm"
        pgm.write_bytes(b"P5\n4 3\n255\n" + bytes(data.draw(st.lists(st.integers(0, 255), min_size=12, max_size=12))))
        path = Path(d) / "map.yaml"
        path.write_text(yaml_text, encoding="utf-8")
        ok, m = call(planicp.read_ros_map, path)
        ok, _ = call(PlanMap.from_ros_map, path, cache=False)
    a = EnhancedOccupancyGrid(box_plan(), resolution=data.draw(st.sampled_from([0.05, 0.1])))
    b = EnhancedOccupancyGrid(box_plan(), resolution=0.05, margin=data.draw(st.sampled_from([1.0, 1.02, 2.0])))
    ok, g = call(planicp.compare_grids, a, b)


# --------------------------------------------------------------------------------------------------
# regressions of what the fuzzing found
# --------------------------------------------------------------------------------------------------


def test_se2_garbage_is_a_type_error_not_an_index_error() -> None:
    for bad in ("", "ab", None, 3.0, (1.0, 2.0), (1.0, 2.0, 3.0, 4.0)):
        for fn, args in (
            (se2.compose, (bad, (0.0, 0.0, 0.0))),
            (se2.inverse, (bad,)),
            (se2.between, ((0.0, 0.0, 0.0), bad)),
            (se2.transform_points, (bad, np.zeros((1, 2)))),
        ):
            with pytest.raises(TypeError, match=r"must be an \(x, y, yaw\) triple"):
                fn(*args)


@pytest.mark.parametrize("position", [1, 5])
def test_native_negative_counts_are_planicp_errors_not_overflow_errors(position: int) -> None:
    args: list[Any] = [0.25, 30, 1.0, 1e-4, 1e-4, 1, [1.0], True, True, None]
    args[position] = -1
    with pytest.raises(planicp.PlanicpError, match="must be a non-negative integer"):
        _core.IcpSettings(icp_fields(*args))


def icp_fields(*values: Any) -> SimpleNamespace:
    """An object with the fields the native `IcpSettings` reads off a planicp.IcpConfig: `values` in
    the order of the ten given, and the tracking's search with automatic trimming off."""
    names = [
        "max_correspondence_distance",
        "max_iterations",
        "trim_ratio",
        "translation_tolerance",
        "rotation_tolerance",
        "subsample",
        "correspondence_schedule",
        "use_visibility",
        "accelerate",
        "visibility_range",
    ]
    return SimpleNamespace(**dict(zip(names, values)), auto_trim=False, correspondence_search="wall_index")


@pytest.mark.parametrize("position", [0, 1, 8])
def test_native_grid_negative_counts_are_planicp_errors(position: int) -> None:
    args: list[Any] = [10, 10, 0.1, (0.0, 0.0), 0.85, -0.4, -2.0, 3.5, 1 << 16]
    args[position] = -1
    with pytest.raises(planicp.PlanicpError, match="must be a non-negative integer"):
        _core.LogOddsGrid(*args)


@pytest.mark.parametrize("reader", ["carmen", "g2o"])
def test_a_broken_zip_log_is_a_value_error(reader: str, tmp_path: Path) -> None:
    # Found by test_readers_on_garbled_text[g2o]: the zip signature alone escaped as zipfile.BadZipFile.
    fn, _, suffix = READERS[reader]
    path = tmp_path / f"log{suffix}"
    path.write_bytes(b"PK\x03\x04")
    with pytest.raises(ValueError, match="not one"):
        fn(path)
