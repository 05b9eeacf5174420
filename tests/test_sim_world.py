"""The simulated world: furniture that is not in the plan, never blocking the building; people walking."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from planicp import PlanRaster
from planicp.plans.default_plan import load_default_plan
from planicp.sim.world import Furnishing, World


@pytest.fixture(scope="module")
def raster() -> PlanRaster:
    plan = load_default_plan()
    assert plan.raster is not None
    return plan.raster


def test_furniture_is_seeded_off_the_walls_and_keeps_the_building_connected(raster: PlanRaster) -> None:
    a = World.from_raster(raster, np.random.default_rng(4))
    b = World.from_raster(raster, np.random.default_rng(4))
    c = World.from_raster(raster, np.random.default_rng(5))
    np.testing.assert_array_equal(a.floor.clutter, b.floor.clutter)
    assert not np.array_equal(a.floor.clutter, c.floor.clutter)
    frame = np.zeros_like(a.floor.walls)
    frame[3:-3, 3:-3] = True
    furniture = a.floor.clutter & frame
    assert not (furniture & a.floor.walls).any()
    # 30 x 20 m floor, ~500 m^2 free: several square metres of cabinets and blocks.
    assert furniture.sum() * a.floor.resolution**2 > 5.0
    bare = World.from_raster(raster, np.random.default_rng(4), Furnishing(0, 0, 0, 0))
    assert inside_regions(a) == inside_regions(bare)  # furniture closed no door or corridor
    # ~500 m^2 of floor at 1 person per 100 m^2.
    assert 3 <= len(a.people) <= 8


def inside_regions(world: World) -> int:
    free = (~world.floor.occupied()).astype(np.uint8)
    count, labels = cv2.connectedComponents(free, connectivity=4)
    border = set(np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])).tolist())
    return len([k for k in range(1, count) if k not in border and (labels == k).sum() > 50])


def test_empty_furnishing_and_validation(raster: PlanRaster) -> None:
    bare = World.from_raster(raster, np.random.default_rng(0), Furnishing(0, 0, 0, 0))
    assert bare.floor.clutter[3:-3, 3:-3].sum() == 0 and bare.people == []
    for field in ("cabinets", "blocks", "tables", "people"):
        with pytest.raises(ValueError, match=f"Furnishing.{field} must be"):
            Furnishing(**{field: -1.0})
    with pytest.raises(ValueError, match="origin yaw 0"):
        World.from_raster(PlanRaster(raster.walls, raster.resolution, (0.0, 0.0, 0.3)), np.random.default_rng(0))
    open_box = np.zeros((40, 40), dtype=bool)
    open_box[5, 5:35] = True  # a single wall: nothing enclosed
    with pytest.raises(ValueError, match="no enclosed free space"):
        World.from_raster(PlanRaster(open_box, 0.05, (0.0, 0.0, 0.0)), np.random.default_rng(0))


def test_people_walk_in_free_space_and_keep_clear_of_the_robot(raster: PlanRaster) -> None:
    rng = np.random.default_rng(2)
    world = World.from_raster(raster, rng, Furnishing(people=3.0))
    occupied = world.floor.occupied()
    res, (ox, oy) = world.floor.resolution, world.floor.origin
    start = world.discs().copy()
    robot = (float(start[0, 0]) + 2.0, float(start[0, 1]))
    for _ in range(200):
        world.advance(0.1, rng, keep_clear=robot)
        for x, y, _radius in world.discs():
            c, rr = int((x - ox) / res), int((y - oy) / res)
            assert not occupied[rr, c]
    moved = np.hypot(*(world.discs()[:, :2] - start[:, :2]).T)
    assert np.median(moved) > 0.5  # people do walk
    d = world.discs()
    assert np.all(np.hypot(d[:, 0] - robot[0], d[:, 1] - robot[1]) > d[:, 2] + 0.55)
