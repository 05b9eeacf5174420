"""Vector floor plans (`planicp.plans.vector_plan`): sampling segments into wall points, the HouseExpo
outline reader and the DXF reader, checked against geometry known in closed form, down to a scan
localized against a plan read from a DXF file."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from ezdxf.document import Drawing
from ezdxf.filemanagement import new as new_drawing
from ezdxf.layouts.layout import Modelspace
from ezdxf.math import bulge_to_arc
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

import planicp
from geometry_checks import nearest_distance
from planicp.plans.vector_plan import dxf_segments, house_expo_segments, sample_segments

DATA = Path(__file__).parent / "data"
HOUSE_EXPO = DATA / "house_expo_room_0000.json"
DEG = math.pi / 180.0
EZDXF_MISSING = "reading DXF plans needs ezdxf: pip install 'planicp[cad]'"

Array = NDArray[np.float64]


# --------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------


def segment_distance(points: Array, a: Array, b: Array) -> Array:
    """Distance of each point to the segment a-b (a point when a == b)."""
    ab = b - a
    den = float(ab @ ab)
    t = np.zeros(len(points)) if den == 0.0 else np.clip((points - a) @ ab / den, 0.0, 1.0)
    return np.asarray(np.hypot(*(points - (a + t[:, None] * ab)).T))


def distance_to_segments(points: Array, segments: Array) -> Array:
    """Distance of each point to the nearest of the segments."""
    return np.asarray(np.min([segment_distance(points, s[0], s[1]) for s in segments], axis=0))


def check_sampling(points: Array, segments: Array, spacing: float) -> None:
    """Per segment: its points include both endpoints and are at most `spacing` apart along it."""
    for a, b in segments:
        on = points[segment_distance(points, a, b) <= 1e-12]
        assert (on == a).all(axis=1).any() and (on == b).all(axis=1).any()
        ab = b - a
        length = math.hypot(*ab)
        if length == 0.0:
            continue
        along = np.sort((on - a) @ ab / length)
        assert along[0] == pytest.approx(0.0, abs=1e-12) and along[-1] == pytest.approx(length, abs=1e-12)
        assert np.diff(along).max() <= spacing + 1e-12


def new_dxf(units: int) -> tuple[Drawing, Modelspace]:
    doc = new_drawing()
    doc.header["$INSUNITS"] = units
    return doc, doc.modelspace()


def save(doc: Drawing, path: Path) -> Path:
    doc.saveas(path)
    return path


def check_arc_chain(segs: Array, center: tuple[float, float], radius: float, tol: float) -> Array:
    """The segments form one chain of chords of the circle, each with sagitta <= tol.

    Returns the polar angle of each chain vertex about `center`, unwrapped.
    """
    c = np.asarray(center, dtype=np.float64)
    np.testing.assert_array_equal(segs[1:, 0], segs[:-1, 1])  # contiguous
    vertices = np.vstack([segs[:, 0], segs[-1:, 1]])
    np.testing.assert_allclose(np.hypot(*(vertices - c).T), radius, rtol=0, atol=1e-12)
    mid = segs.mean(axis=1)
    sagitta = radius - np.hypot(*(mid - c).T)
    assert sagitta.max() <= tol + 1e-12
    return np.unwrap(np.arctan2(vertices[:, 1] - c[1], vertices[:, 0] - c[0]))


def min_chords(sweep: float, radius: float, tol: float) -> int:
    """The fewest equal chords over `sweep` radians whose sagitta stays <= tol."""
    return math.ceil(abs(sweep) / (2.0 * math.acos(1.0 - tol / radius)))


# --------------------------------------------------------------------------------------------------
# sample_segments
# --------------------------------------------------------------------------------------------------

SEGMENTS = np.array(
    [
        [[0.0, 0.0], [1.0, 0.0]],  # horizontal, 1 m: a whole number of spacings
        [[1.0, 0.0], [1.0, 0.37]],  # vertical, shares an endpoint with the first
        [[0.1, -0.3], [2.7, 1.9]],  # diagonal
        [[-2.0, 5.0], [-5.3, 1.1]],  # diagonal, both coordinates decreasing
        [[4.0, 4.0], [4.013, 4.001]],  # shorter than one spacing
        [[3.0, 3.0], [3.0, 3.0]],  # zero length
    ]
)


@pytest.mark.parametrize("spacing", [0.02, 0.07, 0.25])
def test_sample_segments_spacing_endpoints_and_on_segment(spacing: float) -> None:
    points = sample_segments(SEGMENTS, spacing)
    assert points.dtype == np.float64 and points.shape[1] == 2 and points.flags.c_contiguous
    assert distance_to_segments(points, SEGMENTS).max() <= 1e-12
    check_sampling(points, SEGMENTS, spacing)
    assert len(np.unique(points, axis=0)) == len(points)  # no duplicate points


@pytest.mark.parametrize("segment", SEGMENTS[:5].tolist())
def test_each_segment_gets_ceil_length_over_spacing_equal_intervals(segment: list[list[float]]) -> None:
    spacing = 0.03
    (x0, y0), (x1, y1) = segment
    length = math.hypot(x1 - x0, y1 - y0)
    points = sample_segments([segment], spacing)
    n = math.ceil(length / spacing)
    assert len(points) == n + 1
    assert points[0].tolist() == [x0, y0] and points[-1].tolist() == [x1, y1]  # exact endpoints, in order
    gaps = np.hypot(*np.diff(points, axis=0).T)
    np.testing.assert_allclose(gaps, length / n, rtol=0, atol=1e-12)  # evenly spaced, in order
    assert gaps.max() <= spacing + 1e-12


def test_whole_multiples_of_the_spacing_get_no_extra_point() -> None:
    assert len(sample_segments([[[0, 0], [1, 0]]], 0.1)) == 11
    assert len(sample_segments([[[0, 0], [0, 0.3]]], 0.1)) == 4  # 0.3 / 0.1 = 2.9999999999999996
    assert len(sample_segments([[[0, 0], [0, 0.3]]], 0.3)) == 2


def test_zero_length_segment_gives_one_point() -> None:
    points = sample_segments([[[1.5, -2.25], [1.5, -2.25]]])
    np.testing.assert_array_equal(points, [[1.5, -2.25]])
    mixed = sample_segments([[[0.0, 0.0], [0.1, 0.0]], [[7.0, 7.0], [7.0, 7.0]]], 0.05)
    np.testing.assert_array_equal(mixed, [[0.0, 0.0], [0.05, 0.0], [0.1, 0.0], [7.0, 7.0]])


def test_shared_endpoints_appear_once_in_segment_order() -> None:
    square = [[[0, 0], [1, 0]], [[1, 0], [1, 1]], [[1, 1], [0, 1]], [[0, 1], [0, 0]]]
    points = sample_segments(square, 0.5)
    expected = [[0, 0], [0.5, 0], [1, 0], [1, 0.5], [1, 1], [0.5, 1], [0, 1], [0, 0.5]]
    np.testing.assert_array_equal(points, expected)
    # -0.0 and 0.0 are the same point
    signed = sample_segments([[[-0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [0.0, -0.0]]], 1.0)
    np.testing.assert_array_equal(signed, [[0.0, 0.0], [1.0, 0.0]])


def test_integer_and_float32_segments_are_converted() -> None:
    ints = sample_segments(np.array([[[0, 0], [2, 0]]], dtype=np.int32), 1)
    np.testing.assert_array_equal(ints, [[0, 0], [1, 0], [2, 0]])
    f32 = sample_segments(np.array([[[0, 0], [0, 0.5]]], dtype=np.float32), 0.25)
    assert f32.dtype == np.float64 and len(f32) == 3


coordinate = st.floats(-50.0, 50.0, allow_nan=False)


@settings(max_examples=80, deadline=None)
@given(
    st.lists(st.tuples(coordinate, coordinate, coordinate, coordinate), min_size=1, max_size=6),
    st.floats(1e-3, 3.0),
)
def test_sampling_properties(raw: list[tuple[float, float, float, float]], spacing: float) -> None:
    segments = np.array(raw, dtype=np.float64).reshape(-1, 2, 2)
    points = sample_segments(segments, spacing)
    assert distance_to_segments(points, segments).max() <= 1e-9
    check_sampling(points, segments, spacing)


@pytest.mark.parametrize(
    ("segments", "message"),
    [
        (np.zeros((3, 2)), r"shape \(M, 2, 2\)"),
        (np.zeros((3, 3, 2)), r"shape \(M, 2, 2\)"),
        (np.zeros((3, 2, 3)), r"shape \(M, 2, 2\)"),
        (np.zeros((0, 2, 2)), "empty"),
        ([[[0.0, 0.0], [1.0, math.nan]]], "non-finite.*segment 0"),
        ([[[0.0, 0.0], [1.0, 1.0]], [[math.inf, 0.0], [1.0, 1.0]]], "non-finite.*segment 1"),
        ([[[0.0, 0.0], [1.0]]], "array of numbers"),
    ],
)
def test_sample_segments_rejects_malformed_segments(segments: Any, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        sample_segments(segments)


@pytest.mark.parametrize("spacing", [0.0, -0.02, math.nan, math.inf])
def test_sample_segments_rejects_bad_spacing(spacing: float) -> None:
    with pytest.raises(ValueError, match="spacing"):
        sample_segments([[[0.0, 0.0], [1.0, 0.0]]], spacing)


def test_sample_segments_type_errors_and_size_limit() -> None:
    with pytest.raises(TypeError, match="real numbers"):
        sample_segments([[["a", "b"], ["c", "d"]]])
    with pytest.raises(TypeError, match="real numbers"):
        sample_segments(np.ones((1, 2, 2), dtype=complex))
    with pytest.raises(TypeError, match="spacing"):
        sample_segments([[[0.0, 0.0], [1.0, 0.0]]], "0.02")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="spacing"):
        sample_segments([[[0.0, 0.0], [1.0, 0.0]]], True)
    with pytest.raises(ValueError, match="larger spacing"):
        sample_segments([[[0.0, 0.0], [1e6, 0.0]]], 1e-3)


# --------------------------------------------------------------------------------------------------
# A plan built from known segments
# --------------------------------------------------------------------------------------------------


def test_plan_from_sampled_segments_lies_on_and_covers_the_segments() -> None:
    walls = np.array(
        [
            [[0.0, 0.0], [6.0, 0.0]],
            [[6.0, 0.0], [6.0, 2.5]],
            [[6.0, 2.5], [3.5, 2.5]],
            [[3.5, 2.5], [3.5, 4.0]],
            [[3.5, 4.0], [0.0, 4.0]],
            [[0.0, 4.0], [0.0, 0.0]],
            [[1.0, 1.0], [2.3, 3.1]],  # a diagonal partition
            [[4.2, 0.7], [5.1, 1.65]],
        ]
    )
    plan = planicp.PlanMap.from_points(sample_segments(walls, 0.02))
    assert distance_to_segments(plan.points, walls).max() <= 1e-9
    for a, b in walls:
        fine_n = math.ceil(math.hypot(*(b - a)) / 0.001)
        fine = a + np.linspace(0.0, 1.0, fine_n + 1)[:, None] * (b - a)
        assert nearest_distance(fine, plan.points).max() <= 0.0101
    assert plan.extent == pytest.approx((0.0, 0.0, 6.0, 4.0), abs=1e-12)


# --------------------------------------------------------------------------------------------------
# HouseExpo
# --------------------------------------------------------------------------------------------------


def test_house_expo_sample_is_a_closed_polygon_within_its_bbox() -> None:
    raw = json.loads(HOUSE_EXPO.read_text())
    segments, bbox = house_expo_segments(HOUSE_EXPO)
    assert segments.shape == (len(raw["verts"]), 2, 2) == (147, 2, 2)
    np.testing.assert_array_equal(segments[:, 0], raw["verts"])  # vertex order kept
    np.testing.assert_array_equal(segments[:, 1], np.roll(segments[:, 0], -1, axis=0))  # closed
    np.testing.assert_array_equal(segments[-1, 1], segments[0, 0])
    assert bbox == (0.1, 0.1, 10.17, 8.16)
    points = sample_segments(segments, 0.02)
    lo, hi = points.min(axis=0), points.max(axis=0)
    np.testing.assert_allclose([*lo, *hi], bbox, rtol=0, atol=1e-9)
    plan = planicp.PlanMap.from_points(points)
    np.testing.assert_allclose(plan.extent, bbox, rtol=0, atol=1e-9)


def test_house_expo_accepts_str_paths_and_parsed_dicts() -> None:
    segments, bbox = house_expo_segments(str(HOUSE_EXPO))
    from_dict, bbox_dict = house_expo_segments(json.loads(HOUSE_EXPO.read_text()))
    np.testing.assert_array_equal(segments, from_dict)
    assert bbox == bbox_dict


def test_house_expo_repeated_closing_vertex_is_not_an_edge() -> None:
    data = {"verts": [[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]], "bbox": {"min": [0, 0], "max": [2, 1]}}
    segments, bbox = house_expo_segments(data)
    expected = [[[0, 0], [2, 0]], [[2, 0], [2, 1]], [[2, 1], [0, 1]], [[0, 1], [0, 0]]]
    np.testing.assert_array_equal(segments, expected)
    assert bbox == (0.0, 0.0, 2.0, 1.0)


def test_house_expo_missing_file(tmp_path: Path) -> None:
    missing = tmp_path / "no_such_plan.json"
    with pytest.raises(FileNotFoundError, match="no_such_plan.json"):
        house_expo_segments(missing)


GOOD_BBOX = {"min": [0, 0], "max": [1, 1]}
TRIANGLE = [[0, 0], [1, 0], [0, 1]]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"verts": [[0, 0], [1, 0]', "not valid JSON"),
        ("[1, 2, 3]", "JSON object"),
        (json.dumps({"bbox": GOOD_BBOX}), "'verts'"),
        (json.dumps({"verts": TRIANGLE}), "'bbox'"),
        (json.dumps({"verts": [[0, 0], [1, 1]], "bbox": GOOD_BBOX}), "'verts'.*at least 3 vertices, got 2"),
        ('{"verts": [[0, 0], [1, NaN], [0, 1]], "bbox": {"min": [0, 0], "max": [1, 1]}}', "'verts'.*non-finite"),
        (json.dumps({"verts": [[0, 0], [1, None], [0, 1]], "bbox": GOOD_BBOX}), "'verts'.*number pairs"),
        (json.dumps({"verts": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "bbox": GOOD_BBOX}), "'verts'.*number pairs"),
        (json.dumps({"verts": TRIANGLE, "bbox": {"min": [0, 0]}}), "'bbox.max'"),
        (json.dumps({"verts": TRIANGLE, "bbox": [0, 0, 1, 1]}), "'bbox'"),
        (
            '{"verts": [[0, 0], [1, 0], [0, 1]], "bbox": {"min": [0, -Infinity], "max": [1, 1]}}',
            "'bbox.min'.*non-finite",
        ),
        (json.dumps({"verts": TRIANGLE, "bbox": {"min": [2, 0], "max": [1, 1]}}), "'bbox'.*exceeds"),
    ],
)
def test_house_expo_errors_name_the_file_and_the_key(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "broken_plan.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as info:
        house_expo_segments(path)
    assert str(path) in str(info.value)


def test_house_expo_rejects_other_sources() -> None:
    with pytest.raises(TypeError, match="path"):
        house_expo_segments(42)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"dict.*at least 3 vertices"):
        house_expo_segments({"verts": [[0, 0], [1, 1]], "bbox": GOOD_BBOX})


# --------------------------------------------------------------------------------------------------
# DXF
# --------------------------------------------------------------------------------------------------

ROOM_MM = [  # a 5 x 4 m room, millimetres
    ((0.0, 0.0), (5000.0, 0.0)),
    ((5000.0, 0.0), (5000.0, 4000.0)),
    ((5000.0, 4000.0), (0.0, 4000.0)),
    ((0.0, 4000.0), (0.0, 0.0)),
]


def room_with_furniture(path: Path) -> Path:
    doc, msp = new_dxf(4)  # millimetres
    doc.layers.add("WALLS")
    doc.layers.add("FURNITURE")
    for a, b in ROOM_MM:
        msp.add_line(a, b, dxfattribs={"layer": "WALLS"})
    msp.add_line((1000, 1000), (2200, 1000), dxfattribs={"layer": "FURNITURE"})  # a table edge
    msp.add_circle((3000, 2500), 300, dxfattribs={"layer": "FURNITURE"})  # a round table
    msp.add_text("Office 1.02", dxfattribs={"layer": "WALLS"})
    return save(doc, path)


def test_dxf_room_in_millimetres_gives_metres_and_layers_filter(tmp_path: Path) -> None:
    path = room_with_furniture(tmp_path / "room.dxf")
    walls = dxf_segments(path, layers=["walls"])
    np.testing.assert_allclose(walls, np.array(ROOM_MM) / 1000.0, rtol=0, atol=1e-9)
    assert walls.dtype == np.float64 and walls.flags.c_contiguous
    np.testing.assert_array_equal(dxf_segments(str(path), layers="Walls"), walls)  # one str is one layer
    # By default the layer named as walls only: the furniture is left out.
    np.testing.assert_array_equal(dxf_segments(path), walls)
    everything = dxf_segments(path, layers=["FURNITURE", "walls"])
    circle_chords = min_chords(2 * math.pi, 0.3, 0.01)
    assert len(everything) == 4 + 1 + circle_chords
    np.testing.assert_allclose(everything[:4], walls, rtol=0, atol=0)
    np.testing.assert_allclose(everything[4], [[1.0, 1.0], [2.2, 1.0]], rtol=0, atol=1e-9)


def test_dxf_lwpolyline_bulge_semicircle(tmp_path: Path) -> None:
    doc, msp = new_dxf(6)
    msp.add_lwpolyline([(0.0, 0.0, 1.0), (2.0, 0.0, 0.0)], format="xyb")  # bulge 1: CCW semicircle
    msp.add_lwpolyline([(0.0, 5.0, -1.0), (2.0, 5.0, 0.0)], format="xyb")  # bulge -1: clockwise
    segs = dxf_segments(save(doc, tmp_path / "bulge.dxf"), arc_tolerance=0.01)
    n = min_chords(math.pi, 1.0, 0.01)
    assert len(segs) == 2 * n
    for (start, end, bulge), center in (
        (((0.0, 0.0), (2.0, 0.0), 1.0), (1.0, 0.0)),
        (((0.0, 5.0), (2.0, 5.0), -1.0), (1.0, 5.0)),
    ):
        reference = bulge_to_arc(start, end, bulge)[0]  # ezdxf's own reading of the bulge
        assert (reference.x, reference.y) == pytest.approx(center, abs=1e-12)
    for chain, center, side in ((segs[:n], (1.0, 0.0), -1.0), (segs[n:], (1.0, 5.0), 1.0)):
        assert chain[0, 0].tolist() == [0.0, chain[0, 0, 1]] and chain[0, 0, 1] in (0.0, 5.0)
        np.testing.assert_array_equal(chain[-1, 1], [2.0, center[1]])  # exact end vertex
        angles = check_arc_chain(chain, center, 1.0, 0.01)
        assert angles[-1] - angles[0] == pytest.approx(-side * math.pi, abs=1e-12)
        # CCW from (0, 0) to (2, 0) about (1, 0) passes below the chord; clockwise passes above
        assert (side * (chain[:, :, 1] - center[1]) >= -1e-12).all()
        assert side * (chain[n // 2, 0, 1] - center[1]) > 0.9


def test_dxf_closed_lwpolyline_and_2d_polyline(tmp_path: Path) -> None:
    doc, msp = new_dxf(6)
    msp.add_lwpolyline([(0, 0), (4, 0), (4, 3), (0, 3)], close=True)
    # a 2D POLYLINE: 10 x 6 rectangle whose top edge bulges up by a semicircle (bulge on its start vertex)
    msp.add_polyline2d([(10, 0, 0), (20, 0, 0), (20, 6, 1.0), (10, 6, 0)], format="xyb", close=True)
    msp.add_polyline3d([(0, 0, 0), (9, 9, 9)])  # 3D polyline: not a wall
    segs = dxf_segments(save(doc, tmp_path / "polylines.dxf"))
    rect = [[[0, 0], [4, 0]], [[4, 0], [4, 3]], [[4, 3], [0, 3]], [[0, 3], [0, 0]]]
    np.testing.assert_array_equal(segs[:4], rect)
    poly = segs[4:]
    n = min_chords(math.pi, 5.0, 0.01)
    assert len(poly) == 3 + n
    np.testing.assert_array_equal(poly[:2], [[[10, 0], [20, 0]], [[20, 0], [20, 6]]])
    np.testing.assert_array_equal(poly[-1], [[10, 6], [10, 0]])
    arc = poly[2:-1]
    angles = check_arc_chain(arc, (15.0, 6.0), 5.0, 0.01)
    assert angles[-1] - angles[0] == pytest.approx(math.pi, abs=1e-12)  # CCW from 0 to 180 deg: over the top
    assert (arc[:, :, 1] >= 6.0 - 1e-12).all()


@pytest.mark.parametrize(
    ("start_deg", "end_deg"),
    [(0.0, 90.0), (270.0, 45.0), (10.0, 350.0), (-30.0, 30.0)],
)
def test_dxf_arc_flattened_within_tolerance(tmp_path: Path, start_deg: float, end_deg: float) -> None:
    doc, msp = new_dxf(6)
    arc = msp.add_arc((5.0, 5.0), 2.0, start_deg, end_deg)
    tol = 0.004
    segs = dxf_segments(save(doc, tmp_path / "arc.dxf"), arc_tolerance=tol)
    sweep = math.radians((end_deg - start_deg) % 360.0)
    assert len(segs) == min_chords(sweep, 2.0, tol)
    angles = check_arc_chain(segs, (5.0, 5.0), 2.0, tol)
    assert angles[-1] - angles[0] == pytest.approx(sweep, abs=1e-12)  # counter-clockwise
    np.testing.assert_allclose(segs[0, 0], np.array(arc.start_point)[:2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(segs[-1, 1], np.array(arc.end_point)[:2], rtol=0, atol=1e-12)


def test_dxf_circle_is_a_closed_chain_within_tolerance(tmp_path: Path) -> None:
    doc, msp = new_dxf(6)
    msp.add_circle((1.0, 2.0), 0.5)
    msp.add_circle((-4.0, 0.0), 0.0015)  # radius below the tolerance: still a triangle
    segs = dxf_segments(save(doc, tmp_path / "circle.dxf"), arc_tolerance=0.002)
    n = min_chords(2 * math.pi, 0.5, 0.002)
    assert len(segs) == n + 3
    big = segs[:n]
    np.testing.assert_array_equal(big[-1, 1], big[0, 0])  # closed
    angles = check_arc_chain(big, (1.0, 2.0), 0.5, 0.002)
    assert angles[-1] - angles[0] == pytest.approx(2 * math.pi, abs=1e-12)
    np.testing.assert_array_equal(segs[-1, 1], segs[n, 0])
    check_arc_chain(segs[n:], (-4.0, 0.0), 0.0015, 0.002)


def test_dxf_arc_tolerance_is_in_metres_whatever_the_drawing_units(tmp_path: Path) -> None:
    doc, msp = new_dxf(4)  # millimetres
    msp.add_circle((0.0, 0.0), 1000.0)
    segs = dxf_segments(save(doc, tmp_path / "circle_mm.dxf"), arc_tolerance=0.005)
    assert len(segs) == min_chords(2 * math.pi, 1.0, 0.005)  # 0.005 m, not 0.005 mm
    check_arc_chain(segs, (0.0, 0.0), 1.0, 0.005)


def test_dxf_mirrored_arc_follows_its_extrusion(tmp_path: Path) -> None:
    """An ARC with extrusion (0, 0, -1) is drawn in a mirrored OCS; the result is in WCS."""
    doc, msp = new_dxf(6)
    arc = msp.add_arc((2.0, 0.0), 1.0, 0.0, 90.0, dxfattribs={"extrusion": (0.0, 0.0, -1.0)})
    segs = dxf_segments(save(doc, tmp_path / "mirrored.dxf"))
    np.testing.assert_allclose(segs[0, 0], [-3.0, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(segs[-1, 1], [-2.0, 1.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(segs[0, 0], np.array(arc.start_point)[:2], rtol=0, atol=1e-12)
    check_arc_chain(segs, (-2.0, 0.0), 1.0, 0.01)


def test_dxf_mirrored_bulged_polylines_and_circle_follow_their_extrusion(tmp_path: Path) -> None:
    """Extrusion (0, 0, -1) maps OCS (x, y, z) to WCS (-x, y, -z): the vertices land mirrored and
    exactly, a counter-clockwise bulge turns clockwise, and the elevation leaves x, y alone."""
    doc, msp = new_dxf(6)
    mirrored = {"extrusion": (0.0, 0.0, -1.0)}
    # closed, elevation 2.5: a CCW semicircle (bulge 1) below the chord (0, 0)-(2, 0), then a 2 x 3 box
    lw = msp.add_lwpolyline([(0.0, 0.0, 1.0), (2.0, 0.0, 0.0), (2.0, 3.0, 0.0), (0.0, 3.0, 0.0)], format="xyb")
    lw.closed = True
    lw.dxf.extrusion, lw.dxf.elevation = mirrored["extrusion"], 2.5
    # open 2D POLYLINE: a line, then a clockwise semicircle (bulge -1) from (14, 0) to (14, 2) left of x = 14
    msp.add_polyline2d([(10.0, 0.0, 0.0), (14.0, 0.0, -1.0), (14.0, 2.0, 0.0)], format="xyb", dxfattribs=mirrored)
    msp.add_circle((3.0, 4.0, 1.0), 0.5, dxfattribs=mirrored)
    segs = dxf_segments(save(doc, tmp_path / "mirrored_polylines.dxf"), arc_tolerance=0.002)

    n = min_chords(math.pi, 1.0, 0.002)  # each semicircle
    assert len(segs) == (n + 3) + (1 + n) + min_chords(2 * math.pi, 0.5, 0.002)
    lw_segs, poly_segs, circle = segs[: n + 3], segs[n + 3 : 2 * n + 4], segs[2 * n + 4 :]

    bulge = lw_segs[:n]
    np.testing.assert_array_equal(bulge[0, 0], [0.0, 0.0])
    np.testing.assert_array_equal(bulge[-1, 1], [-2.0, 0.0])  # the vertex, exactly
    angles = check_arc_chain(bulge, (-1.0, 0.0), 1.0, 0.002)
    assert angles[-1] - angles[0] == pytest.approx(-math.pi, abs=1e-12)  # clockwise in WCS
    assert (bulge[:, :, 1] <= 1e-12).all() and bulge[n // 2, 0, 1] < -0.9  # still below the chord
    np.testing.assert_array_equal(lw_segs[n:], [[[-2, 0], [-2, 3]], [[-2, 3], [0, 3]], [[0, 3], [0, 0]]])

    np.testing.assert_array_equal(poly_segs[0], [[-10.0, 0.0], [-14.0, 0.0]])
    arc = poly_segs[1:]
    np.testing.assert_array_equal(arc[-1, 1], [-14.0, 2.0])
    angles = check_arc_chain(arc, (-14.0, 1.0), 1.0, 0.002)
    assert angles[-1] - angles[0] == pytest.approx(math.pi, abs=1e-12)  # counter-clockwise in WCS
    assert (arc[:, :, 0] >= -14.0 - 1e-12).all() and arc[n // 2, 0, 0] > -13.1  # right of x = -14

    np.testing.assert_array_equal(circle[-1, 1], circle[0, 0])
    np.testing.assert_allclose(circle[0, 0], [-3.5, 4.0], rtol=0, atol=1e-12)  # OCS angle 0 is WCS -x
    angles = check_arc_chain(circle, (-3.0, 4.0), 0.5, 0.002)
    assert angles[-1] - angles[0] == pytest.approx(-2 * math.pi, abs=1e-12)


def test_dxf_arc_of_equal_start_and_end_angles_is_a_full_circle(tmp_path: Path) -> None:
    """As AutoCAD draws it (ezdxf's own ARC.flattening draws nothing), and as 0 to 360 degrees."""
    doc, msp = new_dxf(6)
    msp.add_arc((1.0, 1.0), 2.0, 30.0, 30.0)
    msp.add_arc((1.0, 1.0), 2.0, 0.0, 360.0)
    segs = dxf_segments(save(doc, tmp_path / "full_arcs.dxf"))
    n = min_chords(2 * math.pi, 2.0, 0.01)
    assert len(segs) == 2 * n
    for circle in (segs[:n], segs[n:]):
        np.testing.assert_allclose(circle[0, 0], [3.0, 1.0], rtol=0, atol=1e-12)  # from angle 0
        np.testing.assert_array_equal(circle[-1, 1], circle[0, 0])
        angles = check_arc_chain(circle, (1.0, 1.0), 2.0, 0.01)
        assert angles[-1] - angles[0] == pytest.approx(2 * math.pi, abs=1e-12)


def test_dxf_bulge_between_coincident_vertices_keeps_the_chain_whole(tmp_path: Path) -> None:
    """A bulge on a zero-length edge is that point (ezdxf's virtual_entities drops the edge)."""
    doc, msp = new_dxf(6)
    msp.add_lwpolyline([(0.0, 0.0, 0.5), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0)], format="xyb")
    segs = dxf_segments(save(doc, tmp_path / "coincident.dxf"))
    np.testing.assert_array_equal(segs, [[[0, 0], [0, 0]], [[0, 0], [1, 0]], [[1, 0], [1, 1]]])


