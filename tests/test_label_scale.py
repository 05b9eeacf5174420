"""The scale of a drawing from its room labels and the rooms they are written in."""

from __future__ import annotations

import numpy as np
import pytest

from planicp.plans.label_scale import RoomLabel, label_scale
from planicp.plans.scale_text import FOOT, INCH

RES = 0.02
"""Metres per pixel the test drawing is drawn at: what the labels must give back."""


def drawing() -> tuple[np.ndarray, list[RoomLabel]]:
    """Three rooms side by side, 10-pixel walls, in image order: 322 x 347 cm, 13 m² (4.00 x
    3.25 m), and 11'7" x 15'7"; one label outside, one that is no label."""
    rooms = [
        (3.22, 3.47, "322 X 347"),
        (4.00, 3.25, "Bedroom\n13 m²"),
        (11 * FOOT + 7 * INCH, 15 * FOOT + 7 * INCH, "11'7\" x 15'7\""),
    ]
    wall = 10
    height = max(int(round(h / RES)) for _, h, _ in rooms) + 2 * wall + 40
    width = sum(int(round(w / RES)) + wall for w, _, _ in rooms) + wall + 40
    walls = np.zeros((height, width), dtype=bool)
    labels = []
    x = 20
    for w, h, text in rooms:
        pw, ph = int(round(w / RES)), int(round(h / RES))
        walls[20 : 20 + ph + 2 * wall, x : x + pw + 2 * wall] = True
        walls[20 + wall : 20 + wall + ph, x + wall : x + wall + pw] = False
        labels.append(RoomLabel(text, x + wall + pw / 2, 20 + wall + ph / 3))
        x += pw + wall
    labels.append(RoomLabel("322 X 347", 5.0, 5.0))  # on the paper: no room
    labels.append(RoomLabel("KITCHEN", labels[0].x, labels[0].y + 20))
    return walls, labels


def test_three_labelled_rooms_give_the_drawings_scale() -> None:
    walls, labels = drawing()
    found = label_scale(walls, labels)
    assert found is not None
    assert found.metres_per_unit == pytest.approx(RES, rel=0.005)
    assert found.labels == 3
    assert "322 X 347" in found.source and "13 m²" in found.source
    # The same drawing in PDF points, 0.5 point a pixel: metres per point is twice metres per pixel.
    in_points = [RoomLabel(label.text, label.x * 0.5, label.y * 0.5) for label in labels]
    halved = label_scale(walls, in_points, unit=0.5)
    assert halved is not None
    assert halved.metres_per_unit == pytest.approx(2 * RES, rel=0.005)


def test_labels_outside_rooms_or_without_numbers_give_nothing() -> None:
    walls, labels = drawing()
    assert label_scale(walls, labels[3:]) is None
    assert label_scale(walls, []) is None
