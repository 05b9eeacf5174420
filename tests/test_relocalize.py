"""Tests of global relocalization (`planicp.relocalize`): no-guess localization on the shipped
office plan and on a real SLAM map, ranked candidates and ambiguity in a symmetric room, search
regions, the result's structure, and every rejected input.

Scans are simulated by the native ray caster in the plan's own raster: a 270-degree, 1081-beam,
30 m LIDAR with 1 cm range noise, sensor at the base. "Correct" is < 10 cm and < 2 deg.

"Unambiguous" is defined without trusting the method under test: a pose counts as ambiguous only
when the method's best candidate is elsewhere AND that other pose explains the scan at least as
well as the true pose does (its inlier ratio >= ICP-from-the-truth's inlier ratio minus the
ambiguity margin): then the plan has another place that looks the same, which no method can tell
apart from one scan. Such poses are excluded from the success rate, and their number is bounded too.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

import planicp
from planicp import (
    Candidate,
    IcpConfig,
    IcpResult,
    PlanicpError,
    PlanMap,
    PlanRaster,
    Relocalization,
    RelocalizationConfig,
    SearchInSteps,
    SearchRegion,
    read_ros_map,
    relocalize,
    scan_to_points,
    synthetic,
)
from planicp._core import OccupancyGrid
from planicp.plans.default_plan import load_default_plan
from planicp.se2 import between
from planicp.sim.experiment import ExperimentConfig, run_experiment

DATA = Path(__file__).parent / "data"
FOV = math.radians(270.0)
BEAMS = 1081
TOL_M = 0.10
TOL_RAD = math.radians(2.0)

Pose = tuple[float, float, float]


class Simulator:
    """A floor to draw poses in and the native ray caster over it."""

    def __init__(self, floor: synthetic.Floor) -> None:
        self.floor = floor
        self.grid = OccupancyGrid(np.ascontiguousarray(floor.occupied()), floor.resolution, floor.origin)

    def scan(self, pose: Pose, seed: int, fov: float = FOV, beams: int = BEAMS) -> NDArray[np.float64]:
        inc = fov / (beams - 1) if fov < 2 * math.pi else fov / beams
        ranges = self.grid.cast(pose, -fov / 2, inc, beams, 0.05, 30.0, 0.01, 0.0, seed)
        return scan_to_points(ranges, -fov / 2, inc, 0.05, 30.0)

    def draw(self, plan: PlanMap, rng: np.random.Generator, seed: int) -> tuple[Pose, NDArray[np.float64], float]:
        """A free pose inside the mapped building (the plan explains >= 80 % of its scan at the truth:
        excludes stray free streaks outside the walls of SLAM maps), its scan, ICP-at-truth inliers."""
        for k in range(200):
            truth = self.floor.sample_pose(rng, clearance=0.4)
            scan = self.scan(truth, seed + k)
            at_truth = planicp.localize(scan, plan, truth).inlier_ratio
            if at_truth >= 0.8:
                return truth, scan, at_truth
        raise AssertionError("no pose inside the mapped building")


def _floor_of_plan(plan: PlanMap) -> synthetic.Floor:
    assert plan.raster is not None
    walls = np.pad(plan.raster.walls[::-1], 3, constant_values=False)
    frame = np.pad(np.zeros_like(plan.raster.walls), 3, constant_values=True)
    res = plan.raster.resolution
    ox, oy, _ = plan.raster.origin
    return synthetic.Floor(walls, frame, res, (ox - 3 * res, oy - 3 * res))


def _floor_of_ros_map(yaml_path: Path) -> synthetic.Floor:
    """Occupied cells are walls; unknown cells block beams but are not in the plan."""
    ros = read_ros_map(yaml_path)
    up = np.pad(ros.occupancy[::-1], 3, constant_values=-1)
    corner = (ros.origin[0] - 3 * ros.resolution, ros.origin[1] - 3 * ros.resolution)
    return synthetic.Floor(up == 100, up == -1, ros.resolution, corner)


def _close(a: Pose, b: Pose, metres: float = TOL_M, radians: float = TOL_RAD) -> bool:
    dx, dy, dyaw = between(a, b)
    return math.hypot(dx, dy) < metres and abs(dyaw) < radians


def _global_success(plan: PlanMap, sim: Simulator, poses: int, seed: int) -> tuple[int, int, int, list[float]]:
    """(correct, wrong, ambiguous scans, seconds per call) over `poses` random poses."""
    rng = np.random.default_rng(seed)
    margin = RelocalizationConfig().ambiguity_margin
    correct = wrong = ambiguous = 0
    seconds = []
    for k in range(poses):
        truth, scan, at_truth = sim.draw(plan, rng, seed * 10_000 + 1000 * k)
        found = relocalize(scan, plan)
        seconds.append(found.seconds)
        best = found.best
        assert best is not None, f"pose {k} {truth}: no candidate at all"
        if _close(best.pose, truth):
            correct += 1
        elif best.score >= at_truth * (1.0 - margin):
            ambiguous += 1
        else:
            wrong += 1
    return correct, wrong, ambiguous, seconds


@pytest.fixture(scope="module")
def office() -> tuple[PlanMap, Simulator]:
    plan = load_default_plan()
    return plan, Simulator(_floor_of_plan(plan))


@pytest.fixture(scope="module")
def depot() -> tuple[PlanMap, Simulator]:
    path = DATA / "depot.yaml"
    return PlanMap.from_ros_map(path, cache=False), Simulator(_floor_of_ros_map(path))


def _rectangle_room() -> PlanMap:
    """A 10 x 6 m empty room (0.1 m pixels, one-pixel walls): symmetric under a half turn."""
    walls = np.zeros((62, 102), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    return PlanMap.from_raster(PlanRaster(walls, 0.1, (0.0, 0.0, 0.0)))


# -- global localization ------------------------------------------------------------------------------


def test_default_plan_global_localization(office: tuple[PlanMap, Simulator]) -> None:
    plan, sim = office
    correct, wrong, ambiguous, seconds = _global_success(plan, sim, poses=25, seed=1)
    unambiguous = correct + wrong
    assert unambiguous >= 20, f"only {unambiguous} of 25 poses unambiguous ({ambiguous} ambiguous)"
    assert correct / unambiguous >= 0.9, f"{correct}/{unambiguous} correct, {wrong} wrong"
    assert float(np.median(seconds)) < 2.0, f"median {np.median(seconds):.2f} s"


def test_real_map_global_localization(depot: tuple[PlanMap, Simulator]) -> None:
    plan, sim = depot
    correct, wrong, ambiguous, seconds = _global_success(plan, sim, poses=25, seed=2)
    unambiguous = correct + wrong
    assert unambiguous >= 20, f"only {unambiguous} of 25 poses unambiguous ({ambiguous} ambiguous)"
    assert correct / unambiguous >= 0.9, f"{correct}/{unambiguous} correct, {wrong} wrong"
    assert float(np.median(seconds)) < 2.0, f"median {np.median(seconds):.2f} s"


def test_best_candidate_is_precise_and_ranked(office: tuple[PlanMap, Simulator]) -> None:
    plan, sim = office
    truth = (6.3, 8.1, 0.9)
    found = relocalize(sim.scan(truth, seed=5), plan)
    assert isinstance(found, Relocalization)
    best = found.best
    assert best is not None and best is found.candidates[0]
    assert _close(best.pose, truth, 0.03, math.radians(0.5)), best
    assert best.score > 0.9 and best.rmse < 0.03
    scores = [c.score for c in found.candidates]
    assert scores == sorted(scores, reverse=True)
    for c in found.candidates:
        assert isinstance(c, Candidate) and isinstance(c.result, IcpResult)
        assert c.inlier_ratio == c.score == c.result.inlier_ratio
        assert c.pose == c.result.pose
        assert 0.0 <= c.search_score <= 1.0
    assert 0.0 <= found.ambiguity <= 1.0
    assert found.complete and found.rotations > 100 and found.nodes > 0 and found.seconds > 0
    assert 10 <= found.scan_points <= RelocalizationConfig().max_scan_points
    with pytest.raises(dataclasses.FrozenInstanceError):
        found.ambiguous = True  # type: ignore[misc]
    assert "Relocalization(best=Candidate(pose=" in repr(found)


# -- symmetry and regions -----------------------------------------------------------------------------


def test_symmetric_room_gives_ranked_candidates_and_is_ambiguous() -> None:
    plan = _rectangle_room()
    sim = Simulator(_floor_of_plan(plan))
    truth = (3.2, 1.9, 0.5)
    mirrored = (10.2 - truth[0], 6.2 - truth[1], truth[2] - math.pi)
    scan = sim.scan(truth, seed=3, fov=2 * math.pi, beams=720)
    found = relocalize(scan, plan)
    assert len(found.candidates) >= 2
    assert found.ambiguous and found.ambiguity > 0.95, found
    top_two = [c.pose for c in found.candidates[:2]]
    for p in (truth, mirrored):
        assert any(_close(q, p, 0.05, math.radians(1.0)) for q in top_two), (p, top_two)
    assert abs(found.candidates[0].score - found.candidates[1].score) < 0.05


def test_a_region_resolves_the_symmetry_and_stays_inside() -> None:
    plan = _rectangle_room()
    sim = Simulator(_floor_of_plan(plan))
    truth = (3.2, 1.9, 0.5)
    scan = sim.scan(truth, seed=4, fov=2 * math.pi, beams=720)
    region = SearchRegion(center=(3.5, 2.2, 0.7), radius=1.0, yaw_tolerance=math.radians(20.0))
    found = relocalize(scan, plan, region=region)
    assert found.best is not None and _close(found.best.pose, truth, 0.05, math.radians(1.0)), found
    assert not found.ambiguous
    for c in found.candidates:
        x, y, yaw = c.search_pose
        assert abs(x - 3.5) <= 1.05 and abs(y - 2.2) <= 1.05, c
        assert abs(planicp.se2.wrap_angle(yaw - 0.7)) <= math.radians(20.0) + 1e-9, c
    whole = relocalize(scan, plan)
    assert found.nodes < whole.nodes


def test_a_region_with_a_lever_finds_a_robot_whose_heading_broke(office: tuple[PlanMap, Simulator]) -> None:
    # Lost at `lost` heading 0, the odometry drove 6 m ahead and turned 0.3 rad; the heading was
    # 50 degrees off at the start, so the robot is at lost + R(50 deg) (6, 0), heading 50 deg +
    # 0.3. A 0.5 m region with that lever finds it; its candidates stay in their headings' squares.
    plan, sim = office
    lost, turn = (20.0, 5.0, 0.0), math.radians(50.0)
    truth = (lost[0] + 6.0 * math.cos(turn), lost[1] + 6.0 * math.sin(turn), turn + 0.3)
    scan = sim.scan(truth, seed=8)
    region = SearchRegion((lost[0], lost[1], 0.3), radius=0.5, lever=(6.0, 0.0))
    found = relocalize(scan, plan, region=region)
    assert found.best is not None and _close(found.best.pose, truth), found
    for c in found.candidates:
        x, y, yaw = c.search_pose
        d = yaw - 0.3
        assert abs(x - lost[0] - 6.0 * math.cos(d)) <= 0.55 and abs(y - lost[1] - 6.0 * math.sin(d)) <= 0.55, c
    # Without the lever the 0.5 m squares are around the lost pose, 6 m from the robot.
    near = relocalize(scan, plan, region=SearchRegion((lost[0], lost[1], 0.3), radius=0.5))
    assert all(not _close(c.pose, truth, 1.0, 0.5) for c in near.candidates), near
    for bad in [(1.0,), (math.nan, 0.0), 3.0]:
        with pytest.raises(ValueError, match="lever"):
            SearchRegion(lost, lever=bad)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="lever x"):
        SearchRegion(lost, lever=("a", 0.0))  # type: ignore[arg-type]


def test_max_candidates_and_config(office: tuple[PlanMap, Simulator]) -> None:
    plan, sim = office
    scan = sim.scan((20.0, 5.0, -2.0), seed=6)
    one = relocalize(scan, plan, max_candidates=1)
    assert len(one.candidates) == 1 and one.ambiguity == 0.0 and not one.ambiguous
    budget = relocalize(scan, plan, config=RelocalizationConfig(max_nodes=10))
    assert not budget.complete
    coarse = relocalize(scan, plan, config=RelocalizationConfig(resolution=0.2, sigma=0.2, levels=5))
    assert coarse.best is not None and _close(coarse.best.pose, (20.0, 5.0, -2.0))


# -- errors -------------------------------------------------------------------------------------------


def test_rejects_bad_scans(office: tuple[PlanMap, Simulator]) -> None:
    plan, _ = office
    with pytest.raises(ValueError, match="empty"):
        relocalize(np.zeros((0, 2)), plan)
    with pytest.raises(ValueError, match="shape"):
        relocalize(np.zeros((20, 3)), plan)
    nan = np.ones((50, 2))
    nan[7, 1] = np.nan
    with pytest.raises(ValueError, match="row 7"):
        relocalize(nan, plan)
    with pytest.raises(PlanicpError, match="at least 10"):
        relocalize(np.array([[1.0, 0.0], [1.0, 0.02], [0.0, 2.0]]), plan)
    with pytest.raises(TypeError):
        relocalize(np.array([["a", "b"]]), plan)


def test_rejects_bad_arguments(office: tuple[PlanMap, Simulator]) -> None:
    plan, sim = office
    scan = sim.scan((20.0, 5.0, -2.0), seed=7)
    with pytest.raises(TypeError, match="PlanMap"):
        relocalize(scan, plan.points)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="RelocalizationConfig"):
        relocalize(scan, plan, config=IcpConfig())  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="SearchRegion"):
        relocalize(scan, plan, region=(1.0, 2.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="max_candidates"):
        relocalize(scan, plan, max_candidates=0)
    with pytest.raises(TypeError, match="max_candidates"):
        relocalize(scan, plan, max_candidates=2.0)  # type: ignore[arg-type]
    for bad in [
        {"resolution": 0.0},
        {"sigma": -1.0},
        {"levels": 0},
        {"levels": 13},
        {"angular_step": math.nan},
        {"min_score": 1.0},
        {"relative_score": 1.5},
        {"nms_distance": 0.0},
        {"max_scan_points": 5},
        {"max_nodes": 0},
        {"ambiguity_margin": 1.0},
    ]:
        with pytest.raises(ValueError):
            RelocalizationConfig(**bad)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="icp"):
        RelocalizationConfig(icp={"max_iterations": 3})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="radius"):
        SearchRegion((1.0, 1.0, 0.0), radius=-1.0)
    with pytest.raises(ValueError, match="yaw_tolerance"):
        SearchRegion((1.0, 1.0, 0.0), yaw_tolerance=math.inf)
    with pytest.raises(ValueError, match="finite"):
        SearchRegion((math.nan, 1.0, 0.0))
    # A region larger than the plan is clipped to it: the whole plan's search, not an error.
    huge = relocalize(scan, plan, region=SearchRegion((1.0, 1.0, 0.0), radius=1e12))
    whole = relocalize(scan, plan)
    assert huge.nodes == whole.nodes and huge.best is not None and whole.best is not None
    assert huge.best.pose == whole.best.pose
    with pytest.raises(PlanicpError, match="resolution"):
        relocalize(scan, plan, config=RelocalizationConfig(resolution=1e-4))


def test_a_search_in_steps_finds_what_one_search_finds_within_its_budget_per_call() -> None:
    """`SearchInSteps` spreads `relocalize` over calls: each scores at most its budget of nodes
    (three more: an expansion scores four children), and the last returns the same candidates."""
    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=3.0, seed=4))
    scan = recording.scans[20]
    whole = relocalize(scan, plan)
    steps = SearchInSteps(scan, plan)
    found, calls, before = None, 0, 0
    while found is None:
        found = steps.advance(5_000)
        calls += 1
        assert steps.nodes - before <= 5_003
        before = steps.nodes
    assert calls >= whole.nodes // 5_000 and found.nodes == whole.nodes
    assert [c.pose for c in found.candidates] == [c.pose for c in whole.candidates]
    assert math.dist(found.candidates[0].pose[:2], recording.truth[20][:2]) < 0.1
    with pytest.raises(ValueError, match="budget"):
        steps.advance(0)
    with pytest.raises(ValueError, match="search_nodes"):
        planicp.RecoveryConfig(search_nodes=0)
    with pytest.raises(TypeError, match="plan must be a planicp.PlanMap"):
        SearchInSteps(scan, "plan.yaml")  # type: ignore[arg-type]


def test_a_search_in_steps_out_of_time_stops_at_its_next_check_and_goes_on_from_there() -> None:
    """With `seconds`, a call also stops where it is once that time has passed, at its next check
    (every 1024 nodes): given none, each call scores one check's worth (three more at most), and
    the calls together find what one search finds."""
    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=3.0, seed=4))
    scan = recording.scans[20]
    whole = relocalize(scan, plan)
    steps = SearchInSteps(scan, plan)
    found, before = None, 0
    while found is None:
        found = steps.advance(10**9, seconds=0.0)
        assert 1 <= steps.nodes - before <= 1024 + 3
        before = steps.nodes
    assert found.nodes == whole.nodes
    assert [c.pose for c in found.candidates] == [c.pose for c in whole.candidates]
    with pytest.raises(ValueError, match="seconds must be a finite number of seconds >= 0 or None"):
        SearchInSteps(scan, plan).advance(100, seconds=-1.0)
    with pytest.raises(ValueError, match="search_time"):
        planicp.RecoveryConfig(search_time=0.0)
    with pytest.raises(ValueError, match="search_spare_time"):
        planicp.RecoveryConfig(search_spare_time=-0.01)
    assert planicp.RecoveryConfig(search_spare_time=None).search_spare_time is None
    # An update's budget out of time scores nothing more: its searches wait for the next update.
    from planicp.tracking.recovery import SearchBudget

    spent = SearchBudget(20_000, 0, until=0.0)
    assert spent.seconds(whole_plan=True) == 0.0
    region = SearchRegion(center=tuple(map(float, recording.truth[20])), radius=1.0, yaw_tolerance=0.5)
    assert spent.search(scan, plan, region, planicp.RelocalizationConfig(), 5) is None
    assert spent.left == 20_000
