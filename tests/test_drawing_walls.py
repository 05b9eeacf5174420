"""Walls out of cluttered raster drawings (`planicp.plans.wall_extraction`), on drawings the tests
draw themselves with OpenCV: walls plus text, door swings, furniture symbols, dimension strings
with arrows and hatching, in a thick-wall style (grey or black bands) and a line style (1-2 px
wall lines). The extracted wall surfaces are scored against the walls drawn: precision and recall
of points within 5 cm, both at least 90 %, and each door is an opening."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

from planicp import PlanMap
from planicp.cli import main as cli_main
from planicp.plans.plan_figure import CLASS_COLOURS, plot_drawing_overlay
from planicp.plans.plan_raster import load_rgb
from planicp.plans.wall_extraction import DROPPED_CLASSES, WALL, WallExtraction, explain_image, extract_walls

RES = 0.02  # metres per pixel of the drawings
H, W = 400, 600  # pixels: a 12 x 8 m floor
TOLERANCE = 0.05  # metres


def _faces(area: NDArray[np.bool_]) -> NDArray[np.float64]:
    """(N, 2) map-frame metres of the faces between `area` and the rest (origin (0, 0, 0))."""
    a = np.pad(area, 1)
    vr, vc = np.nonzero(a[:-1, :] != a[1:, :])
    hr, hc = np.nonzero(a[:, :-1] != a[:, 1:])
    rows = np.concatenate([vr.astype(np.float64), hr - 1 + 0.5])
    cols = np.concatenate([vc - 1 + 0.5, hc.astype(np.float64)])
    return np.column_stack([cols * RES, (area.shape[0] - rows) * RES])


def _share_near(points: NDArray[np.float64], others: NDArray[np.float64]) -> float:
    """Share of `points` within TOLERANCE of one of `others` (metres)."""
    grid = np.ones((2 * H + 4, 2 * W + 4), np.uint8)
    idx = np.round(others / RES * 2).astype(np.int64) + 1
    grid[idx[:, 1], idx[:, 0]] = 0
    dist = cv2.distanceTransform(grid, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * RES / 2
    q = np.round(points / RES * 2).astype(np.int64) + 1
    return float((dist[q[:, 1], q[:, 0]] <= TOLERANCE).mean())


# The floor: an outer wall, an inner wall with a door, an outer door; in pixels (col, row).
DOORS = [((300, 180), (300, 235)), ((120, 360), (175, 360))]  # door openings: (start, end) on a wall line


def _wall_mask(thickness: int) -> NDArray[np.bool_]:
    """The true walls (bool, image order) drawn `thickness` px thick, doors cut out."""
    walls = np.zeros((H, W), np.uint8)
    cv2.rectangle(walls, (40, 40), (560, 360), 1, thickness)
    cv2.line(walls, (300, 40), (300, 360), 1, thickness)
    cv2.line(walls, (300, 250), (560, 250), 1, thickness)
    for (c0, r0), (c1, r1) in DOORS:
        half = thickness // 2 + 1
        cv2.rectangle(walls, (min(c0, c1) - half, min(r0, r1) - half), (max(c0, c1) + half, max(r0, r1) + half), 0, -1)
        if c0 == c1:  # an opening in a vertical wall: its rows
            walls[r0:r1, c0 - half : c0 + half + 1] = 0
        else:
            walls[r0 - half : r0 + half + 1, c0:c1] = 0
    return walls.astype(bool)


def _clutter(image: NDArray[np.uint8], pen: int = 1) -> None:
    """Text, door swings, furniture, a dimension string with arrows and hatching, in black pen lines."""
    black = 0
    for text, (c, r) in (("LIVING 24m2", (90, 150)), ("BED 11m2", (380, 130)), ("BATH", (400, 310))):
        cv2.putText(image, text, (c, r), cv2.FONT_HERSHEY_SIMPLEX, 0.6, black, pen, cv2.LINE_AA)
    # Door swings: a quarter arc and the leaf, hinged at a side of each opening.
    (c0, r0), (c1, r1) = DOORS[0]
    radius = r1 - r0
    cv2.ellipse(image, (c0, r0), (radius, radius), 0, 90, 180, black, pen, cv2.LINE_AA)
    cv2.line(image, (c0, r0), (c0 - radius, r0), black, pen)
    (c0, r0), (c1, r1) = DOORS[1]
    radius = c1 - c0
    cv2.ellipse(image, (c0, r0), (radius, radius), 0, 270, 360, black, pen, cv2.LINE_AA)
    cv2.line(image, (c0, r0), (c0, r0 - radius), black, pen)
    # Furniture: a bed, a table with chairs, a round basin.
    cv2.rectangle(image, (420, 60), (520, 110), black, pen)
    cv2.rectangle(image, (430, 65), (470, 80), black, pen)
    cv2.rectangle(image, (120, 220), (200, 270), black, pen)
    for c in (130, 160, 190):
        cv2.rectangle(image, (c - 8, 205), (c + 8, 215), black, pen)
    cv2.circle(image, (480, 300), 18, black, pen, cv2.LINE_AA)
    # A dimension string below the floor, with arrows and its text.
    cv2.arrowedLine(image, (300, 392), (40, 392), black, pen, tipLength=0.03)
    cv2.arrowedLine(image, (300, 392), (560, 392), black, pen, tipLength=0.03)
    cv2.putText(image, "10.40", (280, 388), cv2.FONT_HERSHEY_SIMPLEX, 0.4, black, pen, cv2.LINE_AA)
    # Hatching: a tiled floor of short parallel strokes (0.3 m across).
    for k in range(0, 100, 8):
        cv2.line(image, (320 + k, 270), (320 + k + 15, 285), black, pen)


def thick_drawing(grey: int) -> tuple[NDArray[np.uint8], NDArray[np.bool_]]:
    """A thick-wall drawing (walls 10 px = 20 cm bands of grey level `grey`) and its true walls."""
    walls = _wall_mask(10)
    image = np.full((H, W), 255, np.uint8)
    image[walls] = grey
    _clutter(image)
    return image, walls


def line_drawing() -> tuple[NDArray[np.uint8], NDArray[np.bool_]]:
    """A line drawing and its true walls: the walls of `_wall_mask(16)` (32 cm) drawn as their
    outlines, 2 px pen lines (the wall ends at the doors closed), the clutter in 1 px lines."""
    band = _wall_mask(16).astype(np.uint8)
    inside = cv2.erode(band, np.ones((5, 5), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0)
    walls = (band > 0) & ~(inside > 0)
    image = np.full((H, W), 255, np.uint8)
    image[walls] = 0
    _clutter(image)
    return image, walls


def _score(plan: PlanMap, walls: NDArray[np.bool_]) -> tuple[float, float]:
    truth = _faces(walls)
    return _share_near(plan.points, truth), _share_near(truth, plan.points)


@pytest.mark.parametrize("grey", [0, 100])
def test_thick_wall_drawing_keeps_the_walls_and_drops_the_clutter(grey: int) -> None:
    image, walls = thick_drawing(grey)
    plan = PlanMap.from_image(image, RES, cache=False)
    precision, recall = _score(plan, walls)
    assert precision >= 0.95 and recall >= 0.95, (precision, recall)
    old = PlanMap.from_image(image, RES, cache=False, walls="all-dark")
    old_precision, _ = _score(old, walls)
    assert old_precision < 0.75  # every dark pixel: text, swings and furniture are walls
    extracted = explain_image(image, RES)
    assert extracted.style == "thick"
    assert 9 <= extracted.wall_px <= 11 and extracted.pen_px <= 2


def test_line_drawing_keeps_the_wall_lines_and_drops_the_clutter() -> None:
    image, walls = line_drawing()
    plan = PlanMap.from_image(image, RES, cache=False)
    precision, recall = _score(plan, walls)
    assert precision >= 0.9 and recall >= 0.9, (precision, recall)
    extracted = explain_image(image, RES)
    assert extracted.style == "line"
    assert not extracted.walls[300:320, 480:500].any()  # the basin's circle
    assert not extracted.walls[60:110, 420:520].any()  # the bed, apart from the walls


def test_long_hatching_in_a_line_drawing_is_no_wall() -> None:
    """Hatching of long parallel lines inside a frame: the narrow strips between them lie side by
    side, each line between two strips, unlike a wall's face line (a room on its other side)."""
    image, walls = line_drawing()
    hatch = np.zeros_like(image)
    for k in range(-100, 220, 7):
        cv2.line(hatch, (60 + k, 100), (160 + k, 200), 1, 1)
    hatch[:, :70] = 0
    hatch[:, 270:] = 0
    hatch[:100] = 0
    hatch[201:] = 0
    cv2.rectangle(hatch, (70, 100), (270, 200), 1, 1)
    image[hatch > 0] = 0
    extracted = explain_image(image, RES)
    assert (extracted.walls & (hatch > 0)).sum() < 0.1 * (hatch > 0).sum()
    _, recall = _score(PlanMap.from_image(image, RES, cache=False), walls)
    assert recall >= 0.95


