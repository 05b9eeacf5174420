"""A PDF's scale from its legend: the areas listed beside colour swatches against the rooms the
page fills in those colours. The PDFs are written here as text, drawn at 1:200."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

import pdf_files

pytestmark = pytest.mark.skipif(importlib.util.find_spec("pdfminer") is None, reason="needs the pdf extra")

M_PER_PT = 0.0254 / 72 * 200  # 1:200
SQUARE_FOOT = 0.09290304


def pt(metres: float) -> float:
    return metres / M_PER_PT


def write_pdf(path: Path, content: str, size: tuple[int, int] = (900, 700)) -> Path:
    """A one-page PDF with `content` as its content stream and Helvetica as /F1."""
    return pdf_files.write_pdf(path, content, size=size)


def room(colour: str, x: float, y: float, w: float, h: float) -> str:
    """A room filled in `colour` (an "r g b" string) with black 1 pt walls around it; metres."""
    box = f"{pt(x):.4f} {pt(y):.4f} {pt(w):.4f} {pt(h):.4f} re"
    return f"{colour} rg {box} f 0 0 0 RG 1 w {box} S"


def entry(colour: str, y: float, text: str) -> str:
    """A legend line at page height `y` (points) with its swatch just left of it."""
    return f"{colour} rg 20 {y - 2:.1f} 20 10 re f BT /F1 8 Tf 45 {y:.1f} Td ({text}) Tj ET"


RED, GREEN, BLUE = "1 0 0", "0 0.6 0", "0 0 1"


def floor(
    *,
    blue_area: float = 10.0,
    entries: tuple[str, ...] = ("red", "green", "blue"),
    drawn: tuple[float, float, float] = (1.0, 1.0, 1.0),
) -> str:
    """Offices (red: two rooms, 1,000 sq ft in all), a lab (green, 24 m²) and a store (blue, 10 m²
    in the legend, `blue_area` m² drawn), from x = 10 m on the page; the legend at the left. Each
    colour's rooms are drawn `drawn` times their true size (red, green, blue)."""
    office = 1000 * SQUARE_FOOT  # m², in two rooms 5 m deep
    r, g, b = drawn
    parts = [
        room(RED, 10, 10, r * office / 10, r * 5),
        room(RED, 10, 15, r * office / 10, r * 5),
        room(GREEN, 10 + office / 10, 10, g * 6, g * 4),
        room(BLUE, 10 + office / 10, 14, b * blue_area / 4, b * 4),
    ]
    lines = {
        "red": entry(RED, 100, "270410 - OFFICES, 1,000 USF"),
        "green": entry(GREEN, 80, "LAB 24 m\\262"),  # m² (WinAnsiEncoding: octal 262 is ²)
        "blue": entry(BLUE, 60, "STORE, 10 m2"),
    }
    return "\n".join(parts + [lines[name] for name in entries])


def test_scale_from_the_legend_areas_and_the_filled_rooms(tmp_path: Path) -> None:
    from planicp.plans.legend_scale import legend_scale

    found = legend_scale(write_pdf(tmp_path / "floor.pdf", floor()))
    assert found is not None
    assert found.metres_per_point == pytest.approx(M_PER_PT, rel=1e-4)
    assert found.agreeing == 3
    by_text = {e.text: e for e in found.entries}
    office = by_text["270410 - OFFICES, 1,000 USF"]
    assert office.rooms == 2 and office.area_m2 == pytest.approx(92.90304)
    assert office.colour == pytest.approx((1.0, 0.0, 0.0))
    assert by_text["LAB 24 m²"].area_m2 == 24.0 and by_text["STORE, 10 m2"].area_m2 == 10.0


def test_rooms_drawn_a_little_off_give_the_round_print_scale_they_allow(tmp_path: Path) -> None:
    from planicp.plans.legend_scale import legend_scale

    # The rooms drawn 0.2 % to 0.4 % larger than the areas stated (outlines a stroke's width out):
    # the median is 0.3 % small, and 1:200, the one round scale within half a percent of every
    # entry, is taken, exactly.
    found = legend_scale(write_pdf(tmp_path / "floor.pdf", floor(drawn=(1.002, 1.003, 1.004))))
    assert found is not None and found.agreeing == 3
    assert found.median == pytest.approx(M_PER_PT / 1.003, rel=2e-4)
    assert found.metres_per_point == pytest.approx(M_PER_PT, rel=1e-9)
    assert found.round_scale == "1:200"
    assert "the one round print scale they allow, 1:200, taken" in found.describe()
    # Drawn at 1:213 (no round scale within half a percent): the median stands.
    odd = legend_scale(write_pdf(tmp_path / "odd.pdf", floor(drawn=(200 / 213,) * 3)))
    assert odd is not None and odd.round_scale == ""
    assert odd.metres_per_point == pytest.approx(M_PER_PT * 213 / 200, rel=1e-4)


def test_round_print_scales_of_each_family() -> None:
    from planicp.plans.print_scale import round_print_scale

    assert round_print_scale(99.0, 101.0, metric=True, imperial=False) == (100.0, "1:100")
    assert round_print_scale(248.0, 252.0, metric=True, imperial=False) == (250.0, "1:250")
    assert round_print_scale(95.5, 96.5, metric=False, imperial=True) == (96.0, '1/8" = 1\'-0"')
    assert round_print_scale(286.0, 290.0, metric=False, imperial=True) == (288.0, "1\" = 24'")
    assert round_print_scale(286.0, 290.0, metric=True, imperial=False) is None  # no metric scale there
    assert round_print_scale(270.0, 310.0, metric=False, imperial=True) is None  # 23', 24', 25': which?
    assert round_print_scale(101.0, 101.0, metric=True, imperial=False) is None
    assert round_print_scale(float("nan"), 100.0, metric=True, imperial=True) is None


def test_a_disagreeing_entry_is_outvoted_and_named(tmp_path: Path) -> None:
    from planicp.plans.legend_scale import legend_scale

    found = legend_scale(write_pdf(tmp_path / "floor.pdf", floor(blue_area=12.0)))
    assert found is not None and found.agreeing == 2
    assert found.metres_per_point == pytest.approx(M_PER_PT, rel=1e-4)
    # The store drawn 12 m² for 10 stated: its scale is sqrt(10 / 12) of the others', -8.7 %.
    assert "disagreeing: 'STORE, 10 m2' (-8.7%)" in found.describe()


def test_no_scale_from_one_entry_or_from_entries_that_disagree(tmp_path: Path) -> None:
    from planicp.plans.legend_scale import legend_scale
    from planicp.plans.pdf_plan import pdf_walls

    assert legend_scale(write_pdf(tmp_path / "one.pdf", floor(entries=("red",)))) is None
    two = write_pdf(tmp_path / "two.pdf", floor(blue_area=12.0, entries=("red", "blue")))
    assert legend_scale(two) is None
    with pytest.raises(ValueError, match=r"states no print scale in its text \(nor areas in a legend.*--scale"):
        pdf_walls(two)


def test_pdf_walls_take_the_legend_scale_when_the_text_states_none(tmp_path: Path) -> None:
    from planicp.plans.pdf_plan import pdf_walls

    path = write_pdf(tmp_path / "floor.pdf", floor())
    walls = pdf_walls(path)
    assert walls.metres_per_point == pytest.approx(M_PER_PT, rel=1e-4)
    assert walls.scale_source.startswith("the legend's areas against the rooms filled in their colours: 3 of 3")
    assert "1:200 at print size" in walls.scale_source
    # A scale given still wins.
    assert pdf_walls(path, scale="1:100").metres_per_point == pytest.approx(M_PER_PT / 2)
