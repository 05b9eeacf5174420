"""Drawing formats as plans (issue 22): vector PDF, SVG, IFC, DXF layers and blocks, EXIF photos, and
the refusals that name the missing extra. Every drawing is made here, by hand: a PDF and an IFC file
written as text, an SVG as text, DXF with ezdxf, a photo with Pillow."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from pdf_files import write_pdf
from planicp import PlanMap
from planicp.cli import main as cli_main
from planicp.plans import plan_formats
from planicp.plans.plan_loading import load_plan, read_plan_file
from planicp.plans.print_scale import find_print_scale, parse_print_scale
from planicp.plans.region_outline import region_outline

HAS_PDF = all(importlib.util.find_spec(m) is not None for m in ("pdfminer", "pypdfium2"))
HAS_SVG = importlib.util.find_spec("svgelements") is not None
HAS_DXF = importlib.util.find_spec("ezdxf") is not None
needs_pdf = pytest.mark.skipif(not HAS_PDF, reason="needs the pdf extra (pdfminer.six, pypdfium2)")
needs_svg = pytest.mark.skipif(not HAS_SVG, reason="needs the svg extra (svgelements)")
needs_dxf = pytest.mark.skipif(not HAS_DXF, reason="needs the cad extra (ezdxf)")


def distance_to_segments(points: NDArray[np.float64], segments: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance from each point to the nearest of `segments` (M, 2, 2), metres."""
    a, b = segments[:, 0][None], segments[:, 1][None]
    p = points[:, None]
    d = b - a
    t = np.clip(((p - a) * d).sum(axis=2) / np.maximum((d * d).sum(axis=2), 1e-300), 0.0, 1.0)
    nearest = a + t[..., None] * d
    return np.asarray(np.hypot(*(p - nearest).transpose(2, 0, 1)).min(axis=1))


def rectangle(x0: float, y0: float, x1: float, y1: float) -> NDArray[np.float64]:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


def outline(x0: float, y0: float, x1: float, y1: float) -> NDArray[np.float64]:
    r = rectangle(x0, y0, x1, y1)
    return np.stack([r, np.roll(r, -1, axis=0)], axis=1)


# --------------------------------------------------------------------------------------------------
# Print scales and the outline of a region
# --------------------------------------------------------------------------------------------------


def test_print_scales_as_written_on_drawings() -> None:
    assert parse_print_scale("1:100") == 100.0
    assert parse_print_scale(50) == 50.0
    assert parse_print_scale("1\"=24'") == pytest.approx(288.0)
    assert parse_print_scale('1/8" = 1\'-0"') == pytest.approx(96.0)
    assert parse_print_scale("10 mm = 1 m") == pytest.approx(100.0)
    assert find_print_scale('PLAN 3rd FLOOR   SCALE: 1/4" = 1\'-0"')[0] == pytest.approx(48.0)  # type: ignore[index]
    assert find_print_scale("Grundriss M 1:50") == (50.0, "1:50")
    assert find_print_scale("room 3102, 12:30") is None
    with pytest.raises(ValueError, match="not understood.*'1:100'"):
        parse_print_scale("large")
    with pytest.raises(ValueError, match="not positive"):
        parse_print_scale(0)


def test_region_outline_unions_walls_and_opens_doors() -> None:
    # Two walls meeting in an L (overlapping at the corner), a door through the long one.
    walls = [rectangle(0, 0, 6, 0.2), rectangle(0, 0, 0.2, 4)]
    door = rectangle(2, -0.5, 3, 0.7)
    segs = region_outline(walls, [door])
    points = np.concatenate([segs[:, 0], segs[:, 1]])
    # Every piece is on the region's true boundary, none inside the corner or across the door.
    mids = segs.mean(axis=1)
    assert not ((mids[:, 0] > 0.01) & (mids[:, 0] < 0.19) & (mids[:, 1] > 0.01) & (mids[:, 1] < 0.19)).any()
    assert not ((mids[:, 0] > 2 + 1e-9) & (mids[:, 0] < 3 - 1e-9)).any()  # the door is a gap
    assert np.isclose(points[:, 0], 2.0).any() and np.isclose(points[:, 0], 3.0).any()  # its jambs
    total = float(np.hypot(*(segs[:, 1] - segs[:, 0]).T).sum())
    # Outer L: 6 + 0.2 + 5.8 + 3.8 + 0.2 + 4 = 20 m, less the door's 2 x 1 m, plus its jambs 2 x 0.2 m.
    assert total == pytest.approx(20.0 - 2.0 + 0.4, abs=1e-9)


# --------------------------------------------------------------------------------------------------
# PDF
# --------------------------------------------------------------------------------------------------

PT = 0.0254 / 72.0  # metres of paper per point
RATIO = 100.0  # the drawings' print scale, 1:100
M = 1.0 / (PT * RATIO)  # points per metre of building
OFFSET = 50.0  # the room's lower-left corner on the page, points
ROOM = (10.0, 8.0)  # metres


def room_walls_m() -> NDArray[np.float64]:
    """The true walls of the PDF room, metres on the building: its outline and a partition at
    x = 5 m with a door from y = 4 to 5 m."""
    x0 = y0 = OFFSET / M
    w, h = ROOM
    partition = np.array([[[x0 + 5, y0], [x0 + 5, y0 + 4]], [[x0 + 5, y0 + 5], [x0 + 5, y0 + h]]])
    return np.concatenate([outline(x0, y0, x0 + w, y0 + h), partition])