@pytest.mark.parametrize(
    ("units", "metres_per_unit"),
    [(1, 0.0254), (2, 0.3048), (5, 0.01), (6, 1.0), (0, 1.0), (10, 0.9144), (21, 1200 / 3937)],
)
def test_dxf_units_are_converted_to_metres(tmp_path: Path, units: int, metres_per_unit: float) -> None:
    doc, msp = new_dxf(units)
    msp.add_line((0.0, 0.0), (100.0, 50.0))
    msp.add_line((-12.0, 3.0), (7.0, -1.0))
    segs = dxf_segments(save(doc, tmp_path / f"units_{units}.dxf"))
    expected = np.array([[[0, 0], [100, 50]], [[-12, 3], [7, -1]]], dtype=np.float64) * metres_per_unit
    np.testing.assert_allclose(segs, expected, rtol=1e-15, atol=0)
    if units == 1:
        assert segs[0, 1].tolist() == pytest.approx([2.54, 1.27], abs=1e-12)
    if units == 2:
        assert segs[0, 1].tolist() == pytest.approx([30.48, 15.24], abs=1e-12)


def test_dxf_unknown_units_are_an_error(tmp_path: Path) -> None:
    doc, msp = new_dxf(99)
    msp.add_line((0.0, 0.0), (1.0, 0.0))
    path = save(doc, tmp_path / "odd_units.dxf")
    with pytest.raises(ValueError, match=r"unknown drawing units \$INSUNITS = 99") as info:
        dxf_segments(path)
    assert str(path) in str(info.value)


