"""The simulation's building: an open outline closed (or refused), the robot never started outside,
and drawings (plans made of points) furnished like images."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.typing import NDArray

from planicp import PlanMap, PlanRaster
from planicp.sim.building_outline import OpenOutlineWarning, building_outline
from planicp.sim.drive import simulate_drive
from planicp.sim.experiment import ExperimentConfig, run_experiment
from planicp.sim.world import Furnishing, World

RES = 0.05
BUILDING = (10.0, 10.0, 22.0, 18.0)
"""x0, y0, x1, y1 of the building's outer wall faces, metres, on 40 x 30 m of paper."""


def paper_plan(gap: float) -> NDArray[np.bool_]:
    """A 12 x 8 m building of 15 cm walls on 40 x 30 m of paper (image order): two rooms off a
    corridor through doors of 0.9 m, and a gap of `gap` metres in its south wall (0: closed)."""
    rows, cols = int(30 / RES), int(40 / RES)
    up = np.zeros((rows, cols), dtype=bool)  # rows grow with +y

    def wall(x0: float, y0: float, x1: float, y1: float) -> None:
        up[int(round(y0 / RES)) : int(round(y1 / RES)), int(round(x0 / RES)) : int(round(x1 / RES))] = True

    x0, y0, x1, y1 = BUILDING
    t = 0.15
    wall(x0, y0, x1, y0 + t)
    wall(x0, y1 - t, x1, y1)
    wall(x0, y0, x0 + t, y1)
    wall(x1 - t, y0, x1, y1)
    wall(x0, 14.0, 19.0, 14.0 + t)  # the corridor's north side, with two doors
    wall(15.0, 14.0, 15.0 + t, y1)
    up[int(14.0 / RES) : int(14.15 / RES) + 1, int(12.0 / RES) : int(12.9 / RES)] = False
    up[int(14.0 / RES) : int(14.15 / RES) + 1, int(17.0 / RES) : int(17.9 / RES)] = False
    if gap:
        up[int(y0 / RES) : int((y0 + t) / RES) + 1, int(16.0 / RES) : int((16.0 + gap) / RES)] = False
    return up[::-1].copy()


def in_building(x: float, y: float) -> bool:
    x0, y0, x1, y1 = BUILDING
    return x0 < x < x1 and y0 < y < y1


def test_an_open_outline_is_closed_with_a_warning_and_the_robot_stays_inside() -> None:
    raster = PlanRaster(paper_plan(1.0), RES, (0.0, 0.0, 0.0))
    with pytest.warns(OpenOutlineWarning, match=r"outline is open \(gaps up to 1 m") as caught:
        world = World.from_raster(raster, np.random.default_rng(0))
    assert len(caught) == 1
    assert world.notes and "shut doors" in world.notes[0]
    outline = building_outline(raster.walls[::-1], RES)
    assert outline.gap == 1.0 and outline.closed_by_sealing
    # The building's 12 x 8 m less its walls, not the 1,100 m^2 of paper around it.
    assert 80.0 < outline.inside.sum() * RES**2 < 96.0
    # The seal: a straight line of cells across the 1 m gap, in the wall's line, nowhere else (the
    # disc's edge there was an arc bulging up to 0.5 m into the building: a curved wall).
    rows, cols = np.nonzero(outline.sealed)
    assert 18 <= len(rows) <= 24  # one cell deep across the 20-cell gap
    assert np.ptp(rows) == 0 and abs(rows[0] * RES - BUILDING[1]) < 0.2  # along the wall
    assert np.all((cols * RES > 15.9) & (cols * RES < 17.1))
    for seed in range(5):
        x, y, _ = world.floor.sample_pose(np.random.default_rng(seed), clearance=0.45)
        assert in_building(x, y), (seed, x, y)
    trajectory = simulate_drive(world.floor, np.random.default_rng(1), 30.0, clearance=0.45)
    assert all(in_building(x, y) for x, y, _ in trajectory.poses)
    assert all(in_building(p.x, p.y) for p in world.people)


