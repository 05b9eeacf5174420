"""Every bad input is rejected with the right exception and a message naming the problem; a Rust
panic or an extreme input never surfaces as anything but a documented error."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap
from typing import Any

import numpy as np
import pytest

import planicp
from planicp import (
    AcceptanceGate,
    IcpConfig,
    Localizer,
    PlanicpError,
    PlanicpInternalError,
    PlanMap,
    localize,
    scan_to_points,
    se2,
)


def box_points(w: float = 4.0, h: float = 3.0, spacing: float = 0.05) -> np.ndarray:
    """Points every `spacing` m around the rectangle [0, w] x [0, h]."""
    xs = np.arange(0.0, w, spacing)
    ys = np.arange(0.0, h, spacing)
    return np.vstack(
        [
            np.column_stack([xs, np.zeros_like(xs)]),
            np.column_stack([xs + spacing, np.full_like(xs, h)]),
            np.column_stack([np.zeros_like(ys), ys + spacing]),
            np.column_stack([np.full_like(ys, w), ys]),
        ]
    )


TRUTH = (1.7, 1.2, 0.3)


@pytest.fixture(scope="module")
def plan() -> PlanMap:
    return PlanMap.from_points(box_points())


@pytest.fixture(scope="module")
def scan() -> np.ndarray:
    """Every other box point seen from TRUTH, in the robot frame."""
    return se2.transform_points(se2.inverse(TRUTH), box_points()[::2] + 0.01)


# --------------------------------------------------------------------------------------------------
# exception hierarchy
# --------------------------------------------------------------------------------------------------


def test_exception_hierarchy() -> None:
    assert issubclass(PlanicpError, ValueError)
    assert issubclass(PlanicpInternalError, RuntimeError)
    assert not issubclass(PlanicpInternalError, ValueError)
    assert planicp.PlanicpError is planicp._core.PlanicpError


def test_rust_panic_becomes_planicp_internal_error() -> None:
    with pytest.raises(PlanicpInternalError, match="deliberate panic") as info:
        planicp._core._panic_for_tests()
    assert isinstance(info.value, RuntimeError)
    assert type(info.value).__name__ == "PlanicpInternalError"
    # pyo3's PanicException derives from BaseException, not Exception: it must not be what we got
    assert isinstance(info.value, Exception)
    assert "PanicException" not in type(info.value).__name__
    # the interpreter is still usable afterwards
    assert planicp._core._panic_for_tests.__name__ == "_panic_for_tests"
    with pytest.raises(PlanicpInternalError):
        planicp._core._panic_for_tests()


# --------------------------------------------------------------------------------------------------
# PlanMap.from_points
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("xy", "match"),
    [
        (np.zeros((5, 3)), r"shape \(N, 2\), got \(5, 3\)"),
        (np.zeros(6), r"shape \(N, 2\), got \(6,\)"),
        (np.zeros((2, 3, 2)), r"shape \(N, 2\), got \(2, 3, 2\)"),
        (np.zeros((0, 2)), "empty"),
        ([], r"shape \(N, 2\)"),
        ([[0.0, 0.0], [1.0, 2.0, 3.0]], r"\(N, 2\) array"),  # ragged
        ([[0.0, 0.0], [1.0]], r"\(N, 2\) array"),
        (5.0, r"shape \(N, 2\), got \(\)"),
    ],
)
def test_plan_bad_shapes(xy: Any, match: str) -> None:
    with pytest.raises(ValueError, match=match) as info:
        PlanMap.from_points(xy)
    assert "plan points" in str(info.value)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("row", [0, 3, 7])
def test_plan_non_finite_names_the_row(bad: float, row: int) -> None:
    pts = box_points()[:8].copy()
    pts[row, row % 2] = bad
    with pytest.raises(ValueError, match=rf"non-finite.*at row {row}\b"):
        PlanMap.from_points(pts)


@pytest.mark.parametrize(
    "xy",
    [
        np.array([["a", "b"], ["c", "d"]]),
        np.array([[1.0, 2.0], [3.0, 4.0]], dtype=object),
        np.array([[1 + 2j, 0j], [1j, 2j]]),
        np.array([[True, False], [False, True]]),
        [["1", "2"], ["3", "4"]],
        [[None, 1.0], [2.0, 3.0]],
    ],
)
def test_plan_non_numeric_dtype_is_type_error(xy: Any) -> None:
    with pytest.raises(TypeError, match="real numbers"):
        PlanMap.from_points(xy)


@pytest.mark.parametrize(
    ("resolution", "exc", "match"),
    [
        (0.0, ValueError, "resolution must be a positive finite number"),
        (-0.05, ValueError, "resolution must be a positive finite number"),
        (math.nan, ValueError, "resolution must be a positive finite number"),
        (math.inf, ValueError, "resolution must be a positive finite number"),
        (True, TypeError, "resolution must be a number"),
        ("0.05", TypeError, "resolution must be a number"),
        (None, None, None),
    ],
)
def test_plan_resolution_validation(resolution: Any, exc: Any, match: Any) -> None:
    if exc is None:
        assert PlanMap.from_points(box_points(), resolution=resolution).raster_resolution > 0
        return
    with pytest.raises(exc, match=match):
        PlanMap.from_points(box_points(), resolution=resolution)


def test_plan_resolution_too_fine_for_the_extent() -> None:
    with pytest.raises(PlanicpError, match="raster"):
        PlanMap.from_points(box_points() * 1000.0, resolution=1e-6)


def test_plan_accepts_int_float32_and_lists() -> None:
    pts = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [2, 2]])
    for xy in (pts, pts.astype(np.float32), pts.astype(np.uint8), pts.tolist(), np.asfortranarray(pts)):
        plan = PlanMap.from_points(xy)
        np.testing.assert_array_equal(plan.points, pts.astype(np.float64))


# --------------------------------------------------------------------------------------------------
# localize
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("bad_scan", "exc", "match"),
    [
        (np.zeros((5, 3)), ValueError, r"scan_xy must have shape \(N, 2\), got \(5, 3\)"),
        (np.zeros(10), ValueError, r"scan_xy must have shape \(N, 2\)"),
        (np.zeros((2, 5, 2)), ValueError, r"scan_xy must have shape \(N, 2\)"),
        (np.zeros((0, 2)), ValueError, "scan_xy is empty"),
        ([[1.0, 0.0], [0.0, 1.0]], ValueError, r"2 usable points; at least 3"),
        ([[1.0, 0.0]], ValueError, r"1 usable points; at least 3"),
        ([[1.0, 0.0], [0.0, np.nan], [1.0, 1.0]], ValueError, r"non-finite.*row 1\b"),
        ([[1.0, 0.0], [0.0, 1.0], [np.inf, 1.0]], ValueError, r"non-finite.*row 2\b"),
        ([[1.0, 0.0], [0.0, 1.0], [1.0, -np.inf]], ValueError, r"non-finite.*row 2\b"),
        (np.array([["1", "2"], ["3", "4"], ["5", "6"]]), TypeError, "scan_xy must hold real numbers"),
        (np.ones((4, 2), dtype=complex), TypeError, "scan_xy must hold real numbers"),
        (np.ones((4, 2), dtype=bool), TypeError, "scan_xy must hold real numbers"),
        (np.ones((4, 2), dtype=object), TypeError, "scan_xy must hold real numbers"),
        ([[1.0, 2.0], [3.0]], ValueError, r"scan_xy must be an \(N, 2\) array"),
    ],
)
def test_localize_bad_scan(plan: PlanMap, bad_scan: Any, exc: type, match: str) -> None:
    with pytest.raises(exc, match=match):
        localize(bad_scan, plan, TRUTH)


def test_too_few_points_after_subsampling(plan: PlanMap, scan: np.ndarray) -> None:
    with pytest.raises(PlanicpError, match=r"after subsampling\) has 2 usable points"):
        localize(scan[:5], plan, TRUTH, IcpConfig(subsample=3))
    # 7 points, every 3rd: 3 usable points is enough
    assert np.isfinite(localize(scan[:7], plan, TRUTH, IcpConfig(subsample=3)).pose).all()


@pytest.mark.parametrize(
    ("pose", "exc", "match"),
    [
        ((1.0, 2.0), ValueError, r"initial_pose must be \(x, y, yaw\) with 3 values, got shape \(2,\)"),
        ((1.0, 2.0, 3.0, 4.0), ValueError, r"3 values, got shape \(4,\)"),
        ([[1.0, 2.0, 3.0]], ValueError, r"3 values, got shape \(1, 3\)"),
        ((1.0, math.nan, 0.0), ValueError, "initial_pose must be finite"),
        ((1.0, 2.0, math.inf), ValueError, "initial_pose must be finite"),
        (("1", "2", "3"), TypeError, "initial_pose must hold real numbers"),
        ((1.0, None, 0.0), TypeError, "initial_pose must hold real numbers"),
        ((1 + 1j, 0.0, 0.0), TypeError, "initial_pose must hold real numbers"),
        ((True, False, True), TypeError, "initial_pose must hold real numbers"),
        (((1.0, 2.0), 3.0, 4.0), ValueError, "initial_pose must be"),  # ragged
    ],
)
def test_localize_bad_initial_pose(plan: PlanMap, scan: np.ndarray, pose: Any, exc: type, match: str) -> None:
    with pytest.raises(exc, match=match):
        localize(scan, plan, pose)


def test_localize_wrong_plan_and_config_types(plan: PlanMap, scan: np.ndarray) -> None:
    with pytest.raises(TypeError, match="plan must be a planicp.PlanMap, got ndarray"):
        localize(scan, box_points(), TRUTH)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="plan must be a planicp.PlanMap, got PointMap"):
        localize(scan, plan._native, TRUTH)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="config must be a planicp.IcpConfig, got dict"):
        localize(scan, plan, TRUTH, {"max_iterations": 5})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="config must be a planicp.IcpConfig, got IcpSettings"):
        localize(scan, plan, TRUTH, IcpConfig()._native)  # type: ignore[arg-type]


def test_localize_accepts_int_and_float32_like_float64(plan: PlanMap) -> None:
    # integer millimetre-free scan: points of the box seen from an integer-friendly pose
    truth = (2.0, 1.0, 0.0)
    scan64 = box_points()[::3] - np.array([2.0, 1.0])
    scan_int = np.round(scan64 * 20).astype(np.int64)  # 5 cm units, exact in every dtype
    scan64 = scan_int.astype(np.float64)
    guess = (2.05, 0.97, 0.02)
    ref = localize(scan64 / 20.0, plan, guess)
    assert np.hypot(ref.pose[0] - truth[0], ref.pose[1] - truth[1]) < 0.05
    # dtype conversion: the same values as int32/int64/float32 give the bitwise same result
    big_plan = PlanMap.from_points(box_points() * 20.0)
    ref20 = localize(scan64, big_plan, (guess[0] * 20, guess[1] * 20, guess[2]))
    for arr in (scan_int, scan_int.astype(np.int32), scan_int.astype(np.int16), scan_int.astype(np.float32)):
        res = localize(arr, big_plan, (guess[0] * 20, guess[1] * 20, guess[2]))
        assert res.pose == ref20.pose, arr.dtype
        np.testing.assert_array_equal(res.inlier_mask, ref20.inlier_mask)
        np.testing.assert_array_equal(res.covariance, ref20.covariance)
    # float32 of a non-representable scan: same as float64 of the float32 values
    s32 = (scan64 / 20.0).astype(np.float32)
    assert localize(s32, plan, guess).pose == localize(s32.astype(np.float64), plan, guess).pose
    # integer pose is accepted too
    assert (
        localize(scan64 / 20.0, plan, np.array([2, 1, 0])).pose == localize(scan64 / 20.0, plan, (2.0, 1.0, 0.0)).pose
    )


# --------------------------------------------------------------------------------------------------
# IcpConfig
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("changes", "exc", "match"),
    [
        ({"max_correspondence_distance": 0.0}, ValueError, "max_correspondence_distance must be a positive"),
        ({"max_correspondence_distance": -1.0}, ValueError, "max_correspondence_distance must be a positive"),
        ({"max_correspondence_distance": math.nan}, ValueError, "max_correspondence_distance must be a positive"),
        ({"max_correspondence_distance": math.inf}, ValueError, "max_correspondence_distance must be a positive"),
        ({"max_correspondence_distance": "0.25"}, TypeError, "max_correspondence_distance must be a number"),
        ({"max_correspondence_distance": True}, TypeError, "max_correspondence_distance must be a number"),
        ({"max_iterations": 30.0}, TypeError, "max_iterations must be an integer"),
        ({"max_iterations": 0}, ValueError, "max_iterations must be at least 1"),
        ({"max_iterations": -3}, ValueError, "max_iterations must be at least 1"),
        ({"max_iterations": True}, TypeError, "max_iterations must be an integer"),
        ({"max_iterations": "30"}, TypeError, "max_iterations must be an integer"),
        ({"trim_ratio": 0.0}, ValueError, r"trim_ratio must be in \(0, 1\]"),
        ({"trim_ratio": 1.5}, ValueError, r"trim_ratio must be in \(0, 1\]"),
        ({"trim_ratio": math.nan}, ValueError, r"trim_ratio must be in \(0, 1\]"),
        ({"trim_ratio": None}, TypeError, "trim_ratio must be a number"),
        ({"translation_tolerance": -1e-4}, ValueError, "translation_tolerance must be a finite number >= 0"),
        ({"translation_tolerance": math.inf}, ValueError, "translation_tolerance must be a finite number >= 0"),
        ({"rotation_tolerance": -1e-4}, ValueError, "rotation_tolerance must be a finite number >= 0"),
        ({"rotation_tolerance": math.nan}, ValueError, "rotation_tolerance must be a finite number >= 0"),
        ({"rotation_tolerance": "0"}, TypeError, "rotation_tolerance must be a number"),
        ({"subsample": 0}, ValueError, "subsample must be at least 1"),
        ({"subsample": 2.0}, TypeError, "subsample must be an integer"),
        ({"correspondence_schedule": ()}, ValueError, "correspondence_schedule needs at least one stage"),
        ({"correspondence_schedule": []}, ValueError, "correspondence_schedule needs at least one stage"),
        ({"correspondence_schedule": (1.0, -0.5)}, ValueError, "correspondence_schedule factor must be a positive"),
        ({"correspondence_schedule": (1.0, 0.0)}, ValueError, "correspondence_schedule factor must be a positive"),
        ({"correspondence_schedule": (1.0, math.nan)}, ValueError, "correspondence_schedule factor must be a positive"),
        ({"correspondence_schedule": (1.0, "0.5")}, TypeError, "correspondence_schedule factor must be a number"),
        ({"correspondence_schedule": "1.0"}, TypeError, "correspondence_schedule must be a sequence"),
        ({"correspondence_schedule": b"\x01"}, TypeError, "correspondence_schedule must be a sequence"),
        ({"correspondence_schedule": 1.0}, TypeError, "correspondence_schedule must be a sequence"),
        ({"correspondence_schedule": {1.0, 0.5}}, TypeError, "correspondence_schedule must be a sequence"),
        ({"use_visibility": 1}, TypeError, "use_visibility must be a bool"),
        ({"use_visibility": "yes"}, TypeError, "use_visibility must be a bool"),
        ({"use_visibility": None}, TypeError, "use_visibility must be a bool"),
        ({"visibility_range": 0.0}, ValueError, "visibility_range must be a positive"),
        ({"visibility_range": -5.0}, ValueError, "visibility_range must be a positive"),
        ({"visibility_range": math.inf}, ValueError, "visibility_range must be a positive"),
        ({"covariance_scale": 0.0}, ValueError, "covariance_scale must be a positive"),
        ({"auto_trim": 1}, TypeError, "auto_trim must be a bool"),
        ({"covariance_scale": math.nan}, ValueError, "covariance_scale must be a positive"),
        ({"visibility_range": "30"}, TypeError, "visibility_range must be a number"),
    ],
)
def test_icp_config_validation(changes: dict[str, Any], exc: type, match: str) -> None:
    with pytest.raises(exc, match=match):
        IcpConfig(**changes)
    with pytest.raises(exc, match=match):
        IcpConfig().replace(**changes)


@pytest.mark.parametrize("field", ["max_iterations", "subsample"])
def test_icp_config_huge_integers_are_a_value_error_naming_the_field(field: str) -> None:
    """An integer too large for the native core is an out-of-range value, not an OverflowError
    with a message that does not say which setting is wrong."""
    with pytest.raises(ValueError, match=field):
        IcpConfig(**{field: 2**64})


def test_icp_config_accepts_numpy_scalars_and_normalises_the_schedule() -> None:
    cfg = IcpConfig(
        max_correspondence_distance=np.float32(0.3),
        max_iterations=np.int64(12),
        subsample=np.uint8(2),
        correspondence_schedule=[2.0, np.float64(1.0)],
        visibility_range=np.int32(20),
    )
    assert cfg.correspondence_schedule == (2.0, 1.0)
    assert isinstance(cfg.correspondence_schedule, tuple)
    assert cfg.stage_distances == pytest.approx((0.6, 0.3))


def test_icp_config_from_dict_unknown_key() -> None:
    with pytest.raises(ValueError, match=r"unknown IcpConfig keys: \['max_iter', 'trim'\]"):
        IcpConfig.from_dict({"max_iter": 3, "trim": 0.5, "subsample": 2})
    with pytest.raises(ValueError, match="_native"):
        IcpConfig.from_dict({"_native": None})


def test_icp_config_from_dict_validates_values() -> None:
    with pytest.raises(ValueError, match="subsample must be at least 1"):
        IcpConfig.from_dict({"subsample": 0})


@pytest.mark.parametrize(
    "cfg",
    [
        IcpConfig(),
        IcpConfig(
            max_correspondence_distance=0.4,
            max_iterations=77,
            trim_ratio=0.8,
            translation_tolerance=0.0,
            rotation_tolerance=0.0,
            subsample=3,
            correspondence_schedule=(3.0, 1.0),
            use_visibility=False,
            visibility_range=12.5,
        ),
    ],
)
def test_icp_config_dict_round_trip(cfg: IcpConfig) -> None:
    d = cfg.to_dict()
    assert "_native" not in d
    assert isinstance(d["correspondence_schedule"], list)
    assert set(d) == {
        "max_correspondence_distance",
        "max_iterations",
        "trim_ratio",
        "auto_trim",
        "translation_tolerance",
        "rotation_tolerance",
        "subsample",
        "correspondence_schedule",
        "use_visibility",
        "accelerate",
        "visibility_range",
        "covariance_scale",
        "correspondence_search",
    }
    back = IcpConfig.from_dict(d)
    assert back == cfg
    assert back.to_dict() == d
    assert IcpConfig.from_dict({}) == IcpConfig()


def test_icp_config_is_frozen() -> None:
    cfg = IcpConfig()
    with pytest.raises(AttributeError):
        cfg.max_iterations = 5  # type: ignore[misc]


# --------------------------------------------------------------------------------------------------
# scan_to_points
# --------------------------------------------------------------------------------------------------


GOOD_SCAN_ARGS: dict[str, Any] = dict(angle_min=0.0, angle_increment=0.01, range_min=0.1, range_max=30.0)


@pytest.mark.parametrize(
    ("ranges", "changes", "exc", "match"),
    [
        (np.ones((3, 2)), {}, ValueError, r"ranges must be one-dimensional, got shape \(3, 2\)"),
        (np.float64(1.0), {}, ValueError, r"ranges must be one-dimensional, got shape \(\)"),
        (np.array(["1", "2"]), {}, TypeError, "ranges must hold real numbers"),
        (np.ones(3, dtype=complex), {}, TypeError, "ranges must hold real numbers"),
        (np.ones(3, dtype=bool), {}, TypeError, "ranges must hold real numbers"),
        (np.ones(3), {"range_min": 5.0, "range_max": 5.0}, ValueError, "need 0 <= range_min < range_max"),
        (np.ones(3), {"range_min": 6.0, "range_max": 5.0}, ValueError, "need 0 <= range_min < range_max"),
        (np.ones(3), {"range_min": -1.0}, ValueError, "need 0 <= range_min < range_max"),
        (np.ones(3), {"range_min": math.nan}, ValueError, "need 0 <= range_min < range_max"),
        (np.ones(3), {"range_max": math.nan}, ValueError, "need 0 <= range_min < range_max"),
        (np.ones(3), {"angle_increment": math.nan}, ValueError, "angle_min and angle_increment must be finite"),
        (np.ones(3), {"angle_min": math.inf}, ValueError, "angle_min and angle_increment must be finite"),
        (np.ones(3), {"angle_min": "0"}, TypeError, "angle_min must be a number"),
        (np.ones(3), {"range_max": None}, TypeError, "range_max must be a number"),
        (np.ones(3), {"sensor_pose": (0.0, 0.0)}, ValueError, r"sensor_pose must be \(x, y, yaw\) with 3 values"),
        (np.ones(3), {"sensor_pose": (0.0, math.nan, 0.0)}, ValueError, "sensor_pose must be finite"),
        (np.ones(3), {"sensor_pose": ("a", "b", "c")}, TypeError, "sensor_pose must hold real numbers"),
    ],
)
def test_scan_to_points_validation(ranges: Any, changes: dict[str, Any], exc: type, match: str) -> None:
    with pytest.raises(exc, match=match):
        scan_to_points(ranges, **{**GOOD_SCAN_ARGS, **changes})


# --------------------------------------------------------------------------------------------------
# AcceptanceGate
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("changes", "exc", "match"),
    [
        ({"require_convergence": 1}, TypeError, "require_convergence must be a bool"),
        ({"require_convergence": "yes"}, TypeError, "require_convergence must be a bool"),
        ({"min_inliers": -1}, ValueError, "min_inliers must be at least 0"),
        ({"min_inliers": 3.0}, TypeError, "min_inliers must be an integer"),
        ({"min_inliers": True}, TypeError, "min_inliers must be an integer"),
        ({"min_inlier_ratio": -0.1}, ValueError, r"min_inlier_ratio must be in \[0, 1\]"),
        ({"min_inlier_ratio": 1.5}, ValueError, r"min_inlier_ratio must be in \[0, 1\]"),
        ({"min_inlier_ratio": math.nan}, ValueError, r"min_inlier_ratio must be in \[0, 1\]"),
        ({"min_inlier_ratio": "0.5"}, TypeError, "min_inlier_ratio must be a number"),
        ({"max_translation_jump": 0.0}, ValueError, "max_translation_jump must be a positive"),
        ({"max_translation_jump": math.inf}, ValueError, "max_translation_jump must be a positive"),
        ({"max_translation_jump": None}, TypeError, "max_translation_jump must be a number"),
        ({"max_rotation_jump": -0.1}, ValueError, "max_rotation_jump must be a positive"),
        ({"max_rotation_jump": math.nan}, ValueError, "max_rotation_jump must be a positive"),
    ],
)
def test_acceptance_gate_validation(changes: dict[str, Any], exc: type, match: str) -> None:
    with pytest.raises(exc, match=match):
        AcceptanceGate(**changes)


def test_acceptance_gate_boundaries_are_valid() -> None:
    gate = AcceptanceGate(require_convergence=False, min_inliers=0, min_inlier_ratio=0.0)
    assert gate.min_inliers == 0
    assert AcceptanceGate(min_inlier_ratio=1.0).min_inlier_ratio == 1.0


# --------------------------------------------------------------------------------------------------
# Localizer
# --------------------------------------------------------------------------------------------------


def test_localizer_constructor_validation(plan: PlanMap) -> None:
    with pytest.raises(TypeError, match="plan must be a planicp.PlanMap"):
        Localizer(box_points(), TRUTH)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="config must be a planicp.IcpConfig"):
        Localizer(plan, TRUTH, {"subsample": 2})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="gate must be a planicp.AcceptanceGate"):
        Localizer(plan, TRUTH, gate={"min_inliers": 3})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="initial_pose must be finite"):
        Localizer(plan, (0.0, math.nan, 0.0))
    with pytest.raises(ValueError, match=r"initial_pose must be \(x, y, yaw\)"):
        Localizer(plan, (0.0, 0.0))
    with pytest.raises(TypeError, match="initial_pose must hold real numbers"):
        Localizer(plan, ("a", "b", "c"))
    loc = Localizer(plan, TRUTH)
    with pytest.raises(ValueError, match="pose must be finite"):
        loc.reset((math.inf, 0.0, 0.0))
    assert loc.pose == TRUTH


@pytest.mark.parametrize(
    ("bad_scan", "exc", "match"),
    [
        ([[1.0, 0.0], [np.nan, 1.0], [1.0, 1.0], [2.0, 2.0]], ValueError, r"scan_xy has a non-finite.*row 1"),
        (np.zeros((5, 3)), ValueError, r"scan_xy must have shape \(N, 2\)"),
        (np.zeros(8), ValueError, r"scan_xy must have shape \(N, 2\)"),
        (np.array([["a", "b"]] * 4), TypeError, "scan_xy must hold real numbers"),
    ],
)
def test_localizer_malformed_scan_raises_and_loses_nothing(
    plan: PlanMap, scan: np.ndarray, bad_scan: Any, exc: type, match: str
) -> None:
    odom0 = (10.0, -3.0, 1.0)
    loc = Localizer(plan, TRUTH)
    first = loc.update(scan, odom0)
    assert first.accepted, first.reason
    pose_before = loc.pose
    # the robot moves 5 cm forward and turns 1 deg; the bad scan comes with the intermediate reading
    odom1 = se2.compose(odom0, (0.03, 0.0, 0.01))
    with pytest.raises(exc, match=match):
        loc.update(bad_scan, odom1)
    assert loc.pose == pose_before
    odom2 = se2.compose(odom0, (0.05, 0.0, 0.0175))
    est = loc.update(scan, odom2)
    expected = se2.compose(pose_before, se2.between(odom0, odom2))
    np.testing.assert_allclose(est.predicted_pose, expected, rtol=0, atol=1e-12)
    assert est.odom_pose == odom2


def test_localizer_bad_odometry_raises_and_loses_nothing(plan: PlanMap, scan: np.ndarray) -> None:
    loc = Localizer(plan, TRUTH)
    loc.update(scan, (0.0, 0.0, 0.0))
    before = loc.pose
    with pytest.raises(ValueError, match="odom_pose must be finite"):
        loc.update(scan, (0.1, math.nan, 0.0))
    with pytest.raises(ValueError, match=r"odom_pose must be \(x, y, yaw\)"):
        loc.update(scan, (0.1, 0.0))
    assert loc.pose == before
    est = loc.update(scan, (0.02, 0.0, 0.0))
    np.testing.assert_allclose(est.predicted_pose, se2.compose(before, (0.02, 0.0, 0.0)), atol=1e-12)


@pytest.mark.parametrize("n_points", [0, 1, 2])
def test_localizer_too_few_points_follows_odometry(plan: PlanMap, scan: np.ndarray, n_points: int) -> None:
    loc = Localizer(plan, TRUTH)
    assert loc.update(scan, (1.0, 2.0, 0.5)).accepted
    start = loc.pose
    motion = (0.1, -0.02, 0.03)
    est = loc.update(scan[:n_points], se2.compose((1.0, 2.0, 0.5), motion))
    assert est.accepted is False
    assert est.result is None
    expected = se2.compose(start, motion)
    np.testing.assert_allclose(est.pose, expected, atol=1e-12)
    np.testing.assert_allclose(est.predicted_pose, expected, atol=1e-12)
    assert loc.pose == est.pose
    assert f"{n_points} usable points" in est.reason and "need 3" in est.reason


def test_localizer_subsampled_scan_too_small(plan: PlanMap, scan: np.ndarray) -> None:
    loc = Localizer(plan, TRUTH, IcpConfig(subsample=4))
    est = loc.update(scan[:8], (0.0, 0.0, 0.0))  # every 4th of 8 points: 2 usable
    assert est.accepted is False and est.result is None
    assert "2 usable points" in est.reason
    np.testing.assert_allclose(est.pose, TRUTH, rtol=0, atol=1e-12)


# --------------------------------------------------------------------------------------------------
# extreme but finite inputs: a documented result or a documented error, never anything else
# --------------------------------------------------------------------------------------------------


def _outcome(fn: Any) -> str:
    """'ok' (finite pose, consistent fields) or 'error' (PlanicpError/ValueError). Anything else fails."""
    try:
        res = fn()
    except ValueError as exc:  # PlanicpError is a ValueError
        assert str(exc), "an error must say what is wrong"
        return "error"
    if isinstance(res, planicp.IcpResult):
        assert all(math.isfinite(v) for v in res.pose), res
        assert 0.0 <= res.inlier_ratio <= 1.0
        assert res.num_inliers == int(res.inlier_mask.sum())
        assert res.iterations >= 0
        cov = res.covariance
        assert cov.shape == (3, 3)
        assert not np.isnan(np.diag(cov)).any(), cov
        assert (math.isnan(res.rmse) and res.num_inliers == 0) or res.rmse >= 0.0
    return "ok"


EXTREME_CASES = {
    "plan 1e300": lambda: localize(box_points()[:50], PlanMap.from_points(box_points() * 1e300), (0.0, 0.0, 0.0)),
    "plan 1e150": lambda: localize(box_points()[:50], PlanMap.from_points(box_points() * 1e150), (0.0, 0.0, 0.0)),
    "scan 1e300": lambda: localize(box_points()[:50] * 1e300, PlanMap.from_points(box_points()), (1.0, 1.0, 0.0)),
    "scan 1e300 no visibility": lambda: localize(
        box_points()[:50] * 1e300, PlanMap.from_points(box_points()), (1.0, 1.0, 0.0), IcpConfig(use_visibility=False)
    ),
    "scan near max float": lambda: localize(
        np.array([[1.7e308, 0.0], [0.0, 1.7e308], [-1.7e308, -1.7e308], [1.0, 1.0]]),
        PlanMap.from_points(box_points()),
        (1.0, 1.0, 0.0),
    ),
    "tiny 1e-300": lambda: localize(
        box_points()[:60] * 1e-300 - 1e-300, PlanMap.from_points(box_points() * 1e-300), (0.0, 0.0, 0.0)
    ),
    "subnormal 5e-324": lambda: localize(
        np.array([[5e-324, 0.0], [0.0, 5e-324], [5e-324, 5e-324]]),
        PlanMap.from_points([[0.0, 0.0], [5e-324, 0.0]]),
        (0.0, 0.0, 0.0),
    ),
    "plan of one point": lambda: localize(box_points()[:50], PlanMap.from_points([[1.0, 1.0]]), (1.0, 1.0, 0.0)),
    "plan of identical points": lambda: localize(
        box_points()[:50], PlanMap.from_points(np.full((500, 2), 3.0)), (1.0, 1.0, 0.0)
    ),
    "scan of identical points": lambda: localize(np.full((200, 2), 0.5), PlanMap.from_points(box_points()), TRUTH),
    "scan of identical points on a wall": lambda: localize(
        np.full((200, 2), 0.0), PlanMap.from_points(box_points()), (2.0, 0.0, 0.0)
    ),
    "collinear plan": lambda: localize(
        np.column_stack([np.arange(50) * 0.05, np.zeros(50)]),
        PlanMap.from_points(np.column_stack([np.arange(100) * 0.05, np.zeros(100)])),
        (0.5, 0.02, 0.01),
    ),
    "plan at 1e9 over 4 mm": lambda: localize(
        box_points()[::4] * 1e-3, PlanMap.from_points(box_points() * 1e-3 + 1e9), (1e9 + 0.002, 1e9 + 0.001, 0.0)
    ),
    "plan at 1e9, pose at origin": lambda: localize(
        box_points()[:50], PlanMap.from_points(box_points() * 1e-3 + 1e9), (0.0, 0.0, 0.0)
    ),
    "huge visibility_range": lambda: localize(
        se2.transform_points(se2.inverse(TRUTH), box_points()),
        PlanMap.from_points(box_points()),
        TRUTH,
        IcpConfig(visibility_range=1e300),
    ),
    "tiny visibility_range": lambda: localize(
        se2.transform_points(se2.inverse(TRUTH), box_points()),
        PlanMap.from_points(box_points()),
        TRUTH,
        IcpConfig(visibility_range=1e-300),
    ),
    "huge max_correspondence_distance": lambda: localize(
        se2.transform_points(se2.inverse(TRUTH), box_points()),
        PlanMap.from_points(box_points()),
        TRUTH,
        IcpConfig(max_correspondence_distance=1e300),
    ),
    "tiny max_correspondence_distance": lambda: localize(
        se2.transform_points(se2.inverse(TRUTH), box_points()),
        PlanMap.from_points(box_points()),
        TRUTH,
        IcpConfig(max_correspondence_distance=1e-300),
    ),
    "huge schedule factor": lambda: localize(
        se2.transform_points(se2.inverse(TRUTH), box_points()),
        PlanMap.from_points(box_points()),
        TRUTH,
        IcpConfig(correspondence_schedule=(1e300, 1.0)),
    ),
    "huge subsample": lambda: localize(
        box_points(), PlanMap.from_points(box_points()), TRUTH, IcpConfig(subsample=2**62)
    ),
    "tiny trim ratio": lambda: localize(
        box_points(), PlanMap.from_points(box_points()), TRUTH, IcpConfig(trim_ratio=1e-300)
    ),
    "huge yaw": lambda: localize(box_points(), PlanMap.from_points(box_points()), (1.0, 1.0, 1e300)),
    "pose far outside the plan (1e6)": lambda: localize(
        box_points(), PlanMap.from_points(box_points()), (1e6, -1e6, 0.0)
    ),
    "huge explicit resolution": lambda: localize(
        box_points(), PlanMap.from_points(box_points(), resolution=1e300), TRUTH
    ),
    "tiny explicit resolution": lambda: PlanMap.from_points(box_points(), resolution=1e-300),
}


@pytest.mark.parametrize("case", list(EXTREME_CASES))
def test_extreme_inputs_never_escape_as_other_errors(case: str) -> None:
    _outcome(EXTREME_CASES[case])


def test_extreme_plans_of_huge_extent_are_rejected_with_a_message() -> None:
    with pytest.raises(PlanicpError, match=r"coordinate of -1e300 m at row 0, beyond \+-1e9 m"):
        PlanMap.from_points(np.array([[-1e300, -1e300], [1e300, 1e300], [0.0, 0.0]]))
    # A plan that fits the coordinate range but is too wide for a fine explicit raster.
    with pytest.raises(PlanicpError, match="raster"):
        PlanMap.from_points(np.array([[-1e8, -1e8], [1e8, 1e8]]), resolution=0.01)


def test_visible_indices_extremes(plan: PlanMap) -> None:
    assert len(plan.visible_indices(TRUTH, 1e300)) > 0
    assert len(plan.visible_indices((1e6, 1e6, 0.0), 30.0)) == 0
    with pytest.raises(ValueError, match="max_range must be a positive"):
        plan.visible_indices(TRUTH, 0.0)
    with pytest.raises(ValueError, match="pose must be finite"):
        plan.visible_indices((math.nan, 0.0, 0.0))


_HANG_SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    import planicp
    xs = np.arange(0.0, 4.0, 0.05)
    box = np.vstack([np.c_[xs, 0 * xs], np.c_[xs, 0 * xs + 3.0],
                     np.c_[0 * xs, xs * 0.75], np.c_[0 * xs + 4.0, xs * 0.75]])
    plan = planicp.PlanMap.from_points(box)
    case = sys.argv[1]
    try:
        if case == "visible_indices":
            plan.visible_indices((1e18, 0.0, 0.0), 30.0)
        elif case == "localize":
            planicp.localize(box - 2.0, plan, (-1e19, 5e18, 0.0))
        elif case == "far_plan":
            planicp.localize(box - 2.0, planicp.PlanMap.from_points(box + 1e18), (0.0, 0.0, 0.0))
    except ValueError:
        pass
    print("done")
    """
)


