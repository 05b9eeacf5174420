"""The simulated world: furniture that is not in the plan, never blocking the building; people walking."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from planicp import PlanRaster, _core
from planicp.plans.default_plan import load_default_plan
from planicp.se2 import compose
from planicp.sim.experiment import ExperimentConfig, LidarModel, run_experiment
from planicp.sim.floor import Floor
from planicp.sim.world import Furnishing, Person, World


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


def _corridor() -> Floor:
    """A corridor 2 m wide between 15 cm walls, 12 m long, closed at both ends (5 cm cells)."""
    res = 0.05
    walls = np.zeros((int(2.6 / res), int(12.0 / res)), dtype=bool)
    walls[:6], walls[-6:], walls[:, :6], walls[:, -6:] = True, True, True, True
    return Floor(walls, np.zeros_like(walls), res, (0.0, 0.0))


@pytest.mark.parametrize(
    ("heading", "speed", "seed"),
    [(0.0, 0.3, 0), (0.0, 0.3, 1), (math.pi, 0.3, 0), (math.pi, 0.3, 2), (math.pi / 2, 0.3, 0), (0.0, 0.6, 1)],
)
def test_a_person_in_the_robots_way_gives_way_and_never_covers_it(heading: float, speed: float, seed: int) -> None:
    """The robot drives down the corridor's centre line at 0.5 m/s through where a person walks
    (away from it, at it, across). Before people gave way, the person froze once the robot was
    within their keep-clear distance and the robot drove through them (centres 0.00-0.06 m apart,
    i.e. the person's disc over the LIDAR, in every one of these cases but the last)."""
    floor = _corridor()
    grid = _core.OccupancyGrid(np.ascontiguousarray(floor.occupied()), floor.resolution, floor.origin)
    world = World(floor, [Person(4.0, 1.3, heading, speed, 0.25)])
    rng = np.random.default_rng(seed)
    path = np.column_stack([1.0 + 0.05 * np.arange(181), np.full(181, 1.3)])  # 10 Hz, 0.5 m/s
    lidar = LidarModel()
    gaps, returns = [], []
    for k, (x, y) in enumerate(path):
        world.advance(0.1, rng, keep_clear=(x, y), robot_radius=0.3, robot_ahead=path[k + 1 : k + 21])
        person = world.people[0]
        gaps.append(math.hypot(person.x - x, person.y - y) - person.radius - 0.3)
        assert _free_disc(floor, person)
        ranges = grid.cast(
            compose((x, y, 0.0), lidar.mount), lidar.angle_min, lidar.angle_increment, lidar.beams,
            lidar.range_min, lidar.range_max, 0.0, 0.0, 0, world.discs(),
        )  # fmt: skip
        returns.append(np.mean(np.isfinite(ranges) & (ranges < lidar.range_max)))
    assert min(gaps) > 0.0  # never overlaps the robot's footprint
    assert min(returns) > 0.5  # so the LIDAR always sees the corridor


def test_people_never_overlap_the_robot_in_a_crowded_drive() -> None:
    """The drift experiment on the office plan with 5 people per 100 m^2: the people come close
    to the robot (within half a metre of its footprint, blocking beams) but never onto it."""
    recording, world = run_experiment(
        load_default_plan(), ExperimentConfig(duration_s=60.0, seed=0, furnishing=Furnishing(people=5.0))
    )
    assert len(world.people) >= 20 and recording.person_gap is not None
    metrics = recording.metrics()
    assert 0.0 < metrics["closest_person_m"] < 0.5
    assert metrics["lost_scans"] == 0 and metrics["planicp_position_rms_m"] < 0.03


def _free_disc(floor: Floor, person: Person) -> bool:
    """The person's disc touches no wall or furniture cell."""
    occupied, res, (ox, oy) = floor.occupied(), floor.resolution, floor.origin
    c0, c1 = int((person.x - person.radius - ox) / res), int((person.x + person.radius - ox) / res)
    r0, r1 = int((person.y - person.radius - oy) / res), int((person.y + person.radius - oy) / res)
    return not occupied[r0 : r1 + 1, c0 : c1 + 1].any()
