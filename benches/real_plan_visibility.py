#!/usr/bin/env python3
"""The visibility step on plans made from real buildings, against matching without it.

Each plan is a ROS map or plan image: Willow Garage (BSD, its own furniture is in the map), nav2's
depot and tb3_sandbox (Apache-2.0), the HouseExpo sample (MIT, its outline rendered with 15 cm
walls), all in tests/data, plus any --map. Scans are
simulated in the map itself (occupied cells are walls, unknown cells block beams but are not in
the plan), with --people discs of 0.15-0.35 m radius standing in free space that are not in the
plan. The guess is 0.2 m and 3 deg off; success = < 5 cm and < 0.5 deg.

    python benches/real_plan_visibility.py [--map other.yaml] [--poses 40]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

import planicp
from planicp import PlanMap, read_ros_map, sim

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"


def floor_from_map(yaml_path: Path) -> tuple[sim.Floor, PlanMap]:
    ros = read_ros_map(yaml_path)
    up = np.pad(ros.occupancy[::-1], 3, constant_values=-1)
    corner = (ros.origin[0] - 3 * ros.resolution, ros.origin[1] - 3 * ros.resolution)
    return sim.Floor(up == 100, up == -1, ros.resolution, corner), PlanMap.from_ros_map(yaml_path, cache=False)


def floor_from_image(path: Path, resolution: float) -> tuple[sim.Floor, PlanMap]:
    plan = PlanMap.from_image(path, resolution, walls="all-dark", cache=False)  # maps, not drawings
    assert plan.raster is not None
    up = np.pad(plan.raster.walls[::-1], 3, constant_values=False)
    frame = np.pad(np.zeros_like(plan.raster.walls), 3, constant_values=True)  # closes the image's edges
    return sim.Floor(up, frame, resolution, (-3 * resolution, -3 * resolution)), plan


def floor_from_house_expo(path: Path, resolution: float = 0.05) -> tuple[sim.Floor, PlanMap]:
    """The HouseExpo outline (free space) rendered at `resolution` with 0.15 m walls around it; the
    plan is that rendering (both wall faces), so that plan and simulated building agree exactly."""
    import cv2

    segments, (xmin, ymin, xmax, ymax) = planicp.plans.vector_plan.house_expo_segments(path)
    margin = 1.0
    cols = int(math.ceil((xmax - xmin + 2 * margin) / resolution))
    rows = int(math.ceil((ymax - ymin + 2 * margin) / resolution))
    corner = (xmin - margin, ymin - margin)
    polygon = np.round((segments[:, 0, :] - corner) / resolution).astype(np.int32)  # rows grow with y
    inside = np.zeros((rows, cols), np.uint8)
    cv2.fillPoly(inside, [polygon], 1)
    band = int(round(0.15 / resolution))
    walls = cv2.dilate(inside, np.ones((2 * band + 1, 2 * band + 1), np.uint8)).astype(bool) & ~inside.astype(bool)
    frame = np.ones_like(walls)
    frame[3:-3, 3:-3] = False
    plan = PlanMap.from_raster(planicp.PlanRaster(walls[::-1], resolution, (corner[0], corner[1], 0.0)))
    return sim.Floor(walls, frame, resolution, corner), plan


def people(floor: sim.Floor, rng: np.random.Generator, count: int, robot: tuple[float, ...]) -> np.ndarray:
    """`count` discs in free space, none within 1 m of the robot."""
    discs: list[tuple[float, float, float]] = []
    while len(discs) < count:
        x, y, _ = floor.sample_pose(rng, clearance=0.5)
        if math.hypot(x - robot[0], y - robot[1]) > 1.0:
            discs.append((x, y, float(rng.uniform(0.15, 0.35))))
    return np.array(discs).reshape(-1, 3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--map", action="append", default=[], help="extra ROS map YAML")
    parser.add_argument("--poses", type=int, default=40)
    parser.add_argument("--people", type=int, default=15)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    floors = {
        "willow (0.1 m)": floor_from_image(DATA / "willow-full.pgm", 0.1),
        "depot (0.05 m)": floor_from_map(DATA / "depot.yaml"),
        "tb3_sandbox (0.05 m)": floor_from_map(DATA / "tb3_sandbox.yaml"),
        "HouseExpo 4 rooms (0.05 m)": floor_from_house_expo(DATA / "house_expo_room_0000.json"),
    }
    for extra in args.map:
        floors[Path(extra).name] = floor_from_map(Path(extra))
    kd = planicp.IcpConfig(correspondence_search="kd_tree")
    configs = {
        "0.25 m, visibility": kd,
        "0.25 m, no visibility": kd.replace(use_visibility=False),
        "0.25 m, wall index": planicp.IcpConfig(),
        "0.4 m, visibility": kd.replace(max_correspondence_distance=0.4),
        "0.4 m, no visibility": kd.replace(max_correspondence_distance=0.4, use_visibility=False),
        "0.4 m, wall index": planicp.IcpConfig(max_correspondence_distance=0.4),
    }
    print(f"{args.poses} poses per plan, {args.people} people not in the plan, guess 0.2 m / 3 deg off\n")
    print("| plan | wall points | " + " | ".join(configs) + " |")
    print("|---|---|" + "---|" * len(configs))
    for name, (floor, plan) in floors.items():
        rng = np.random.default_rng(args.seed)
        ok = dict.fromkeys(configs, 0)
        ms = {k: [] for k in configs}
        for _ in range(args.poses):
            truth = floor.sample_pose(rng, clearance=0.6)
            scan, _ = sim.simulate_scan(floor, truth, rng, dynamic_discs=people(floor, rng, args.people, truth))
            guess = sim.perturb_pose(truth, rng, 0.2, math.radians(3.0))
            for key, config in configs.items():
                t0 = time.perf_counter()
                result = planicp.localize(scan, plan, guess, config)
                ms[key].append(1e3 * (time.perf_counter() - t0))
                dx, dy, dyaw = planicp.se2.between(truth, result.pose)
                ok[key] += math.hypot(dx, dy) < 0.05 and abs(dyaw) < math.radians(0.5)
        cells = " | ".join(f"{100 * ok[k] / args.poses:.0f} % ({np.median(ms[k]):.1f} ms)" for k in configs)
        print(f"| {name} | {len(plan)} | {cells} |", flush=True)


if __name__ == "__main__":
    main()