def test_a_closed_building_on_a_larger_sheet_starts_the_robot_inside_and_changes_nothing() -> None:
    raster = PlanRaster(paper_plan(0.0), RES, (0.0, 0.0, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error", OpenOutlineWarning)
        world = World.from_raster(raster, np.random.default_rng(0), Furnishing(0, 0, 0, 0))
    assert world.notes == ()
    outline = building_outline(raster.walls[::-1], RES)
    assert outline.gap == 0.0 and not outline.sealed.any()
    # The paper around the building is larger than it: before, the robot could start there.
    for seed in range(10):
        x, y, _ = world.floor.sample_pose(np.random.default_rng(seed), clearance=0.45)
        assert in_building(x, y), (seed, x, y)


def test_run_experiment_on_an_open_outline_tracks_inside_the_building() -> None:
    plan = PlanMap.from_image(np.where(paper_plan(1.0), 0, 255).astype(np.uint8), RES, cache=False)
    with pytest.warns(OpenOutlineWarning):
        recording, world = run_experiment(plan, ExperimentConfig(duration_s=20.0, seed=2))
    assert all(in_building(x, y) for x, y, _ in recording.truth)
    assert recording.metrics()["planicp_position_rms_m"] < 0.05


@pytest.mark.parametrize(("gap", "max_gap"), [(4.0, 3.0), (1.0, 0.0)])
def test_an_outline_open_beyond_max_gap_is_refused_naming_the_fix(gap: float, max_gap: float) -> None:
    raster = PlanRaster(paper_plan(gap), RES, (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"no enclosed free space .* Draw its outer walls closed"):
        World.from_raster(raster, np.random.default_rng(0), max_gap=max_gap)


def test_a_single_wall_is_refused() -> None:
    lone = np.zeros((60, 60), dtype=bool)
    lone[30, 5:55] = True
    with pytest.raises(ValueError, match="building's outline is open or missing"):
        World.from_raster(PlanRaster(lone, RES, (0.0, 0.0, 0.0)), np.random.default_rng(0))


def test_a_drawing_made_of_segments_is_furnished_and_tracked() -> None:
    """A drawing's plan has no raster: its wall lines are rasterised at 1 cm for the simulated
    building, furnished like an image's, and planicp tracks on the drawn lines."""
    x0, y0, x1, y1 = 0.0, 0.0, 12.0, 8.0
    segments = [
        ((x0, y0), (x1, y0)),
        ((x1, y0), (x1, y1)),
        ((x1, y1), (x0, y1)),
        ((x0, y1), (x0, y0)),
        ((x0, 4.0), (2.0, 4.0)),  # a wall across, with a 1 m door between 2 and 3 m
        ((3.0, 4.0), (12.0, 4.0)),
        ((6.0, 4.0), (6.0, 8.0)),
    ]
    plan = PlanMap.from_segments(np.array(segments, dtype=float), spacing=0.02)
    assert plan.raster is None
    world = World.from_plan(plan, np.random.default_rng(3))
    assert world.floor.resolution == 0.01
    assert world.notes == ()  # the drawn outline is closed: nothing sealed
    furniture = world.floor.clutter[3:-3, 3:-3].sum() * world.floor.resolution**2
    assert furniture > 1.0  # cabinets and blocks in 96 m^2
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=20.0, seed=3))
    assert all(x0 < x < x1 and y0 < y < y1 for x, y, _ in recording.truth)
    metrics = recording.metrics()
    assert metrics["planicp_position_rms_m"] < 0.05
    assert metrics["accepted_share"] > 0.9


def test_an_open_building_with_a_closet_is_refused_not_simulated_in_the_closet() -> None:
    """Before, the largest enclosed region was "the building": here a 1.5 x 1.5 m closet, while the
    building's rooms reach the paper through a 4 m gap."""
    plan = paper_plan(4.0)[::-1].copy()
    closet = (int(15.5 / RES), int(10.5 / RES))  # rows, cols of its lower-left corner
    side = int(1.5 / RES)
    plan[closet[0], closet[1] : closet[1] + side] = True
    plan[closet[0] + side, closet[1] : closet[1] + side + 1] = True
    plan[closet[0] : closet[0] + side, closet[1]] = True
    plan[closet[0] : closet[0] + side, closet[1] + side] = True
    raster = PlanRaster(plan[::-1].copy(), RES, (0.0, 0.0, 0.0))
    with pytest.raises(
        ValueError,
        match=r"outline is open: the largest region its walls enclose is 2.1 m\^2, 2 %.*Draw its outer walls closed",
    ):
        World.from_raster(raster, np.random.default_rng(0))