def test_dxf_missing_layer_lists_the_existing_ones(tmp_path: Path) -> None:
    path = room_with_furniture(tmp_path / "layered_room.dxf")
    with pytest.raises(ValueError, match="'doors'") as info:
        dxf_segments(path, layers=["WALLS", "doors"])
    message = str(info.value)
    assert str(path) in message
    assert "WALLS" in message and "FURNITURE" in message


def test_dxf_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="no_such_plan.dxf"):
        dxf_segments(tmp_path / "no_such_plan.dxf")


def test_dxf_without_wall_entities(tmp_path: Path) -> None:
    doc, msp = new_dxf(4)
    doc.layers.add("WALLS")
    msp.add_text("no walls here")
    msp.add_polyline3d([(0, 0, 0), (1, 1, 1)])
    msp.add_line((0, 0), (1000, 0), dxfattribs={"layer": "FURNITURE"})
    path = save(doc, tmp_path / "empty_plan.dxf")
    with pytest.raises(ValueError, match="no wall entities") as info:
        dxf_segments(path, layers=["WALLS"])
    assert str(path) in str(info.value) and "TEXT" in str(info.value)
    doc2, msp2 = new_dxf(4)
    msp2.add_text("only text")
    with pytest.raises(ValueError, match="no wall entities.*any layer"):
        dxf_segments(save(doc2, tmp_path / "text_only.dxf"))


