"""Tests of the enhanced occupancy grid: single beams, the four states on a hand-checked room, the
fusion rules, growth, LaserScan input, exports (ROS map, PNG, nav_msgs layout), scoring, errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from planicp import (
    EnhancedOccupancyGrid,
    EogState,
    OccupancyModel,
    PlanicpError,
    PlanMap,
    PlanRaster,
    compare_grids,
    read_ros_map,
    scan_to_points,
)
from planicp._core import OccupancyGrid
from planicp.evaluation.figures import plot_eog, plot_eog_comparison
from planicp.mapping.eog_state import STATE_COLOURS

RES = 0.1
FOV = math.radians(360.0)
BEAMS = 720


def _room_plan() -> PlanMap:
    """A 4 x 4 m room (40 x 40 pixels of 0.1 m, origin (0, 0)), walls one pixel thick."""
    walls = np.zeros((40, 40), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    return PlanMap.from_raster(PlanRaster(walls, RES, (0.0, 0.0, 0.0)))


def _world_cells(plan: PlanMap, box: tuple[slice, slice] | None) -> NDArray[np.bool_]:
    """The plan's walls (rows growing with +y) plus an optional box the plan lacks."""
    assert plan.raster is not None
    cells = plan.raster.walls[::-1].copy()
    if box is not None:
        cells[box] = True
    return cells


def _scan(cells: NDArray[np.bool_], pose: tuple[float, float, float]) -> NDArray[np.float64]:
    """A noise-free 360-degree scan from `pose` (base = laser) in the base frame."""
    grid = OccupancyGrid(np.ascontiguousarray(cells), RES, (0.0, 0.0))
    inc = FOV / BEAMS
    ranges = grid.cast(pose, -math.pi, inc, BEAMS, 0.05, 30.0)
    return scan_to_points(ranges, -math.pi, inc, 0.05, 30.0)


def _state_at(grid: EnhancedOccupancyGrid, states: NDArray[np.uint8], x: float, y: float) -> EogState:
    ox, oy = grid.origin
    row, col = math.floor((y - oy) / grid.resolution), math.floor((x - ox) / grid.resolution)
    return EogState(int(states[row, col]))


def test_one_beam_marks_exactly_its_cells() -> None:
    plan = _room_plan()
    grid = EnhancedOccupancyGrid(plan, RES, margin=0.0)
    # Sensor at (1.05, 2.05) in cell (10, 20) of the room; return at (1.75, 2.05) in cell (17, 20).
    grid.integrate([[0.7, 0.0]], (1.05, 2.05, 0.0))
    obs = grid.observation_states()
    assert grid.origin == (0.0, 0.0) and grid.shape == (40, 40)
    expected = np.full((40, 40), EogState.UNKNOWN, dtype=np.uint8)
    expected[20, 10:17] = EogState.FREE
    expected[20, 17] = EogState.OCCUPIED
    np.testing.assert_array_equal(obs, expected)
    p = grid.probabilities()
    assert p[20, 10] == pytest.approx(0.4, abs=1e-6) and p[20, 17] == pytest.approx(0.7, abs=1e-6)
    assert np.isnan(p[0, 0])
    assert grid.scans == 1


def test_sensor_offset_moves_the_ray_start() -> None:
    grid = EnhancedOccupancyGrid(_room_plan(), RES, margin=0.0)
    # Base at (1.05, 2.05) facing +y; laser 0.5 m ahead of it (at y = 2.55); return 1 m ahead of the base.
    grid.integrate([[1.0, 0.0]], (1.05, 2.05, math.pi / 2), sensor_offset=(0.5, 0.0, 0.0))
    obs = grid.observation_states()
    assert list(np.flatnonzero(obs[:, 10] == EogState.FREE)) == [25, 26, 27, 28, 29]
    assert obs[30, 10] == EogState.OCCUPIED
    assert obs[24, 10] == EogState.UNKNOWN