def test_far_away_pose_returns_instead_of_hanging() -> None:
    """A finite pose ~1e18 m from the plan (or a plan ~1e18 m from the pose) must give a result or an
    error, not an endless ray-casting loop. Each case runs in its own subprocess (all at once, 5 s in
    all) so that a hang cannot stall the suite."""
    import time

    cases = ["visible_indices", "localize", "far_plan"]
    procs = {
        c: subprocess.Popen(
            [sys.executable, "-c", _HANG_SCRIPT, c], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for c in cases
    }
    deadline = time.monotonic() + 5.0
    hung, crashed = [], []
    for case, proc in procs.items():
        try:
            out, err = proc.communicate(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            hung.append(case)
            continue
        if proc.returncode != 0 or out.strip() != "done":
            crashed.append((case, proc.returncode, err[-500:]))
    assert not hung, f"still running after 5 s (endless loop in the visibility ray caster): {hung}"
    assert not crashed, crashed


# --------------------------------------------------------------------------------------------------
# Sizes from the input: refused or clipped, never an abort (each in its own process: an abort kills it)
# --------------------------------------------------------------------------------------------------


def run_isolated(code: str) -> subprocess.CompletedProcess[str]:
    """`code` run by this interpreter in a fresh process, with its address space capped at 4 GiB
    so that an allocation of tens of GB fails there as it would on a small robot computer."""
    prelude = "import resource\nresource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))\n"
    return subprocess.run(
        [sys.executable, "-c", prelude + textwrap.dedent(code)], capture_output=True, text=True, timeout=300
    )


def test_a_search_region_larger_than_the_plan_is_clipped_to_it() -> None:
    """A 10 km region around the shipped 30 x 20 m plan aborted the process (SIGABRT, "memory
    allocation of 10737418240 bytes failed"); clipped to the plan, it is the whole plan's search."""
    done = run_isolated("""
        import math
        import numpy as np
        import planicp
        from planicp import SearchRegion
        from planicp.plans.default_plan import load_default_plan
        from planicp.sim.experiment import ExperimentConfig, run_experiment
        plan = load_default_plan()
        recording, _ = run_experiment(plan, ExperimentConfig(duration_s=1.0, seed=2))
        found = planicp.relocalize(recording.scans[0], plan, region=SearchRegion((15.0, 10.0, 0.0), 1e4, math.pi))
        best = found.best
        assert best is not None and math.dist(best.pose[:2], recording.truth[0][:2]) < 0.1, best
        print("ok")
    """)
    assert done.returncode == 0 and done.stdout.strip() == "ok", (done.returncode, done.stderr[-2000:])


def test_a_recovery_with_a_huge_local_radius_does_not_abort() -> None:
    """`RecoveryConfig(local_radius=1e4)` aborted the process after a 0.5 rad odometry step."""
    done = run_isolated("""
        import numpy as np
        import planicp
        from planicp import Localizer, RecoveryConfig
        from planicp.plans.default_plan import load_default_plan
        from planicp.se2 import compose
        from planicp.sim.experiment import ExperimentConfig, run_experiment
        plan = load_default_plan()
        rec, _ = run_experiment(plan, ExperimentConfig(duration_s=2.0, seed=3))
        loc = Localizer(plan, tuple(rec.truth[0]), recovery=RecoveryConfig(local_radius=1e4))
        for k in range(10):
            odom = tuple(rec.odometry_in_odom[k])
            if k >= 5:
                odom = compose(odom, (0.0, 0.0, 0.5))
            loc.update(rec.scans[k], odom)
        print("ok")
    """)
    assert done.returncode == 0 and done.stdout.strip() == "ok", (done.returncode, done.stderr[-2000:])


def test_an_occupancy_grid_too_large_for_memory_is_an_error() -> None:
    """A grid allowed 2^40 cells, grown to a point 3 km away (29 GB), aborted the process."""
    done = run_isolated("""
        import planicp
        from planicp import EnhancedOccupancyGrid
        from planicp.plans.default_plan import load_default_plan
        grid = EnhancedOccupancyGrid(load_default_plan(), max_cells=2**40, max_range=1e4)
        try:
            grid.integrate([[3000.0, 3000.0]], (5.0, 10.0, 0.0))
        except planicp.PlanicpError as exc:
            print("refused:", exc)
    """)
    assert done.returncode == 0 and "refused: could not allocate" in done.stdout, (done.returncode, done.stderr[-2000:])


def test_poses_beyond_a_billion_metres_are_refused_at_the_door(plan: PlanMap, scan: np.ndarray) -> None:
    with pytest.raises(ValueError, match=r"odom_pose has a coordinate of 3\.0+e\+09 m, beyond \+-1e\+09 m"):
        Localizer(plan, (1.0, 1.0, 0.0)).update(scan, (3e9, 0.0, 0.0))