def test_dxf_that_is_not_a_drawing(tmp_path: Path) -> None:
    path = tmp_path / "notes.dxf"
    path.write_text("this is a text file, not a drawing\n")
    with pytest.raises(ValueError) as info:
        dxf_segments(path)
    assert str(path) in str(info.value)


def test_dxf_argument_errors(tmp_path: Path) -> None:
    path = room_with_furniture(tmp_path / "room.dxf")
    with pytest.raises(ValueError, match="arc_tolerance"):
        dxf_segments(path, arc_tolerance=0.0)
    with pytest.raises(ValueError, match="layers is empty"):
        dxf_segments(path, layers=[])
    with pytest.raises(TypeError, match="layer names must be str"):
        dxf_segments(path, layers=[1])  # type: ignore[list-item]
    with pytest.raises(TypeError, match="layers must be"):
        dxf_segments(path, layers=3)  # type: ignore[arg-type]


def test_dxf_without_ezdxf_says_how_to_install_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = room_with_furniture(tmp_path / "room.dxf")
    for name in [m for m in sys.modules if m == "ezdxf" or m.startswith("ezdxf.")]:
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(ImportError) as info:
        dxf_segments(path)
    assert str(info.value) == EZDXF_MISSING


# --------------------------------------------------------------------------------------------------
# End to end: DXF -> segments -> points -> PlanMap -> localize
# --------------------------------------------------------------------------------------------------

