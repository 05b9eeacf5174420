"""A raster drawing's scale from its room labels read by OCR (RapidOCR, installed by hand), and
how a drawing without a resolution is refused without it."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from planicp.cli import main as cli_main
from planicp.plans import drawing_text as text_module
from planicp.plans.drawing_text import clean_ocr_text, drawing_text, ocr_available
from planicp.plans.plan_loading import load_plan, read_plan_file
from planicp.plans.scale_text import parse_area, parse_dimensions
from test_label_scale import RES, flat

needs_ocr = pytest.mark.skipif(
    not ocr_available(), reason="RapidOCR and ONNX Runtime are not installed (.ci/run installs them)"
)


def flat_image(path: Path) -> Path:
    """`test_label_scale.flat`'s three rooms drawn as an image at `RES` metres per pixel, each
    room's label written in it with OpenCV's Hershey font ("13 m2" for the area: the font has no
    "²"), "KITCHEN" below the first, and a dimension label on the paper beside the building."""
    walls, labels = flat()
    image = np.where(walls, 0, 255).astype(np.uint8)
    for label in labels:
        text = label.text.replace("Bedroom 13 m²", "13 m2")
        (width, height), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.55, 1)
        x, y = (label.x, label.y) if label.x > 20 else (image.shape[1] - width - 5, 25.0)
        cv2.putText(
            image, text, (int(x - width / 2), int(y + height / 2)), cv2.FONT_HERSHEY_SIMPLEX, 0.55, 0, 1, cv2.LINE_AA
        )
    cv2.imwrite(str(path), image)
    return path


def test_ocr_misreadings_of_inch_marks_are_undone() -> None:
    assert clean_ocr_text("11'7° × 15'7\"") == "11'7\" × 15'7\""
    assert clean_ocr_text("10'1* × 10'8\"") == "10'1\" × 10'8\""
    assert parse_dimensions(clean_ocr_text("10'1* × 10'8\"")) == pytest.approx((3.0734, 3.2512))
    assert clean_ocr_text(" 13m² ") == "13m²" and clean_ocr_text("25°C") == "25°C"  # no foot mark: as read


@needs_ocr
def test_ocr_reads_the_labels_and_plan_takes_the_scale_they_give(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    image = flat_image(tmp_path / "flat.png")
    read = drawing_text(cv2.imread(str(image), cv2.IMREAD_GRAYSCALE))
    words = {label.text for label in read}
    assert "KITCHEN" in words
    assert sum(parse_dimensions(t) is not None for t in words) >= 2 and any(parse_area(t) for t in words)
    for label in read:  # centres in pixels of the image: each label where it was written
        assert 0 <= label.x < 1000 and 0 <= label.y < 400 and label.box is not None
    assert cli_main(["plan", str(image), "--out", str(tmp_path / "out"), "--no-cache"]) == 0
    printed = capsys.readouterr().out
    assert "from the drawing's room labels read by OCR: 3 room labels agree" in printed
    resolution = yaml.safe_load((tmp_path / "out" / "plan.yaml").read_text())["resolution"]
    assert resolution == pytest.approx(RES, rel=0.02)
    # An explicit resolution wins, and no OCR note is made.
    given = read_plan_file(image, resolution=0.05, cache=False)
    assert given.plan.raster is not None and given.plan.raster.resolution == 0.05
    assert not any("OCR" in note for note in given.notes)


@needs_ocr
def test_a_drawing_whose_text_states_no_size_is_refused_naming_the_resolution(tmp_path: Path) -> None:
    walls, _ = flat()
    image = np.where(walls, 0, 255).astype(np.uint8)
    cv2.putText(image, "BEDROOM", (120, 120), cv2.FONT_HERSHEY_SIMPLEX, 0.55, 0, 1, cv2.LINE_AA)
    cv2.imwrite(str(tmp_path / "plain.png"), image)
    # (The detector finds no text at all in this one, beside thick walls: it says so the same way.)
    with pytest.raises(ValueError, match=r"needs a resolution.*its room labels give none.*OCR read no room dimensions"):
        load_plan(tmp_path / "plain.png", cache=False)


def test_without_the_extra_the_refusal_names_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    image = flat_image(tmp_path / "flat.png")
    monkeypatch.setattr(text_module, "_OCR_MODULES", ("planicp_no_such_ocr_module",))
    text_module._engine.cache_clear()
    try:
        assert not ocr_available()
        with pytest.raises(
            ImportError, match=r"RapidOCR .*GEOS, LGPL-2.1.*pip install 'rapidocr>=3.10,<4' 'onnxruntime"
        ):
            drawing_text(np.zeros((10, 10), np.uint8))
        with pytest.raises(ValueError, match=r"needs a resolution.*pip install 'rapidocr.*room labels"):
            load_plan(image, cache=False)
        assert len(load_plan(image, resolution=RES, cache=False)) > 0  # given one, nothing else changes
    finally:
        text_module._engine.cache_clear()


def test_the_scale_read_from_labels_is_cached_with_the_plan(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The OCR runs once per drawing and options: a second load takes the scale from the plan
    cache; another drawing, or other options, read it again. (OCR stood in for: no extra needed.)"""
    from planicp.plans import raster_scale
    from planicp.plans.label_scale import RoomLabel
    from planicp.plans.scale_text import LabelScale

    calls: list[Path] = []

    def fake(source: Path, **options: object) -> raster_scale.RasterScale:
        calls.append(source)
        return raster_scale.RasterScale(LabelScale(RES, 0.0, 3, "3 room labels agree"), (RoomLabel("x", 0, 0),), 1)

    monkeypatch.setattr(text_module, "ocr_available", lambda: True)
    monkeypatch.setattr(raster_scale, "raster_label_scale", fake)
    image = flat_image(tmp_path / "flat.png")
    cache = tmp_path / "cache"
    first = read_plan_file(image, cache=cache)
    second = read_plan_file(image, cache=cache)
    assert len(calls) == 1
    assert first.notes == second.notes and "3 room labels agree" in first.notes[0]
    assert second.plan.raster is not None and second.plan.raster.resolution == RES
    read_plan_file(image, cache=cache, threshold=100)
    assert len(calls) == 2
    read_plan_file(image, cache=False)
    assert len(calls) == 3
