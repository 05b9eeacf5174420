#!/usr/bin/env python3
"""Global localization from no guess (`planicp.relocalize`): success rate and run time.

For each plan, random free poses (0.4 m from any wall) get a simulated 270-degree, 1081-beam,
30 m LIDAR scan with 1 cm range noise (the native ray caster, `_core.OccupancyGrid.cast`), cast in
the plan's own raster (for ROS maps, unknown cells block beams but are not in the plan). Then
`relocalize` searches the whole plan, every heading, with no guess.

Scoring (honest about symmetric buildings):
- correct: the best candidate is within --tol-cm and --tol-deg of the truth;
- ambiguous scan: the best candidate is elsewhere but explains the scan as well as the truth does
  (its inlier ratio is at least the inlier ratio of ICP started AT the truth, minus the ambiguity
  margin): the plan has another place that looks the same, no method could tell them apart from
  this scan; these poses are excluded from the success rate and counted separately;
- wrong: anything else (the best is elsewhere and explains the scan worse than the truth).
Poses are drawn inside the mapped building: a draw whose scan the plan explains poorly even at the
true pose (< 80 % ICP inliers from the truth; a stray free streak of a SLAM map, outside the walls)
is drawn again and counted as "redrawn".
Success rate = correct / (correct + wrong). The time is the wall-clock time of the `relocalize`
call (search and ICP refinement; the plan's likelihood pyramid is built once beforehand).

    python benches/global_localization.py [--poses 50] [--seed 0] [--map other.yaml]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

import planicp
from planicp import PlanMap, read_ros_map, scan_to_points, sim
from planicp._core import OccupancyGrid
from planicp.plans.default_plan import load_default_plan

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
FOV = math.radians(270.0)
BEAMS = 1081
RANGE_MAX = 30.0


def floor_from_plan(plan: PlanMap) -> sim.Floor:
    """The plan's own raster as a floor (rows growing with +y), closed by a frame (not in the plan)."""
    assert plan.raster is not None
    walls = np.pad(plan.raster.walls[::-1], 3, constant_values=False)
    frame = np.pad(np.zeros_like(plan.raster.walls), 3, constant_values=True)
    res = plan.raster.resolution
    ox, oy, _ = plan.raster.origin
    return sim.Floor(walls, frame, res, (ox - 3 * res, oy - 3 * res))


def floor_from_ros_map(yaml_path: Path) -> tuple[sim.Floor, PlanMap]:
    """Occupied cells are walls (in the plan); unknown cells block beams but are not in the plan."""
    ros = read_ros_map(yaml_path)
    up = np.pad(ros.occupancy[::-1], 3, constant_values=-1)
    corner = (ros.origin[0] - 3 * ros.resolution, ros.origin[1] - 3 * ros.resolution)
    return sim.Floor(up == 100, up == -1, ros.resolution, corner), PlanMap.from_ros_map(yaml_path, cache=False)


def simulate(grid: OccupancyGrid, pose: tuple[float, float, float], seed: int) -> np.ndarray:
    """A noisy 270-degree scan from `pose` (sensor = base), robot frame."""
    inc = FOV / (BEAMS - 1)
    ranges = grid.cast(pose, -FOV / 2, inc, BEAMS, 0.05, RANGE_MAX, 0.01, 0.0, seed)
    return scan_to_points(ranges, -FOV / 2, inc, 0.05, RANGE_MAX)


def draw_pose(
    floor: sim.Floor, grid: OccupancyGrid, plan: PlanMap, rng: np.random.Generator, seed: int
) -> tuple[tuple[float, float, float], np.ndarray, int]:
    """A random free pose (0.4 m clearance) inside the mapped building, its scan, and how many draws
    were rejected: a draw whose scan the plan explains poorly even at the true pose (ICP from the
    truth has < 80 % inliers) stands outside the mapped building (e.g. on a stray free streak of a
    SLAM map, seeing the raster's artificial frame), not a relocalization case."""
    for rejected in range(1000):
        truth = floor.sample_pose(rng, clearance=0.4)
        scan = simulate(grid, truth, seed + rejected)
        if len(scan) >= 10 and planicp.localize(scan, plan, truth).inlier_ratio >= 0.8:
            return truth, scan, rejected
    raise RuntimeError("no pose inside the mapped building")


