"""The scale of a drawing from its room labels and the rooms they are written in."""

from __future__ import annotations

import numpy as np
import pytest

from planicp.plans.label_scale import RoomLabel, close_gaps, label_scale, room_scales
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


def flat(entrance: bool = True, window: bool = True) -> tuple[np.ndarray, list[RoomLabel]]:
    """Three rooms in a row at `RES`, 10-pixel walls shared between them, 0.9 m doors between
    them, a 0.9 m entrance to the paper (`entrance`) in the first room's bottom wall, a 1.5 m
    window drawn as a gap to the paper (`window`) in the third room's top wall, a table 1.3 m or
    more from the walls inside the second room (an island its area counts); one label in each
    room, one on the paper, one without numbers."""
    rooms = [
        (3.22, 3.47, "322 X 347"),
        (4.00, 3.25, "Bedroom 13 m²"),
        (11 * FOOT + 7 * INCH, 15 * FOOT + 7 * INCH, "11'7\" x 15'7\""),
    ]
    wall, top, door = 10, 40, int(round(0.9 / RES))
    sizes = [(int(round(w / RES)), int(round(h / RES))) for w, h, _ in rooms]
    walls = np.zeros((top + max(h for _, h in sizes) + 2 * wall + 40, sum(w for w, _ in sizes) + 4 * wall + 80), bool)
    labels = []
    x = 40
    lefts = []
    for pw, ph in sizes:
        walls[top : top + ph + 2 * wall, x : x + pw + 2 * wall] = True
        lefts.append(x)
        x += pw + wall
    for (pw, ph), x0, (_, _, text) in zip(sizes, lefts, rooms):
        walls[top + wall : top + wall + ph, x0 + wall : x0 + wall + pw] = False
        labels.append(RoomLabel(text, x0 + wall + pw / 2, top + wall + ph / 3))
    for x0 in lefts[1:]:  # doors through the shared walls, 20 px below the top
        walls[top + wall + 20 : top + wall + 20 + door, x0 : x0 + wall] = False
    if entrance:
        x0, (pw, ph) = lefts[0], sizes[0]
        walls[top + wall + ph : top + 2 * wall + ph, x0 + wall + 30 : x0 + wall + 30 + door] = False
    if window:
        x0, (pw, _) = lefts[2], sizes[2]
        walls[top : top + wall, x0 + wall + 40 : x0 + wall + 40 + int(round(1.5 / RES))] = False
    x0, (pw, ph) = lefts[1], sizes[1]
    walls[top + wall + 65 : top + wall + 85, x0 + wall + 70 : x0 + wall + 120] = True  # the table
    labels.append(RoomLabel("322 X 347", 5.0, 5.0))  # on the paper
    labels.append(RoomLabel("KITCHEN", labels[0].x, labels[0].y + 30))
    return walls, labels


def test_rooms_are_measured_with_their_doors_and_windows_closed() -> None:
    walls, labels = flat()
    found = label_scale(walls, labels)
    assert found is not None
    assert found.metres_per_unit == pytest.approx(RES, rel=0.02)
    assert found.labels == 3  # each room, the one with the window too; not the paper's, not KITCHEN
    assert "gaps up to" in found.source and "disagreeing" not in found.source
    # A label written on a wall gives nothing.
    assert label_scale(walls, [RoomLabel("322 X 347", 45.0, labels[0].y)]) is None
    # Each room's label alone gives the scale (the area with the table counted as floor).
    for label in labels[:3]:
        alone = label_scale(walls, [label])
        assert alone is not None and alone.metres_per_unit == pytest.approx(RES, rel=0.02), label.text


def test_doors_leak_rooms_into_each_other_unless_closed() -> None:
    """Measured as they are, the rooms run through their doors into one region (open to the
    paper through the entrance; with it and the window shut, one region three rooms large): no
    label gives the scale. Closed at a door's width they do."""
    walls, labels = flat()
    assert room_scales(walls, labels) == [None] * len(labels)
    shut, labels = flat(entrance=False, window=False)
    leaked = [s for s in room_scales(shut, labels) if s is not None]
    assert len(leaked) == 3
    assert all(s.metres_per_unit < 0.8 * RES for s in leaked)  # the three rooms' region is far larger
    closed = label_scale(shut, labels)
    assert closed is not None and closed.metres_per_unit == pytest.approx(RES, rel=0.02)


def test_an_opening_wider_than_any_window_leaves_the_room_unmeasured() -> None:
    walls, labels = flat()
    # The first room's bottom wall opened over 2.8 m: an open-plan area, not a room.
    x0 = 40 + 10
    bottom = 40 + 10 + int(round(3.47 / RES))
    walls[bottom : bottom + 10, x0 + 5 : x0 + 5 + int(round(2.8 / RES))] = False
    assert label_scale(walls, labels[:1]) is None
    found = label_scale(walls, labels)
    assert found is not None and found.labels == 2


def test_closing_bridges_gaps_up_to_its_width_only() -> None:
    walls = np.zeros((40, 100), bool)
    walls[18:22, :] = True
    walls[18:22, 30:40] = False  # a 10-cell gap
    walls[18:22, 60:72] = False  # a 12-cell gap
    closed = close_gaps(walls, 10)
    assert closed[18:22, 30:40].all() and not closed[18:22, 60:72].any()
    assert (closed[:18] == walls[:18]).all() and (closed[22:] == walls[22:]).all()  # nothing else grew
    assert close_gaps(walls, 12)[18:22, 60:72].all()


def test_two_labels_that_disagree_give_one_of_them_not_a_crash() -> None:
    walls, labels = flat()
    wrong = RoomLabel("644 X 694", labels[0].x, labels[0].y)  # twice the first room's sides
    found = label_scale(walls, [wrong, labels[1]])
    assert found is not None and found.labels == 1 and "1 disagreeing left out" in found.source