def test_the_four_states_on_a_hand_checked_room() -> None:
    plan = _room_plan()
    # A 0.5 x 0.5 m cabinet the plan lacks, at x 2.5-3.0, y 1.5-2.0.
    cells = _world_cells(plan, (slice(15, 20), slice(25, 30)))
    grid = EnhancedOccupancyGrid(plan, RES)
    for pose in [(1.05, 1.75, 0.0), (1.05, 2.55, -0.3)]:
        grid.integrate(_scan(cells, pose), pose)
    s = grid.states()
    assert _state_at(grid, s, 1.05, 1.75) == EogState.FREE  # where the robot stood
    assert _state_at(grid, s, 2.0, 1.0) == EogState.FREE  # open floor
    assert _state_at(grid, s, 2.55, 1.75) == EogState.OCCUPIED  # the cabinet's front face
    assert _state_at(grid, s, 0.05, 2.05) == EogState.ARCHITECTURAL  # a plan wall, seen
    assert _state_at(grid, s, 3.95, 1.75) == EogState.ARCHITECTURAL  # a plan wall behind the cabinet, unseen
    assert _state_at(grid, s, 2.85, 1.75) == EogState.UNKNOWN  # inside the cabinet
    assert _state_at(grid, s, 3.45, 1.75) == EogState.UNKNOWN  # the cabinet's shadow
    assert _state_at(grid, s, -0.5, 2.0) == EogState.UNKNOWN  # outside the building
    # Every plan wall cell is architectural; occupied cells are only the cabinet's faces.
    walls = grid.plan_walls()
    assert (s[walls] == EogState.ARCHITECTURAL).all()
    occupied = np.argwhere(s == EogState.OCCUPIED)
    ox, oy = grid.origin
    xs, ys = ox + (occupied[:, 1] + 0.5) * RES, oy + (occupied[:, 0] + 0.5) * RES
    assert len(occupied) >= 8
    assert ((xs > 2.45) & (xs < 3.05) & (ys > 1.45) & (ys < 2.05)).all()


def test_a_wall_seen_from_two_poses_stays_occupied() -> None:
    plan = _room_plan()
    cells = _world_cells(plan, (slice(15, 20), slice(25, 30)))
    grid = EnhancedOccupancyGrid(plan, RES, wall_tolerance_cells=0)
    front = (slice(16, 19), 25)  # rows y 1.6-1.9 of the cabinet's face at x = 2.5
    grid.integrate(_scan(cells, (1.05, 1.75, 0.0)), (1.05, 1.75, 0.0))
    obs_origin = grid.origin
    r0 = int(round(-obs_origin[1] / RES))
    c0 = int(round(-obs_origin[0] / RES))
    face = (slice(front[0].start + r0, front[0].stop + r0), front[1] + c0)
    assert (grid.observation_states()[face] == EogState.OCCUPIED).all()
    grid.integrate(_scan(cells, (1.55, 1.25, 0.4)), (1.55, 1.25, 0.4))
    assert (grid.observation_states()[face] == EogState.OCCUPIED).all()
    assert (grid.probabilities()[face] > 0.8).all()  # two hits


def test_moved_obstacles_are_cleared_by_later_scans() -> None:
    plan = _room_plan()
    with_box = _world_cells(plan, (slice(15, 20), slice(25, 30)))
    without = _world_cells(plan, None)
    grid = EnhancedOccupancyGrid(plan, RES)
    pose = (1.05, 1.75, 0.0)
    grid.integrate(_scan(with_box, pose), pose)
    assert _state_at(grid, grid.states(), 2.55, 1.75) == EogState.OCCUPIED
    for _ in range(3):
        grid.integrate(_scan(without, pose), pose)
    assert _state_at(grid, grid.states(), 2.55, 1.75) == EogState.FREE


def test_wall_observations_next_to_plan_walls_are_architectural() -> None:
    plan = _room_plan()
    # The real wall is one cell thicker than the plan's on the east side: the scans end one cell early.
    cells = _world_cells(plan, (slice(1, 39), slice(38, 39)))
    for tolerance, expected in ((1, EogState.ARCHITECTURAL), (0, EogState.OCCUPIED)):
        grid = EnhancedOccupancyGrid(plan, RES, wall_tolerance_cells=tolerance)
        grid.integrate(_scan(cells, (2.05, 2.05, 0.0)), (2.05, 2.05, 0.0))
        assert _state_at(grid, grid.states(), 3.85, 2.05) == expected
        assert _state_at(grid, grid.observation_states(), 3.85, 2.05) == EogState.OCCUPIED