@pytest.mark.parametrize("style", ["thick", "line"])
def test_doors_are_openings(style: str) -> None:
    image, _ = thick_drawing(0) if style == "thick" else line_drawing()
    extracted = explain_image(image, RES)
    for (c0, r0), (c1, r1) in DOORS:
        if c0 == c1:  # the opening's middle, across the wall
            rows, cols = slice(r0 + 5, r1 - 5), slice(c0 - 14, c0 + 15)
        else:
            rows, cols = slice(r0 - 14, r0 + 15), slice(c0 + 5, c1 - 5)
        assert not extracted.walls[rows, cols].any(), (style, (c0, r0))
    assert (extracted.labels[extracted.walls] == WALL).all()


def test_coloured_ink_and_another_tone_are_dropped() -> None:
    image, walls = thick_drawing(100)
    colour = np.repeat(image[:, :, None], 3, axis=2)
    cv2.rectangle(colour, (330, 60), (400, 120), (40, 90, 160), -1)  # a wooden sauna bench, brown (BGR)
    plan = PlanMap.from_image(cv2.cvtColor(colour, cv2.COLOR_BGR2RGB), RES, cache=False)
    precision, recall = _score(plan, walls)
    assert precision >= 0.95 and recall >= 0.95, (precision, recall)


def test_walls_in_two_tones_are_all_kept() -> None:
    """New walls black, existing walls grey (as CAD drawings tell them apart): both are walls."""
    image, walls = thick_drawing(0)
    image[walls & (np.arange(W)[None, :] > 300)] = 110  # the right half's walls grey
    plan = PlanMap.from_image(image, RES, cache=False)
    precision, recall = _score(plan, walls)
    assert precision >= 0.95 and recall >= 0.95, (precision, recall)
    assert any("two tones" in note for note in explain_image(image, RES).notes)