def room_content(*, walls: str = "0 0 0 RG 2 w", scale_text: str = "SCALE 1:100") -> str:
    """Walls (black, 2 pt), thin black dimension line and a door swing, blue hatching (longer than
    the walls), and the scale in words."""
    x0, w, h = OFFSET, ROOM[0] * M, ROOM[1] * M
    xp = x0 + 5 * M
    ops = [
        walls,
        f"{x0:.4f} {x0:.4f} {w:.4f} {h:.4f} re S",
        f"{xp:.4f} {x0:.4f} m {xp:.4f} {x0 + 4 * M:.4f} l S",
        f"{xp:.4f} {x0 + 5 * M:.4f} m {xp:.4f} {x0 + h:.4f} l S",
        "0 0 0 RG 0.25 w",  # a dimension line under the room and a door swing: short thin black
        f"{x0:.4f} {x0 - 20:.4f} m {x0 + w:.4f} {x0 - 20:.4f} l S",
        f"{xp:.4f} {x0 + 4 * M:.4f} m {xp + M:.4f} {x0 + 4 * M:.4f} {xp + M:.4f} {x0 + 5 * M:.4f} "
        f"{xp:.4f} {x0 + 5 * M:.4f} c S",
        "0 0 1 RG 0.5 w",  # hatching: blue, and in all longer than the walls
    ]
    for i in range(60):
        y = x0 + 5 + i * (h - 10) / 60
        ops.append(f"{x0 + 5:.4f} {y:.4f} m {x0 + w - 5:.4f} {y + 3:.4f} l S")
    ops.append(f"BT /F1 8 Tf {x0 + 10:.2f} {x0 + 10:.2f} Td ({scale_text}) Tj ET")
    return "\n".join(ops)


@needs_pdf
def test_pdf_walls_are_the_longest_dark_class_in_metres_at_the_stated_scale(tmp_path: Path) -> None:
    from planicp.plans.pdf_plan import pdf_walls

    path = write_pdf(tmp_path / "room.pdf", room_content())
    walls = pdf_walls(path)
    assert walls.scale_source.startswith("print scale stated in the drawing: '1:100'")
    assert walls.metres_per_point == pytest.approx(PT * RATIO)
    (kept,) = walls.wall_classes
    assert kept.colour == (0.0, 0.0, 0.0) and kept.width == pytest.approx(2.0)
    assert walls.classes[0].colour == (0.0, 0.0, 1.0)  # the hatching is longest, but not dark
    truth = room_walls_m()
    ends = walls.segments.reshape(-1, 2)
    assert distance_to_segments(ends, truth).max() < 1e-5  # no hatching, dimension line or swing
    lo, hi = ends.min(axis=0), ends.max(axis=0)
    np.testing.assert_allclose(hi - lo, ROOM, atol=1e-6)
    # Every wall is there: the points sampled from the truth are all near the segments read.
    plan = load_plan(path, spacing=0.05)
    assert distance_to_segments(plan.points, truth).max() < 1e-5
    assert distance_to_segments(PlanMap.from_segments(truth, 0.05).points, walls.segments).max() < 1e-5
    # The door from y = 4 to 5 m in the partition is a gap.
    x0 = OFFSET / M
    door = (
        (np.abs(plan.points[:, 0] - (x0 + 5)) < 1e-6)
        & (plan.points[:, 1] > x0 + 4.01)
        & (plan.points[:, 1] < x0 + 4.99)
    )
    assert not door.any()


@needs_pdf
def test_pdf_black_hatching_longer_than_the_walls_is_not_taken_for_them(tmp_path: Path) -> None:
    from planicp.plans.pdf_plan import pdf_walls

    # Black hatching (0.3 pt), three times as long as the walls: single strokes, meeting nothing.
    content = room_content().replace("0 0 1 RG 0.5 w", "0 0 0 RG 0.3 w")
    walls = pdf_walls(write_pdf(tmp_path / "hatched.pdf", content))
    assert walls.classes[0].length > 3 * walls.wall_classes[0].length
    # The room's outline is closed; the partition's two strokes meet it mid-side, not end to end.
    assert walls.classes[0].connected == 0.0 and walls.wall_classes[0].connected == pytest.approx(36 * M)
    assert walls.wall_classes[0].width == pytest.approx(2.0)
    assert distance_to_segments(walls.segments.reshape(-1, 2), room_walls_m()).max() < 1e-5


@needs_pdf
def test_pdf_scale_given_colours_widths_and_layers(tmp_path: Path) -> None:
    from planicp.plans.pdf_plan import pdf_walls

    path = write_pdf(tmp_path / "room.pdf", room_content(scale_text="Office floor"))
    with pytest.raises(ValueError, match=r"states no print scale.*scale='1:100'.*--scale"):
        pdf_walls(path)
    at_50 = pdf_walls(path, scale="1:50")
    np.testing.assert_allclose(np.ptp(at_50.segments.reshape(-1, 2), axis=0), np.array(ROOM) / 2, atol=1e-6)
    blue = pdf_walls(path, scale=100, colours=["#0000ff"])
    assert blue.wall_classes[0].colour == (0.0, 0.0, 1.0) and len(blue.segments) == 60
    thin = pdf_walls(path, scale=100, widths=[0.25])
    assert len(thin.wall_classes) == 1 and thin.wall_classes[0].width == pytest.approx(0.25)
    with pytest.raises(ValueError, match="no path matches.*stroke #000000 2 pt"):
        pdf_walls(path, scale=100, colours=["red"])
    # Layers: walls and furniture drawn alike, on two optional content groups.
    x0 = OFFSET
    walls_first, others = room_content(scale_text="1:100").split("0 0 0 RG 0.25 w")
    content = (
        f"/OC /OC0 BDC\n{walls_first}\nEMC\n/OC /OC1 BDC 0 0 0 RG 2 w {x0 + 30} {x0 + 30} 40 20 re S EMC\n"
        f"0 0 0 RG 0.25 w {others}"
    )
    layered = write_pdf(tmp_path / "layers.pdf", content, layers=("A-WALL", "FURNITURE"))
    everything = pdf_walls(layered)
    assert set(everything.layers) == {"A-WALL", "FURNITURE"}
    only_walls = pdf_walls(layered, layers=["a-wall"])
    assert len(everything.segments) == len(only_walls.segments) + 4 == 10  # the dark class on both layers
    assert distance_to_segments(only_walls.segments.reshape(-1, 2), room_walls_m()).max() < 1e-5
    with pytest.raises(ValueError, match="no layer 'walls'; its layers are: A-WALL, FURNITURE"):
        pdf_walls(layered, layers=["walls"])