def test_plan_conflicts_are_plan_walls_seen_free() -> None:
    walls = np.zeros((40, 40), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    walls[:, 20] = True  # the plan shows a wall through the middle of the room ...
    plan = PlanMap.from_raster(PlanRaster(walls, RES, (0.0, 0.0, 0.0)))
    cells = _world_cells(_room_plan(), None)  # ... which the building does not have
    grid = EnhancedOccupancyGrid(plan, RES)
    grid.integrate(_scan(cells, (1.05, 2.05, 0.0)), (1.05, 2.05, 0.0))
    conflicts = grid.plan_conflicts()
    assert conflicts.sum() >= 30
    ox, oy = grid.origin
    cols = np.argwhere(conflicts)[:, 1]
    assert np.all(np.isclose(ox + (cols + 0.5) * RES, 2.05))
    assert (grid.states()[conflicts] == EogState.ARCHITECTURAL).all()


def test_laser_scan_input_with_no_returns() -> None:
    plan = _room_plan()
    grid = EnhancedOccupancyGrid(plan, RES, margin=0.0, no_return_range=1.0)
    # Four beams from (2.05, 2.05) along +x, +y, -x, -y: a return at 1.0 m, no return (+inf),
    # a return beyond range_max (no return), and -inf (too close: skipped).
    ranges = np.array([1.0, np.inf, 9.0, -np.inf])
    grid.integrate_ranges(ranges, 0.0, math.pi / 2, (2.05, 2.05, 0.0), range_min=0.1, range_max=5.0)
    obs = grid.observation_states()
    assert obs[20, 30] == EogState.OCCUPIED and (obs[20, 20:30] == EogState.FREE).all()
    assert (obs[20:31, 20] == EogState.FREE).all() and obs[31, 20] == EogState.UNKNOWN  # +inf: 1 m cleared
    assert (obs[20, 10:20] == EogState.FREE).all() and obs[20, 9] == EogState.UNKNOWN  # beyond range_max
    assert (obs[:20, 20] == EogState.UNKNOWN).all()  # -inf: nothing
    # Without no_return_range, beams without a return change nothing.
    quiet = EnhancedOccupancyGrid(plan, RES, margin=0.0)
    quiet.integrate_ranges(np.array([np.inf, np.nan]), 0.0, 0.1, (2.05, 2.05, 0.0), range_min=0.1, range_max=5.0)
    assert (quiet.observation_states() == EogState.UNKNOWN).all()
    # A laser mounted backwards on the base: its beam 0 looks along -x.
    back = EnhancedOccupancyGrid(plan, RES, margin=0.0)
    back.integrate_ranges(
        [1.0], 0.0, 0.1, (2.05, 2.05, 0.0), range_min=0.1, range_max=5.0, laser_pose=(0.0, 0.0, math.pi)
    )
    assert back.observation_states()[20, 10] == EogState.OCCUPIED


def test_the_grid_grows_and_keeps_plan_and_observations() -> None:
    plan = _room_plan()
    grid = EnhancedOccupancyGrid(plan, RES, margin=0.0)
    grid.integrate([[0.7, 0.0]], (1.05, 2.05, 0.0))
    grid.integrate([[10.0, 0.0]], (1.05, 2.05, 0.0))  # a return 7 m outside the room
    xmin, ymin, xmax, ymax = grid.extent
    assert xmax >= 11.05 and xmin == 0.0 and ymin == 0.0 and ymax == 4.0
    assert _state_at(grid, grid.states(), 11.05, 2.05) == EogState.OCCUPIED
    # The first hit, passed by the second beam: one hit and one miss.
    assert grid.probabilities()[20, 17] == pytest.approx(1 / (1 + (0.3 / 0.7) * (0.6 / 0.4)), abs=1e-6)
    assert _state_at(grid, grid.states(), 3.95, 0.05) == EogState.ARCHITECTURAL
    assert grid.plan_walls().sum() == plan.raster.walls.sum()  # type: ignore[union-attr]


def test_cell_budget_refuses_a_scan_and_keeps_the_grid() -> None:
    grid = EnhancedOccupancyGrid(_room_plan(), RES, margin=0.0, max_cells=2000)
    grid.integrate([[0.7, 0.0]], (1.05, 2.05, 0.0))
    before = grid.probabilities()
    with pytest.raises(PlanicpError, match="would need .* cells \\(limit 2000\\)"):
        grid.integrate([[25.0, 0.0]], (1.05, 2.05, 0.0))
    np.testing.assert_array_equal(grid.probabilities(), before)
    assert grid.scans == 1


def test_plan_walls_at_other_resolutions() -> None:
    plan = _room_plan()  # 0.1 m pixels
    fine = EnhancedOccupancyGrid(plan, 0.025, margin=0.0)
    walls = fine.plan_walls()
    assert walls.shape == (160, 160)
    assert walls[:, :4].all() and not walls[4:-4, 4:-4].any()  # each wall pixel is 4 x 4 fine cells
    assert walls.sum() == 16 * plan.raster.walls.sum()  # type: ignore[union-attr]
    coarse = EnhancedOccupancyGrid(plan, 0.2, margin=0.0)
    assert coarse.shape == (20, 20)
    assert coarse.plan_walls()[:, 0].all() and not coarse.plan_walls()[1:-1, 1:-1].any()
    # A plan of points (no raster): the cells holding wall points.
    square = [[[0, 0], [4, 0]], [[4, 0], [4, 4]], [[4, 4], [0, 4]], [[0, 4], [0, 0]]]
    points_plan = PlanMap.from_segments(np.array(square, dtype=float), spacing=0.02)
    g = EnhancedOccupancyGrid(points_plan, RES, margin=0.5)
    assert g.origin == pytest.approx((-0.5, -0.5))
    assert _state_at(g, g.states(), 2.0, 0.0) == EogState.ARCHITECTURAL
    assert _state_at(g, g.states(), 2.0, 2.0) == EogState.UNKNOWN


def test_ros_export_round_trips(tmp_path: Path) -> None:
    plan = _room_plan()
    cells = _world_cells(plan, (slice(15, 20), slice(25, 30)))
    grid = EnhancedOccupancyGrid(plan, RES)
    grid.integrate(_scan(cells, (1.05, 1.75, 0.0)), (1.05, 1.75, 0.0))
    msg = grid.to_occupancy_grid()
    states = grid.states()
    assert msg.data.dtype == np.int8 and (msg.height, msg.width) == grid.shape
    assert msg.origin == (grid.origin[0], grid.origin[1], 0.0) and msg.resolution == RES
    np.testing.assert_array_equal(msg.data == -1, states == EogState.UNKNOWN)
    np.testing.assert_array_equal(msg.data == 0, states == EogState.FREE)
    np.testing.assert_array_equal(msg.data == 100, states >= EogState.OCCUPIED)
    yaml_path = grid.to_ros_map(tmp_path / "eog.yaml")
    back = read_ros_map(yaml_path)
    np.testing.assert_array_equal(back.occupancy[::-1], msg.data)
    assert back.resolution == RES and back.origin == pytest.approx(msg.origin)
    # The exported map is a plan again: its walls are the plan's walls plus the cabinet.
    reread = PlanMap.from_ros_map(yaml_path, cache=False)
    assert reread.raster is not None
    np.testing.assert_array_equal(reread.raster.walls[::-1], states >= EogState.OCCUPIED)


def test_png_uses_the_thesis_colours(tmp_path: Path) -> None:
    import cv2

    plan = _room_plan()
    grid = EnhancedOccupancyGrid(plan, RES)
    cells = _world_cells(plan, (slice(15, 20), slice(25, 30)))
    grid.integrate(_scan(cells, (1.05, 1.75, 0.0)), (1.05, 1.75, 0.0))
    path = grid.to_png(tmp_path / "eog.png", scale=2)
    bgr = cv2.imread(str(path))
    assert bgr is not None
    rgb = bgr[:, :, ::-1]
    states = grid.states()
    assert rgb.shape == (2 * states.shape[0], 2 * states.shape[1], 3)
    top_left = rgb[::2, ::2][::-1]  # back to rows growing with +y
    for state in EogState:
        assert (states == state).any()
        np.testing.assert_array_equal(
            top_left[states == state], np.tile(STATE_COLOURS[state], ((states == state).sum(), 1))
        )
    assert STATE_COLOURS[EogState.ARCHITECTURAL][2] > 200  # blue
    with pytest.raises(ValueError, match="must end in .png"):
        grid.to_png(tmp_path / "eog.jpeg")
    with pytest.raises(ValueError, match="scale must be at most 64"):
        grid.to_png(tmp_path / "eog.png", scale=65)
    (tmp_path / "file").write_text("")
    with pytest.raises(OSError):
        grid.to_png(tmp_path / "file" / "eog.png")  # a file stands where the folder should be
    with pytest.MonkeyPatch.context() as patch:  # OpenCV reporting a failed write (full disk, ...)
        patch.setattr(cv2, "imwrite", lambda *args: False)
        with pytest.raises(OSError, match="could not write the PNG"):
            grid.to_png(tmp_path / "again.png")
    fig = plot_eog(grid, title="room")
    assert fig.axes[0].get_title() == "room"
    assert len(plot_eog_comparison({"a": grid, "b": grid}).axes) == 2


def test_compare_grids() -> None:
    plan = _room_plan()
    cells = _world_cells(plan, (slice(15, 20), slice(25, 30)))
    poses = [(1.05, 1.75, 0.0), (1.55, 3.05, -0.3), (2.05, 0.75, 1.0)]

    def build(shift: float) -> EnhancedOccupancyGrid:
        g = EnhancedOccupancyGrid(plan, RES)
        for pose in poses:
            g.integrate(_scan(cells, pose), (pose[0] + shift, pose[1] + shift, pose[2]))
        return g

    reference = build(0.0)
    same = compare_grids(build(0.0), reference)
    assert same.occupied_near_reference == 1.0 and same.free_in_reference == 1.0
    assert same.occupied_cells > 50 and same.free_cells > 500
    near = compare_grids(build(0.1), reference)  # one cell off
    assert near.occupied_near_reference > 0.9
    far = compare_grids(build(0.45), reference)
    assert far.occupied_near_reference < 0.5 < near.occupied_near_reference
    assert far.free_in_reference < same.free_in_reference
    assert set(same.as_dict()) == {"occupied_near_reference", "free_in_reference", "occupied_cells", "free_cells"}
    with pytest.raises(ValueError, match="differ in resolution"):
        compare_grids(EnhancedOccupancyGrid(plan, 0.05), reference)
    shifted = PlanMap.from_raster(PlanRaster(plan.raster.walls, RES, (0.03, 0.0, 0.0)))  # type: ignore[union-attr]
    with pytest.raises(ValueError, match="do not line up"):
        compare_grids(EnhancedOccupancyGrid(shifted, RES), reference)
    empty = compare_grids(EnhancedOccupancyGrid(plan, RES), reference)
    assert math.isnan(empty.occupied_near_reference) and empty.free_cells == 0


def test_bad_input_is_refused_with_a_clear_message() -> None:
    plan = _room_plan()
    with pytest.raises(TypeError, match="plan must be a PlanMap"):
        EnhancedOccupancyGrid("plan.png", RES)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="resolution must be a positive"):
        EnhancedOccupancyGrid(plan, 0.0)
    with pytest.raises(ValueError, match="margin"):
        EnhancedOccupancyGrid(plan, RES, margin=-1.0)
    with pytest.raises(ValueError, match="no_return_range"):
        EnhancedOccupancyGrid(plan, RES, no_return_range=math.inf)
    with pytest.raises(ValueError, match="max_cells must be at least 1"):
        EnhancedOccupancyGrid(plan, RES, max_cells=0)
    with pytest.raises(PlanicpError, match="would need"):
        EnhancedOccupancyGrid(plan, 0.001, max_cells=1000)
    with pytest.raises(ValueError, match="p_miss < 0.5 < p_hit"):
        OccupancyModel(p_hit=0.4)
    with pytest.raises(ValueError, match="free_threshold < occupied_threshold"):
        OccupancyModel(free_threshold=0.6, occupied_threshold=0.55)
    with pytest.raises(ValueError, match="strictly between 0 and 1"):
        OccupancyModel(p_max=1.0)
    grid = EnhancedOccupancyGrid(plan, RES)
    with pytest.raises(ValueError, match="scan_xy must have shape"):
        grid.integrate(np.zeros((3, 3)), (1.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="scan_xy has a non-finite"):
        grid.integrate([[np.nan, 1.0]], (1.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="pose must be finite"):
        grid.integrate([[1.0, 1.0]], (np.inf, 1.0, 0.0))
    with pytest.raises(ValueError, match="sensor_offset must be"):
        grid.integrate([[1.0, 1.0]], (1.0, 1.0, 0.0), sensor_offset=(1.0,))
    with pytest.raises(PlanicpError, match="beyond"):
        grid.integrate([[1e10, 1.0]], (1.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="range_min < range_max"):
        grid.integrate_ranges([1.0], 0.0, 0.1, (1.0, 1.0, 0.0), range_min=2.0, range_max=1.0)
    with pytest.raises(ValueError, match="one-dimensional"):
        grid.integrate_ranges([[1.0]], 0.0, 0.1, (1.0, 1.0, 0.0), range_min=0.1, range_max=5.0)
    with pytest.raises(TypeError, match="ranges must hold real numbers"):
        grid.integrate_ranges(["a"], 0.0, 0.1, (1.0, 1.0, 0.0), range_min=0.1, range_max=5.0)
    assert grid.scans == 0
    # An empty scan is a valid scan that observes nothing but the sensor's own cell is untouched too.
    grid.integrate(np.zeros((0, 2)), (1.05, 1.05, 0.0))
    assert grid.scans == 1 and (grid.observation_states() == EogState.UNKNOWN).all()