# Inner faces of a 7 x 5 m room (metres) with a stub wall and a round column: what the laser sees.
INNER_FACES = np.array(
    [
        [[0.0, 0.0], [7.0, 0.0]],
        [[7.0, 0.0], [7.0, 5.0]],
        [[7.0, 5.0], [0.0, 5.0]],
        [[0.0, 5.0], [0.0, 0.0]],
        [[2.5, 5.0], [2.5, 3.4]],  # a stub partition from the top wall
    ]
)
COLUMN = ((5.2, 1.4), 0.25)
WALL = 0.2


def room_dxf(path: Path) -> Path:
    """The room in millimetres: inner and outer wall faces, the column, and furniture on its own layer."""
    doc, msp = new_dxf(4)
    walls = {"layer": "A-WALL"}
    for (x0, y0), (x1, y1) in INNER_FACES:
        msp.add_line((x0 * 1000, y0 * 1000), (x1 * 1000, y1 * 1000), dxfattribs=walls)
    outer = [(-WALL, -WALL), (7 + WALL, -WALL), (7 + WALL, 5 + WALL), (-WALL, 5 + WALL)]
    msp.add_lwpolyline([(x * 1000, y * 1000) for x, y in outer], close=True, dxfattribs=walls)
    (cx, cy), r = COLUMN
    msp.add_circle((cx * 1000, cy * 1000), r * 1000, dxfattribs=walls)
    msp.add_lwpolyline([(800, 800), (2000, 800), (2000, 1600), (800, 1600)], close=True, dxfattribs={"layer": "A-FURN"})
    return save(doc, path)