@needs_pdf
def test_pdf_raster_fallback_renders_the_page_in_the_same_frame(tmp_path: Path) -> None:
    path = write_pdf(tmp_path / "room.pdf", room_content())
    loaded = read_plan_file(path, raster=0.1, cache=False, walls="all-dark")  # the rendering's frame: every line
    assert any("rendered at 0.1 m per pixel" in note for note in loaded.notes)
    xmin, ymin, xmax, ymax = loaded.plan.extent
    x0 = OFFSET / M
    # All the line work is wall in the image (the dimension line 20 pt below the room too). The
    # walls are 2 pt (7 cm) thick and the pixels 10 cm: the faces within two pixels.
    assert (xmin, ymin) == pytest.approx((x0, (OFFSET - 20) / M), abs=0.2)
    assert (xmax, ymax) == pytest.approx((x0 + ROOM[0], x0 + ROOM[1]), abs=0.2)
    # A page with no dark line work (a scan, or a drawing all in colour) is rendered unasked.
    blue = write_pdf(
        tmp_path / "blue.pdf",
        "0 0 1 RG 3 w 20 20 160 120 re S BT /F1 8 Tf 30 30 Td (SCALE 1:25) Tj ET",
        size=(200, 160),
    )
    from planicp.plans.pdf_plan import pdf_walls

    with pytest.raises(ValueError, match="no dark line work.*raster=True"):
        pdf_walls(blue)
    scanned = read_plan_file(blue, cache=False)
    assert scanned.notes[1] == "page 1 rendered at 0.025 m per pixel and read as an image (it has no dark line work)"
    xmin, ymin, xmax, ymax = scanned.plan.extent
    # The rectangle: 160 x 120 pt at 1:25 (1.41 x 1.06 m) to the outer faces of its 3 pt line, within
    # two pixels.
    line = 3 * PT * 25
    assert (xmax - xmin, ymax - ymin) == pytest.approx((160 * PT * 25 + line, 120 * PT * 25 + line), abs=0.05)


@needs_pdf
def test_pdf_page_rotation_is_applied_alike_to_vectors_and_raster(tmp_path: Path) -> None:
    from planicp.plans.pdf_plan import pdf_walls

    # An L of two walls on a page turned a quarter (/Rotate 90): shown, the page is 320 wide, 400 high.
    content = "0 0 0 RG 4 w 100 100 m 300 100 l 300 250 l S BT /F1 8 Tf 150 150 Td (1:100) Tj ET"
    path = write_pdf(tmp_path / "turned.pdf", content, rotate=90)
    ends = pdf_walls(path, scale=100).segments.reshape(-1, 2) / (PT * RATIO)  # back to points
    # Turned clockwise for display: (x, y) -> (y, 400 - x).
    np.testing.assert_allclose(np.sort(ends, axis=0)[[0, -1]], [[100, 100], [250, 300]], atol=1e-6)
    raster = read_plan_file(path, scale=100, raster=0.05, cache=False, walls="all-dark").plan
    lo, hi = np.array(raster.extent[:2]), np.array(raster.extent[2:])
    np.testing.assert_allclose(lo / (PT * RATIO), [100, 100], atol=3.5)  # within a pixel and the line's half width
    np.testing.assert_allclose(hi / (PT * RATIO), [250, 300], atol=3.5)