def evaluate(
    floor: sim.Floor,
    plan: PlanMap,
    poses: int,
    seed: int,
    tol_m: float,
    tol_rad: float,
    config: planicp.RelocalizationConfig,
) -> dict[str, float]:
    grid = OccupancyGrid(np.ascontiguousarray(floor.occupied()), floor.resolution, floor.origin)
    rng = np.random.default_rng(seed)
    scan0 = simulate(grid, floor.sample_pose(rng, clearance=0.4), 1)
    planicp.relocalize(scan0, plan, config=config)  # builds and caches the likelihood pyramid
    correct = wrong = ambiguous_scan = flagged = incomplete = redrawn = 0
    times = []
    for k in range(poses):
        truth, scan, rejected = draw_pose(floor, grid, plan, rng, (seed * 1000 + k) * 1000)
        redrawn += rejected
        t0 = time.perf_counter()
        found = planicp.relocalize(scan, plan, config=config)
        times.append(time.perf_counter() - t0)
        flagged += found.ambiguous
        incomplete += not found.complete
        best = found.best
        ok = False
        if best is not None:
            dx, dy, dyaw = planicp.se2.between(truth, best.pose)
            ok = math.hypot(dx, dy) < tol_m and abs(dyaw) < tol_rad
        if ok:
            correct += 1
            continue
        at_truth = planicp.localize(scan, plan, truth, config.icp).inlier_ratio
        if best is not None and best.score >= at_truth * (1.0 - config.ambiguity_margin):
            ambiguous_scan += 1
        else:
            wrong += 1
    ms = 1e3 * np.array(times)
    return {
        "poses": poses,
        "correct": correct,
        "wrong": wrong,
        "ambiguous_scan": ambiguous_scan,
        "flagged": flagged,
        "incomplete": incomplete,
        "redrawn": redrawn,
        "rate": correct / max(1, correct + wrong),
        "median_ms": float(np.median(ms)),
        "p95_ms": float(np.percentile(ms, 95)),
        "max_ms": float(ms.max()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--tol-cm", type=float, default=10.0)
    parser.add_argument("--tol-deg", type=float, default=2.0)
    parser.add_argument("--map", action="append", default=[], help="extra ROS map YAML")
    parser.add_argument("--no-willow", action="store_true", help="skip the 54 x 59 m Willow Garage floor")
    args = parser.parse_args()
    default = load_default_plan()
    plans: dict[str, tuple[sim.Floor, PlanMap]] = {
        "default office 30 x 20 m (0.05 m)": (floor_from_plan(default), default),
        "nav2 depot (0.05 m)": floor_from_ros_map(DATA / "depot.yaml"),
    }
    if not args.no_willow:
        willow = PlanMap.from_image(DATA / "willow-full.pgm", 0.1, walls="all-dark", cache=False)  # a SLAM map
        plans["Willow Garage 54 x 59 m (0.1 m)"] = (floor_from_plan(willow), willow)
    for extra in args.map:
        plans[Path(extra).name] = floor_from_ros_map(Path(extra))
    config = planicp.RelocalizationConfig()
    print(
        f"{args.poses} random poses per plan, seed {args.seed}, 270 deg / {BEAMS} beams / {RANGE_MAX:.0f} m / "
        f"1 cm noise; correct = < {args.tol_cm:g} cm and < {args.tol_deg:g} deg; whole plan, no guess\n"
    )
    print(
        "| plan | wall points | correct | wrong | ambiguous scans (excluded) | flagged ambiguous | "
        "incomplete | redrawn poses | success (unambiguous) | median ms | p95 ms | max ms |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, (floor, plan) in plans.items():
        r = evaluate(floor, plan, args.poses, args.seed, args.tol_cm / 100, math.radians(args.tol_deg), config)
        print(
            f"| {name} | {len(plan)} | {r['correct']} | {r['wrong']} | {r['ambiguous_scan']} | {r['flagged']} | "
            f"{r['incomplete']} | {r['redrawn']} | "
            f"{100 * r['rate']:.1f} % | {r['median_ms']:.0f} | {r['p95_ms']:.0f} | {r['max_ms']:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