def test_a_clean_wall_image_keeps_every_wall() -> None:
    walls = _wall_mask(10)
    image = np.where(walls, 0, 255).astype(np.uint8)
    drawing = PlanMap.from_image(image, RES, cache=False)
    every = PlanMap.from_image(image, RES, cache=False, walls="all-dark")
    np.testing.assert_array_equal(np.sort(drawing.points, axis=0), np.sort(every.points, axis=0))


def test_tracking_in_the_true_walls_on_the_extracted_plan() -> None:
    """The robot drives in the walls drawn (outside the floor solid), furnished; planicp tracks it
    on the plan extracted from the cluttered drawing."""
    from planicp.plans.plan_raster import PlanRaster
    from planicp.sim.experiment import ExperimentConfig, run_experiment

    image, walls = thick_drawing(100)
    outside = np.ones((H, W), bool)
    outside[40:361, 40:561] = False
    building = PlanRaster(walls | outside, RES, (0.0, 0.0, 0.0))
    plan = PlanMap.from_image(image, RES, cache=False)
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=20.0, seed=4), building=building)
    distance, _ = recording.errors("estimate")
    assert float(np.sqrt(np.mean(distance**2))) < 0.05
    assert recording.lost is not None and not recording.lost.any()


def test_settings_and_refusals() -> None:
    image, _ = thick_drawing(0)
    with pytest.raises(ValueError, match='walls must be "drawing".*or "all-dark"'):
        PlanMap.from_image(image, RES, walls="clean", cache=False)
    with pytest.raises(ValueError, match='with walls="all-dark" leave it out'):
        PlanMap.from_image(image, RES, walls="all-dark", wall_extraction=WallExtraction(), cache=False)
    with pytest.raises(ValueError, match="min_run"):
        WallExtraction(min_run=-1.0)
    blank = np.zeros((H, W), bool)
    with pytest.raises(ValueError, match="no dark pixels"):
        extract_walls(blank, RES)
    specks = np.zeros((H, W), bool)
    specks[::40, ::40] = True
    with pytest.raises(ValueError, match='walls="all-dark"'):
        extract_walls(specks, RES)
    longer = PlanMap.from_image(image, RES, cache=False, wall_extraction=WallExtraction(min_run=0.6))
    assert len(longer) > 0


def test_cli_plan_draws_the_decisions_on_the_drawing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    image, _ = thick_drawing(100)
    path = tmp_path / "drawing.png"
    cv2.imwrite(str(path), image)
    assert cli_main(["plan", str(path), "--resolution", str(RES), "--out", str(tmp_path / "out"), "--no-cache"]) == 0
    text = capsys.readouterr().out
    assert "thick-wall drawing" in text and "dropped" in text and "thin strokes" in text
    overlay = cv2.imread(str(tmp_path / "out" / "overlay.png"))
    assert overlay is not None and overlay.shape[0] > 300
    assert (
        cli_main(["plan", str(path), "--resolution", str(RES), "--walls", "all-dark", "--out", str(tmp_path / "o2")])
        == 0
    )
    assert "every dark pixel is a wall" in capsys.readouterr().out
    figure = plot_drawing_overlay(load_rgb(path), explain_image(path, RES), title="x")
    assert math.isclose(figure.get_figwidth(), 10.0)
    assert set(CLASS_COLOURS) == {WALL, *DROPPED_CLASSES}  # every class has its colour in the overlay