@needs_pdf
def test_pdf_cli_reports_scale_and_classes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write_pdf(tmp_path / "room.pdf", room_content())
    assert cli_main(["plan", str(path), "--list-layers"]) == 0
    listing = capsys.readouterr().out
    assert "stroke #000000 2 pt" in listing and "<- walls by default" in listing
    assert cli_main(["plan", str(path), "--out", str(tmp_path / "out"), "--spacing", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "scale: print scale stated in the drawing: '1:100'" in out
    assert "walls: 6 segments from stroke #000000 2 pt" in out and "dropped: 2 other stroke classes" in out
    assert "(10.00 x 8.00 m)" in out


# --------------------------------------------------------------------------------------------------
# SVG
# --------------------------------------------------------------------------------------------------

SVG_ROOM = """<?xml version="1.0"?>
<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
     width="1000" height="800" viewBox="0 0 1000 800">
  <g inkscape:groupmode="layer" inkscape:label="Walls" transform="translate(100,100)">
    <g class="Wall External" fill="#000000" stroke="#000000" style="stroke-width: 0.2">
      <polygon points="0,0 600,0 600,20 0,20"/>
      <polygon points="0,380 600,380 600,400 0,400"/>
      <g class="Door Swing"><polygon points="200,380 290,380 290,400 200,400" fill="#ffffff"/>
        <path d="M200,380 q90,0 90,-90 l-90,0Z" fill="none"/></g>
    </g>
    <g class="Wall"><rect x="0" y="0" width="20" height="400" fill="#000"/>
      <rect x="580" y="0" width="20" height="400" fill="#000"/></g>
  </g>
  <g inkscape:groupmode="layer" inkscape:label="Furniture">
    <g class="Table"><rect x="300" y="250" width="100" height="50" fill="#000"/></g>
  </g>
  <text x="150" y="300">Office</text>
</svg>
"""
RES = 0.01  # metres per SVG pixel


@needs_svg
def test_svg_wall_class_outlined_with_the_door_open(tmp_path: Path) -> None:
    from planicp.plans.svg_plan import svg_walls

    path = tmp_path / "room.svg"
    path.write_text(SVG_ROOM)
    walls = svg_walls(path, resolution=RES)
    assert walls.shapes == (4, 7) and "class or id 'wall'" in walls.selected
    # The room: x 100..700 px, y 100..500 px (y down) -> x 1..7 m, y 3..7 m (y up).
    segs = walls.segments
    ends = segs.reshape(-1, 2)
    np.testing.assert_allclose(ends.min(axis=0), (1.0, 3.0), atol=1e-9)
    np.testing.assert_allclose(ends.max(axis=0), (7.0, 7.0), atol=1e-9)
    truth = np.concatenate(
        [
            outline(1.0, 3.0, 7.0, 7.0),
            outline(1.2, 3.2, 6.8, 6.8),
            np.array([[[3.0, 3.0], [3.0, 3.2]], [[3.9, 3.0], [3.9, 3.2]]]),  # the door's jambs
        ]
    )
    plan = PlanMap.from_segments(segs, 0.02)
    assert distance_to_segments(plan.points, truth).max() < 1e-9
    door = (plan.points[:, 0] > 3.01) & (plan.points[:, 0] < 3.89) & (plan.points[:, 1] < 3.21)
    assert not door.any()  # the door is a gap
    assert np.isclose(plan.points[:, 0], 3.0).sum() >= 5  # its jamb
    # Picking by layer or class; the scale from a print scale instead.
    table = svg_walls(path, resolution=RES, select="table")
    np.testing.assert_allclose(np.ptp(table.segments.reshape(-1, 2), axis=0), (1.0, 0.5), atol=1e-9)
    assert svg_walls(path, resolution=RES, select=["furniture"]).shapes == (1, 7)
    at_50 = svg_walls(path, scale="1:50")
    assert at_50.metres_per_pixel == pytest.approx(0.0254 / 96 * 50)
    with pytest.raises(ValueError, match="no shape matches class, id or layer sofa; its classes: .*wall"):
        svg_walls(path, resolution=RES, select="sofa")
    with pytest.raises(ValueError, match=r"give its scale: resolution=.*--resolution.*scale=.*--scale.*room label"):
        svg_walls(path)  # its only text, "Office", states no size


@needs_svg
def test_svg_without_a_scale_takes_it_from_a_room_label_hidden_or_not(tmp_path: Path) -> None:
    from planicp.plans.svg_plan import svg_text, svg_walls

    # The room is 560 x 360 px inside its walls, 5.60 x 3.60 m at RES; its door (0.9 m) opens
    # to the paper. The label is placed by its group's transform and hidden, as CubiCasa's are.
    label = '<g transform="translate(300,250)" style="display: none"><text x="0" y="0">5,60 x 3,60</text></g>'
    path = tmp_path / "labelled.svg"
    path.write_text(SVG_ROOM.replace("</svg>", label + "\n</svg>"))
    texts = {t.text: t for t in svg_text(path)}
    assert set(texts) == {"Office", "5,60 x 3,60"}
    assert 300 < texts["5,60 x 3,60"].x < 400 and 230 < texts["5,60 x 3,60"].y < 250
    walls = svg_walls(path)
    assert walls.metres_per_pixel == pytest.approx(RES, rel=0.02)
    assert walls.notes[0].startswith("scale: room labels: 1 room label agrees (room dimensions '5,60 x 3,60'")
    np.testing.assert_allclose(np.ptp(walls.segments.reshape(-1, 2), axis=0), (6.0, 4.0), rtol=0.02)


@needs_svg
def test_svg_without_names_takes_the_longest_dark_strokes(tmp_path: Path) -> None:
    from planicp.plans.svg_plan import svg_walls

    path = tmp_path / "lines.svg"
    path.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" width="500" height="500">'
        '<path d="M 10 10 H 410 V 310 H 10 Z" stroke="black" stroke-width="4" fill="none"/>'
        '<line x1="10" y1="400" x2="410" y2="400" stroke="#333" stroke-width="0.5"/>'
        '<polyline points="20,20 300,290 20,290" stroke="#00f" stroke-width="4" fill="none"/>'
        '<circle cx="200" cy="150" r="30" stroke="#888" fill="none"/></svg>'
    )
    walls = svg_walls(path, resolution=0.01)
    assert walls.selected == "the longest dark colour class (stroke #000000 4 px)"
    np.testing.assert_allclose(walls.segments.reshape(-1, 2).min(axis=0), (0.1, 1.9), atol=1e-9)
    np.testing.assert_allclose(walls.segments.reshape(-1, 2).max(axis=0), (4.1, 4.9), atol=1e-9)
    assert len(walls.segments) == 4


# --------------------------------------------------------------------------------------------------
# IFC
# --------------------------------------------------------------------------------------------------


def ifc_house() -> str:
    """An IFC4 model in millimetres: a 6 x 4 m room of four 200 mm walls on storey 'Ground'
    (walls placed by their start and direction, rectangles overlapping at the corners), a door
    opening 2.0-2.9 m along the south wall, 2.1 m high, cut as ArchiCAD does (a horizontal
    extrusion through the wall); and a storey 'Upper' at 3 m with one wall."""
    lines = [
        "#1=IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.);",
        "#2=IFCUNITASSIGNMENT((#1));",
        "#3=IFCPROJECT('p',$,'House',$,$,$,$,$,#2);",
        "#10=IFCCARTESIANPOINT((0.,0.,0.));",
        "#11=IFCDIRECTION((0.,0.,1.));",
        "#12=IFCDIRECTION((1.,0.,0.));",
        "#13=IFCAXIS2PLACEMENT3D(#10,#11,#12);",
        "#14=IFCLOCALPLACEMENT($,#13);",
        "#20=IFCBUILDINGSTOREY('s1',$,'Ground',$,$,#14,$,$,.ELEMENT.,0.);",
        "#21=IFCCARTESIANPOINT((0.,0.,3000.));",
        "#22=IFCAXIS2PLACEMENT3D(#21,#11,#12);",
        "#23=IFCLOCALPLACEMENT(#14,#22);",
        "#24=IFCBUILDINGSTOREY('s2',$,'Upper',$,$,#23,$,$,.ELEMENT.,3000.);",
        "#30=IFCCARTESIANPOINT((0.,0.));",
        "#31=IFCDIRECTION((1.,0.));",
    ]
    walls = [((0, 0), (6000, 0)), ((6000, 0), (6000, 4000)), ((6000, 4000), (0, 4000)), ((0, 4000), (0, 0))]
    ids = []
    n = 100
    for (x0, y0), (x1, y1) in walls + [((0, 0), (3000, 0))]:
        length = math.hypot(x1 - x0, y1 - y0)
        dx, dy = (x1 - x0) / length, (y1 - y0) / length
        storey_placement = "#14" if len(ids) < 4 else "#23"
        lines += [
            f"#{n}=IFCCARTESIANPOINT(({x0:.1f},{y0:.1f},0.));",
            f"#{n + 1}=IFCDIRECTION(({dx:.1f},{dy:.1f},0.));",
            f"#{n + 2}=IFCAXIS2PLACEMENT3D(#{n},#11,#{n + 1});",
            f"#{n + 3}=IFCLOCALPLACEMENT({storey_placement},#{n + 2});",
            f"#{n + 4}=IFCCARTESIANPOINT(({length / 2:.1f},0.));",
            f"#{n + 5}=IFCAXIS2PLACEMENT2D(#{n + 4},#31);",
            f"#{n + 6}=IFCRECTANGLEPROFILEDEF(.AREA.,$,#{n + 5},{length + 200:.1f},200.);",
            f"#{n + 7}=IFCEXTRUDEDAREASOLID(#{n + 6},#13,#11,2500.);",
            f"#{n + 8}=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(#{n + 7}));",
            f"#{n + 9}=IFCPRODUCTDEFINITIONSHAPE($,$,(#{n + 8}));",
            f"#{n + 10}=IFCWALLSTANDARDCASE('w{n}',$,'Wall {len(ids) + 1}',$,$,#{n + 3},#{n + 9},$,$);",
        ]
        ids.append(n + 10)
        n += 20
    lines += [
        # The door's opening, placed in the south wall's frame: a 900 x 2100 profile standing in the
        # wall's plane (axis along y), extruded 300 mm through it.
        "#300=IFCCARTESIANPOINT((2450.,0.,0.));",
        "#301=IFCAXIS2PLACEMENT3D(#300,#11,#12);",
        f"#302=IFCLOCALPLACEMENT(#{ids[0] - 7},#301);",
        "#303=IFCCARTESIANPOINT((0.,-150.,1050.));",
        "#304=IFCDIRECTION((0.,1.,0.));",
        "#305=IFCAXIS2PLACEMENT3D(#303,#304,#12);",
        "#306=IFCRECTANGLEPROFILEDEF(.AREA.,$,$,900.,2100.);",
        "#307=IFCEXTRUDEDAREASOLID(#306,#305,#11,300.);",
        "#308=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(#307));",
        "#309=IFCPRODUCTDEFINITIONSHAPE($,$,(#308));",
        "#310=IFCOPENINGELEMENT('o1',$,'Door opening',$,$,#302,#309,$,$);",
        f"#311=IFCRELVOIDSELEMENT('v1',$,$,$,#{ids[0]},#310);",
        f"#400=IFCRELCONTAINEDINSPATIALSTRUCTURE('c1',$,$,$,({','.join(f'#{i}' for i in ids[:4])}),#20);",
        f"#401=IFCRELCONTAINEDINSPATIALSTRUCTURE('c2',$,$,$,(#{ids[4]}),#24);",
    ]
    header = (
        "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('ViewDefinition [CoordinationView]'),'2;1');\n"
        "FILE_NAME('house.ifc','2026-01-01T00:00:00',(''),(''),'','','');\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n"
    )
    return header + "\n".join(lines) + "\nENDSEC;\nEND-ISO-10303-21;\n"


def test_ifc_storey_cut_at_one_metre_with_the_door_open(tmp_path: Path) -> None:
    from planicp.plans.ifc_plan import ifc_storeys, ifc_walls

    path = tmp_path / "house.ifc"
    path.write_text(ifc_house())
    assert [(s.name, s.elevation, s.walls) for s in ifc_storeys(path)] == [("Ground", 0.0, 4), ("Upper", 3.0, 1)]
    walls = ifc_walls(path)
    assert walls.storey is not None and walls.storey.name == "Ground"
    assert (walls.walls, walls.openings, walls.cut_z) == (4, 1, 1.0)
    ends = walls.segments.reshape(-1, 2)
    np.testing.assert_allclose(ends.min(axis=0), (-0.1, -0.1), atol=1e-9)
    np.testing.assert_allclose(ends.max(axis=0), (6.1, 4.1), atol=1e-9)
    truth = np.concatenate(
        [
            outline(-0.1, -0.1, 6.1, 4.1),
            outline(0.1, 0.1, 5.9, 3.9),
            np.array([[[2.0, -0.1], [2.0, 0.1]], [[2.9, -0.1], [2.9, 0.1]]]),
        ]
    )
    plan = load_plan(path, spacing=0.02)
    assert distance_to_segments(plan.points, truth).max() < 1e-9
    door = (plan.points[:, 0] > 2.01) & (plan.points[:, 0] < 2.89) & (plan.points[:, 1] < 0.2)
    assert not door.any()
    assert np.isclose(plan.points[:, 0], 2.0).sum() >= 10  # the jambs, 20 cm deep
    # Above the door head (2.1 m) the wall is whole; above the walls (2.5 m) nothing is cut.
    above_door = ifc_walls(path, cut_height=2.3)
    assert above_door.openings == 0
    lengths = np.hypot(*(above_door.segments[:, 1] - above_door.segments[:, 0]).T)
    assert lengths.sum() == pytest.approx(2 * (6.2 + 4.2) + 2 * (5.8 + 3.8), abs=1e-9)  # two whole rectangles
    with pytest.raises(ValueError, match=r"no wall of storey 'Ground'.*crosses the cut 3 m.*--cut-height"):
        ifc_walls(path, cut_height=3.0)
    upper = ifc_walls(path, storey="upper")
    np.testing.assert_allclose(upper.segments.reshape(-1, 2).max(axis=0), (3.1, 0.1), atol=1e-9)
    assert ifc_walls(path, storey=2).storey == upper.storey
    with pytest.raises(ValueError, match="no storey 'roof'; its storeys: 1: 'Ground' at 0.00 m \\(4 walls\\)"):
        ifc_walls(path, storey="roof")


def test_ifc_units_in_feet_and_bad_files(tmp_path: Path) -> None:
    from planicp.plans.ifc_plan import ifc_walls

    text = ifc_house().replace(
        "#1=IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.);",
        "#5=IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.);#6=IFCMEASUREWITHUNIT(IFCLENGTHMEASURE(0.0003048),#5);"
        "#1=IFCCONVERSIONBASEDUNIT(#5,.LENGTHUNIT.,'THOUSANDTH FOOT',#6);",
    )
    path = tmp_path / "feet.ifc"
    path.write_text(text)
    ends = ifc_walls(path, cut_height=0.5).segments.reshape(-1, 2)  # the walls: 2500 units, 0.76 m high
    np.testing.assert_allclose(ends.max(axis=0), (6100 * 0.0003048, 4100 * 0.0003048), atol=1e-9)
    bad = tmp_path / "bad.ifc"
    bad.write_text("ISO-10303-21;\nHEADER;FILE_SCHEMA(('AP214'));ENDSEC;DATA;ENDSEC;")
    with pytest.raises(ValueError, match="schema 'AP214', not an IFC model"):
        ifc_walls(bad)


# --------------------------------------------------------------------------------------------------
# DXF: layers shown, blocks, door swings
# --------------------------------------------------------------------------------------------------


@needs_dxf
def test_dxf_hidden_layers_blocks_and_door_swings(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import ezdxf

    from planicp.plans.dxf_plan import dxf_walls

    doc = ezdxf.new()
    doc.header["$INSUNITS"] = 6  # metres
    msp = doc.modelspace()
    doc.layers.add("WALLS")
    doc.layers.add("HIDDEN").freeze()
    doc.layers.add("SWITCHED").off()
    doc.layers.add("Doors")
    msp.add_line((0, 0), (4, 0), dxfattribs={"layer": "WALLS"})
    msp.add_line((0, 5), (4, 5), dxfattribs={"layer": "HIDDEN"})
    msp.add_line((0, 6), (4, 6), dxfattribs={"layer": "SWITCHED"})
    msp.add_line((0, 7), (4, 7), dxfattribs={"layer": "Doors"})
    # A wall drawn as a block (its line on layer 0), inserted on WALLS turned 90 degrees, scaled 2.
    block = doc.blocks.new("WALL_PIECE")
    block.add_line((0, 0), (1, 0), dxfattribs={"layer": "0"})
    msp.add_blockref("WALL_PIECE", (10, 0), dxfattribs={"layer": "WALLS", "rotation": 90, "xscale": 2, "yscale": 2})
    # A door swing on the wall layer: a 90-degree arc and its leaf from the hinge.
    msp.add_arc((2, 0), 0.9, 0, 90, dxfattribs={"layer": "WALLS"})
    msp.add_line((2, 0), (2, 0.9), dxfattribs={"layer": "WALLS"})
    # A door symbol in one closed polyline: hinge, leaf end, swing back to the wall (a wedge).
    bulge = math.tan(math.radians(90) / 4)
    msp.add_lwpolyline(
        [(6, 0, 0), (6, 0.8, bulge), (6.8, 0, 0)], format="xyb", close=True, dxfattribs={"layer": "WALLS"}
    )
    path = tmp_path / "floor.dxf"
    doc.saveas(path)

    walls = dxf_walls(path)
    np.testing.assert_allclose(walls.segments, [[[0, 0], [4, 0]], [[10, 0], [10, 2]]], atol=1e-9)
    assert walls.layers == ("WALLS",) and walls.door_swings == 1 and walls.block_entities == 1
    assert "1 door swings (arc and leaf), 1 door symbols" in walls.notes[2]
    assert set(walls.skipped_layers) >= {"HIDDEN: frozen", "SWITCHED: off", "Doors: door layer"}
    kept = dxf_walls(path, keep_door_swings=True)
    assert len(kept.segments) > len(walls.segments) + 4  # the arc's chords and the leaf, the wedge
    named = dxf_walls(path, ["walls", "hidden"])
    assert [[0.0, 5.0], [4.0, 5.0]] in named.segments.tolist()  # a layer named is read whatever its state
    assert cli_main(["plan", str(path), "--list-layers"]) == 0
    listing = capsys.readouterr().out.splitlines()
    assert "HIDDEN: frozen; 1 LINE (not read unless named with --layer)" in listing
    assert "WALLS: on, named as walls; 1 ARC, 3 LINE, 1 LWPOLYLINE" in listing


# --------------------------------------------------------------------------------------------------
# Photos
# --------------------------------------------------------------------------------------------------


def test_photo_turned_upright_by_its_exif_orientation(tmp_path: Path) -> None:
    from PIL import Image

    upright = np.full((60, 100), 255, dtype=np.uint8)
    upright[5:15, 5:60] = 0  # a wall along the top, towards the left
    upright[20:55, 80:90] = 0
    expected = PlanMap.from_image(upright, 0.05, cache=False)
    # A camera turned a quarter clockwise stores the picture turned back (and orientation 6).
    stored = Image.fromarray(np.ascontiguousarray(np.rot90(upright, k=1)))
    exif = stored.getexif()
    exif[0x0112] = 6
    photo = tmp_path / "photo.png"
    stored.save(photo, exif=exif)
    plan = PlanMap.from_image(photo, 0.05, cache=False)
    np.testing.assert_array_equal(plan.points, expected.points)
    exif[0x0112] = 1
    stored.save(tmp_path / "plain.png", exif=exif)
    assert PlanMap.from_image(tmp_path / "plain.png", 0.05, cache=False).extent != expected.extent


# --------------------------------------------------------------------------------------------------
# Refusals: each names the problem and the fix
# --------------------------------------------------------------------------------------------------


def _without(monkeypatch: pytest.MonkeyPatch, *modules: str) -> None:
    real = importlib.util.find_spec

    def find_spec(name: str, *args: Any) -> Any:
        return None if name in modules else real(name, *args)

    monkeypatch.setattr(plan_formats.importlib.util, "find_spec", find_spec)


@pytest.mark.parametrize(
    ("name", "content", "modules", "extra"),
    [
        ("plan.pdf", b"%PDF-1.4\n%%EOF\n", ("pdfminer",), "pdf"),
        ("plan.svg", b'<?xml version="1.0"?>\n<svg xmlns="http://www.w3.org/2000/svg"/>', ("svgelements",), "svg"),
        ("plan.dxf", b"  0\nSECTION\n  2\nHEADER\n  0\nENDSEC\n  0\nEOF\n", ("ezdxf",), "cad"),
        ("scan.png", b"%PDF-1.4\n%%EOF\n", ("pypdfium2",), "pdf"),  # a PDF whatever its suffix
    ],
)
def test_a_drawing_without_its_extra_names_the_extra(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    name: str,
    content: bytes,
    modules: tuple[str, ...],
    extra: str,
) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    _without(monkeypatch, *modules)
    with pytest.raises(
        ImportError, match=rf"needs the optional extra '{extra}'.*pip install 'planicp\[{extra}\]'"
    ) as info:
        load_plan(path, resolution=0.05)
    assert str(path) in str(info.value) and "image" not in str(info.value)
    assert cli_main(["plan", str(path), "--resolution", "0.05", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"pip install 'planicp[{extra}]'" in err and "could not be read as an image" not in err


@pytest.mark.parametrize(
    ("name", "content", "fix"),
    [
        ("plan.dwg", b"AC1032\x00\x00\x00\x00", "save the drawing as DXF"),
        ("house.ifczip", b"PK\x03\x04", "unzip it"),
        ("plan.svgz", b"\x1f\x8b\x08\x00", "decompress it"),
        ("model.rvt", b"\xd0\xcf\x11\xe0", "export the floor as IFC or DXF"),
    ],
)
def test_formats_planicp_does_not_read_say_what_to_give(tmp_path: Path, name: str, content: bytes, fix: str) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(ValueError, match=fix) as info:
        load_plan(path, resolution=0.05)
    assert str(path) in str(info.value)


def test_images_still_need_a_resolution_and_unknown_files_name_the_formats(tmp_path: Path) -> None:
    junk = tmp_path / "plan.xyz"
    junk.write_bytes(b"not an image")
    with pytest.raises(ValueError, match="needs a resolution"):
        load_plan(junk)
    with pytest.raises(ValueError, match="could not be read as an image.*DXF, PDF, SVG and IFC"):
        load_plan(junk, resolution=0.05)


def test_ifc_and_pdf_are_recognised_by_their_first_bytes(tmp_path: Path) -> None:
    ifc = tmp_path / "house.txt"
    ifc.write_text(ifc_house())
    assert plan_formats.plan_format(ifc) == "ifc"
    assert len(load_plan(ifc, spacing=0.1)) > 100
    pdf = tmp_path / "drawing"
    pdf.write_bytes(b"%PDF-1.7\n")
    assert plan_formats.plan_format(pdf) == "pdf"
    svg = tmp_path / "drawing.xml"
    svg.write_text('<?xml version="1.0"?><!-- a plan --><svg xmlns="http://www.w3.org/2000/svg"></svg>')
    assert plan_formats.plan_format(svg) == "svg"
    from planicp.plans.plan_loading import plan_layers

    with pytest.raises(ValueError, match="is an image, which has no layers: --list-layers is for drawings"):
        plan_layers(_png(tmp_path))


def _png(tmp_path: Path) -> Path:
    import cv2

    path = tmp_path / "plan.png"
    cv2.imwrite(str(path), np.full((10, 10), 255, dtype=np.uint8))
    return path


def test_damaged_drawings_are_refused_naming_the_file(tmp_path: Path) -> None:
    from planicp.plans.ifc_plan import ifc_walls

    damaged = tmp_path / "damaged.ifc"
    damaged.write_text(
        "ISO-10303-21;\nHEADER;FILE_SCHEMA(('IFC4'));ENDSEC;\nDATA;\n"
        "#1=IFCBUILDINGSTOREY('s',$,'Ground');\n#2=IFCRELCONTAINEDINSPATIALSTRUCTURE('c',$,$,$,(#9),#1);\n"
        "#9=IFCWALL('w',$,'Wall',$,$,#77,#78,$);\nENDSEC;\n"
    )
    with pytest.raises(ValueError, match=rf"{damaged.name}'.*(damaged|no wall)"):
        ifc_walls(damaged)
    assert cli_main(["plan", str(damaged), "--out", str(tmp_path / "o")]) == 2
    if HAS_PDF:
        pdf = tmp_path / "broken.pdf"
        pdf.write_bytes(b"%PDF-1.4\n1 0 obj << /Type /Catalog >> endobj\ntrailer << /Root 1 0 R >>\n%%EOF")
        with pytest.raises(ValueError, match=r"PDF file '.*broken.pdf' (could not be read as PDF|has no pages)"):
            load_plan(pdf, scale="1:100")
    if HAS_SVG:
        svg = tmp_path / "broken.svg"
        svg.write_text('<svg xmlns="http://www.w3.org/2000/svg"><polygon points="0,0 10,0')
        with pytest.raises(ValueError, match=r"SVG file '.*broken.svg' (could not be read as SVG|has no drawn shape)"):
            load_plan(svg, resolution=0.01)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.integers(min_value=0, max_value=6000), junk=st.binary(max_size=40))
def test_ifc_reader_refuses_any_damage_with_a_value_error(tmp_path: Path, cut: int, junk: bytes) -> None:
    """The house cut short anywhere, with bytes of junk after: read, or refused naming the file."""
    from planicp.plans.ifc_plan import ifc_storeys, ifc_walls

    path = tmp_path / "damaged.ifc"
    path.write_bytes(ifc_house().encode()[:cut] + junk)
    for read in (ifc_walls, ifc_storeys):
        try:
            read(path)
        except ValueError as exc:
            assert "damaged.ifc" in str(exc) or "cut_height" in str(exc)


@needs_pdf
def test_pdf_without_a_print_scale_takes_it_from_its_room_labels(tmp_path: Path) -> None:
    from planicp.plans.pdf_plan import pdf_walls

    # The two 5 x 8 m rooms of `room_content` (a 1 m door between them), labelled with their
    # dimensions and area instead of the print scale; a label on the paper below gives nothing.
    x0 = OFFSET
    content = room_content(scale_text="5,00 x 8,00")
    content += f"\nBT /F1 8 Tf {x0 + 6 * M:.2f} {x0 + 4 * M:.2f} Td (40 m2) Tj ET"
    content += f"\nBT /F1 8 Tf {x0:.2f} {x0 - 40:.2f} Td (3,00 x 3,00) Tj ET"
    content = content.replace(f"{x0 + 10:.2f} {x0 + 10:.2f} Td", f"{x0 + 1 * M:.2f} {x0 + 4 * M:.2f} Td")
    walls = pdf_walls(write_pdf(tmp_path / "labelled.pdf", content))
    assert walls.metres_per_point == pytest.approx(PT * RATIO, rel=0.02)
    assert walls.scale_source.startswith("room labels: 2 room labels agree")
    assert "'5,00 x 8,00'" in walls.scale_source and "'40 m2'" in walls.scale_source
    ends = walls.segments.reshape(-1, 2)
    np.testing.assert_allclose(ends.max(axis=0) - ends.min(axis=0), ROOM, rtol=0.02)
    # Labels that state no size: refused as before, saying the labels were looked at.
    unlabelled = write_pdf(tmp_path / "unlabelled.pdf", room_content(scale_text="LIVING ROOM"))
    with pytest.raises(ValueError, match=r"states no print scale.*--scale.*no room label"):
        pdf_walls(unlabelled)
