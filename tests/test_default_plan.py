"""The plan shipped as package data: it is installed, loads, and is a multi-room office."""

from __future__ import annotations

import numpy as np

from planicp import sim as synthetic
from planicp.plans.default_plan import default_plan_path, load_default_plan


def test_default_plan_is_installed_and_loads() -> None:
    path = default_plan_path()
    assert path.is_file() and path.with_name("office_plan.png").is_file()
    plan = load_default_plan()
    xmin, ymin, xmax, ymax = plan.extent
    assert abs((xmax - xmin) - 30.0) < 1e-9 and abs((ymax - ymin) - 20.0) < 1e-9
    assert 7_000 < len(plan) < 10_000


def test_default_plan_has_rooms_joined_by_doors() -> None:
    plan = load_default_plan()
    assert plan.raster is not None
    walls = plan.raster.walls
    free = ~walls
    # Label the free space inside the building (4-connected flood fill, numpy only).
    labels = np.zeros(walls.shape, dtype=np.int32)
    rows, cols = walls.shape
    count = 0
    for start in zip(*np.nonzero(free)):
        if labels[start]:
            continue
        count += 1
        stack = [start]
        labels[start] = count
        while stack:
            r, c = stack.pop()
            for nr, nc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
                if 0 <= nr < rows and 0 <= nc < cols and free[nr, nc] and not labels[nr, nc]:
                    labels[nr, nc] = count
                    stack.append((nr, nc))
    border = set(np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])))
    inside = [k for k in range(1, count + 1) if k not in border and (labels == k).sum() > 100]
    # Doors join every room to the corridor: the inside is one connected region...
    assert len(inside) == 1
    # ...that is a real floor (tens of square metres), not a single room.
    area = (labels == inside[0]).sum() * plan.raster.resolution**2
    assert area > 300.0
    # Rooms of different sizes: the interior walls split the floor at several distinct widths.
    column_walls = walls[walls.shape[0] // 4].nonzero()[0]
    gaps = np.diff(column_walls)[np.diff(column_walls) > 10]
    assert len(gaps) >= 3 and len(set(np.round(gaps, -1))) >= 2


def test_default_plan_matches_its_generator() -> None:
    floor = synthetic.generate_floor(3, "office", width=30.0, height=20.0, rooms=8)
    plan = load_default_plan()
    expected = floor.wall_points()
    assert len(plan) == len(expected)