def simulate_scan(pose: tuple[float, float, float], beams: int = 720) -> Array:
    """Returns of a noise-free 360-degree LIDAR at `pose` off the true room, in the robot frame."""
    x, y, yaw = pose
    origin = np.array([x, y])
    angles = yaw + np.arange(beams) * (2 * math.pi / beams)
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    best = np.full(beams, np.inf)
    for a, b in INNER_FACES:  # ray-segment: origin + t d = a + u (b - a)
        e = b - a
        den = d[:, 0] * e[1] - d[:, 1] * e[0]
        w = a - origin
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[0] * e[1] - w[1] * e[0]) / den
            u = (w[0] * d[:, 1] - w[1] * d[:, 0]) / den
        hit = (np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
        best = np.where(hit & (t < best), t, best)
    (cx, cy), r = COLUMN
    oc = origin - np.array([cx, cy])
    bq = d @ oc
    disc = bq**2 - (oc @ oc - r * r)
    with np.errstate(invalid="ignore"):
        t = -bq - np.sqrt(disc)
    hit = (disc > 0) & (t > 0)
    best = np.where(hit & (t < best), t, best)
    assert np.isfinite(best).all()  # a closed room: every beam hits something
    world = origin + best[:, None] * d
    c, s = math.cos(yaw), math.sin(yaw)
    rel = world - origin
    return np.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], axis=1)


