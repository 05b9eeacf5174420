"""The scale from the words in a drawing's rooms: dimension and area labels, parsed with real units."""

from __future__ import annotations

import math

import pytest

from planicp.plans.scale_text import (
    FOOT,
    INCH,
    LabelScale,
    area_scale,
    combined_scale,
    dimension_scale,
    parse_area,
    parse_dimensions,
)


@pytest.mark.parametrize(
    ("text", "metres"),
    [
        ("322 X 347", (3.22, 3.47)),  # the Swedish apartment: centimetres
        ("322x347", (3.22, 3.47)),
        ("3,22 x 3,47", (3.22, 3.47)),  # a decimal comma: metres
        ("3.22 × 3.47 m", (3.22, 3.47)),
        ("3220 mm x 3470 mm", (3.22, 3.47)),
        ("11'7\" x 15'7\"", (11 * FOOT + 7 * INCH, 15 * FOOT + 7 * INCH)),  # the US apartment
        ("11' 7\" x 15' 7\"", (11 * FOOT + 7 * INCH, 15 * FOOT + 7 * INCH)),
        ("11'-7\" X 15'-7\"", (11 * FOOT + 7 * INCH, 15 * FOOT + 7 * INCH)),
        ("5'4\" x 20'4\"", (5 * FOOT + 4 * INCH, 20 * FOOT + 4 * INCH)),  # the CubiCasa room of docs/plans.md
        ("12' x 10'", (12 * FOOT, 10 * FOOT)),
        ("11 ft 7 in by 15 ft", (11 * FOOT + 7 * INCH, 15 * FOOT)),
        ("10'6 1/2\" x 9'", (10 * FOOT + 6.5 * INCH, 9 * FOOT)),
    ],
)
def test_dimension_labels_in_metres(text: str, metres: tuple[float, float]) -> None:
    found = parse_dimensions(text)
    assert found is not None, text
    assert found == pytest.approx(metres, abs=1e-9)


def test_11_foot_7_is_3_531_metres() -> None:
    found = parse_dimensions("11'7\" x 15'7\"")
    assert found is not None
    assert found[0] == pytest.approx(3.5306)
    assert found[1] == pytest.approx(4.7498)


@pytest.mark.parametrize("text", ["KITCHEN", "12 x 34", "1:100", "322 X", "x 347", "3 x 4.5.6", "0 X 347", "2024"])
def test_words_that_are_no_dimension_label(text: str) -> None:
    assert parse_dimensions(text) is None, text


@pytest.mark.parametrize(
    ("text", "square_metres"),
    [
        ("13 m²", 13.0),
        ("Bedroom 13 m2", 13.0),
        ("13,5 m²", 13.5),
        ("13.5 sqm", 13.5),
        ("13.5 m^2", 13.5),
        ("140 sq ft", 140 * FOOT * FOOT),
        ("140 ft²", 140 * FOOT * FOOT),
        ("140 SF", 140 * FOOT * FOOT),
    ],
)
def test_area_labels_in_square_metres(text: str, square_metres: float) -> None:
    assert parse_area(text) == pytest.approx(square_metres)


@pytest.mark.parametrize("text", ["13 m", "LIVING", "0 m²", "322 X 347"])
def test_words_that_state_no_area(text: str) -> None:
    assert parse_area(text) is None


def test_140_square_feet_are_13_square_metres() -> None:
    assert parse_area("140 sq ft") == pytest.approx(13.006, abs=1e-3)


def test_a_room_drawn_at_2_cm_per_pixel_gives_its_scale() -> None:
    # 322 x 347 cm drawn as 161 x 173.5 pixels, in either order: 0.02 m per pixel.
    found = dimension_scale("322 X 347", (173.5, 161.0))
    assert found is not None
    assert found.metres_per_unit == pytest.approx(0.02)
    assert found.spread == pytest.approx(0.0, abs=1e-12)
    assert "322 X 347" in found.source
    area = area_scale("13 m²", 13.0 / 0.02**2)
    assert area is not None and area.metres_per_unit == pytest.approx(0.02)
    assert dimension_scale("KITCHEN", (10.0, 10.0)) is None
    assert dimension_scale("322 X 347", (0.0, 10.0)) is None
    assert area_scale("13 m²", 0.0) is None


def test_labels_combine_and_a_misread_one_is_left_out() -> None:
    # A PDF in points (1/72 inch) at 1:100: 0.0254 / 72 * 100 m per point.
    per_point = INCH / 72.0 * 100.0
    labels = [
        dimension_scale("322 X 347", (3.22 / per_point, 3.47 / per_point)),
        dimension_scale("11'7\" x 15'7\"", (3.5306 / per_point * 1.004, 4.7498 / per_point * 0.998)),
        area_scale("13 m²", 13.0 / per_point**2),
        area_scale("31 m²", 13.0 / per_point**2),  # read from the wrong room
    ]
    found = combined_scale([s for s in labels if s is not None])
    assert found is not None
    assert found.metres_per_unit == pytest.approx(per_point, rel=0.002)
    assert found.labels == 3
    assert "1 disagreeing left out" in found.source
    assert found.spread < 0.01
    assert combined_scale([]) is None
    one = combined_scale([LabelScale(0.02, 0.0, 1, "x")])
    assert one is not None and one.spread == 0.0 and math.isclose(one.metres_per_unit, 0.02)