def test_dxf_plan_localizes_a_scan_end_to_end(tmp_path: Path) -> None:
    segments = dxf_segments(room_dxf(tmp_path / "room.dxf"), layers=["a-wall"])
    assert segments[:, :, 0].min() == pytest.approx(-WALL, abs=1e-9)
    assert segments[:, :, 1].max() == pytest.approx(5 + WALL, abs=1e-9)
    assert not ((segments > 0.75) & (segments < 2.05)).all(axis=(1, 2)).any()  # no furniture
    plan = planicp.PlanMap.from_points(sample_segments(segments, 0.02))

    true_pose = (3.4, 2.1, 0.6)
    scan = simulate_scan(true_pose)
    for heading in (0.25 * math.pi, 0.75 * math.pi, 1.25 * math.pi, 1.75 * math.pi):
        sign = 1.0 if heading < math.pi else -1.0
        guess = (
            true_pose[0] + 0.15 * math.cos(heading),
            true_pose[1] + 0.15 * math.sin(heading),
            true_pose[2] + sign * 3.0 * DEG,
        )
        result = planicp.localize(scan, plan, guess)
        x, y, yaw = result.pose
        assert result.converged
        assert math.hypot(x - true_pose[0], y - true_pose[1]) < 0.01
        assert abs(math.remainder(yaw - true_pose[2], 2 * math.pi)) < 0.2 * DEG
        assert result.inlier_ratio > 0.95
