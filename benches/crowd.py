#!/usr/bin/env python3
"""People crowding the sensor: tracking error against the share of returns they block.

A 30 s drive on the shipped office plan without furniture; for every scan, N people (discs of
0.18-0.25 m) stand at random free places 0.7-3 m around the robot, blocking part of the beams.
For each N the same scans and odometry are tracked with plain ICP (`IcpConfig(correspondence_search="kd_tree")`, no occlusion
rule), automatic trimming alone (`IcpConfig.for_tracking()`, no occlusion rule), and the
`Localizer`'s defaults (automatic trimming and `OcclusionRule`, which leaves out the returns in
front of the plan's walls); printed: the mean share of blocked returns and the position error RMS /
max in centimetres.

    python benches/crowd.py
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planicp import IcpConfig, Localizer, _core, scan_to_points
from planicp.default_plan import load_default_plan
from planicp.se2 import compose
from planicp.sim.experiment import ExperimentConfig, run_experiment
from planicp.sim.world import Furnishing

VARIANTS: dict[str, dict[str, Any]] = {
    "plain ICP": {"config": IcpConfig(correspondence_search="kd_tree"), "occlusion": False},
    "auto trim only": {"config": IcpConfig.for_tracking(), "occlusion": False},
    "default (+ occlusion)": {},
}


def main() -> None:
    plan = load_default_plan()
    config = ExperimentConfig(duration_s=30.0, seed=2, furnishing=Furnishing(0, 0, 0, 0))
    recording, world = run_experiment(plan, config)
    lidar, floor = config.lidar, world.floor
    grid = _core.OccupancyGrid(np.ascontiguousarray(floor.occupied()), floor.resolution, floor.origin)
    free = ~floor.occupied()

    def crowd(rng: np.random.Generator, pose: NDArray[np.float64], count: int) -> NDArray[np.float64] | None:
        discs: list[tuple[float, float, float]] = []
        while len(discs) < count:
            r, a = rng.uniform(0.7, 3.0), rng.uniform(-math.pi, math.pi)
            x, y = pose[0] + r * math.cos(a), pose[1] + r * math.sin(a)
            col, row = int((x - floor.origin[0]) / floor.resolution), int((y - floor.origin[1]) / floor.resolution)
            if 0 <= row < free.shape[0] and 0 <= col < free.shape[1] and free[row, col]:
                discs.append((x, y, rng.uniform(0.18, 0.25)))
        return np.array(discs) if discs else None

    print(f"{'people':>6s} {'blocked':>8s}  " + "  ".join(f"{name:>22s}" for name in VARIANTS))
    for count in (0, 10, 20, 25, 30, 40):
        rng = np.random.default_rng(0)
        scans, blocked = [], []
        for k, truth in enumerate(recording.truth):
            sensor = compose(tuple(truth), lidar.mount)
            args = (sensor, lidar.angle_min, lidar.angle_increment, lidar.beams, lidar.range_min, lidar.range_max)
            clear = grid.cast(*args, 0.0, 0.0, 1)
            ranges = grid.cast(*args, lidar.range_sigma, 0.0, k, crowd(rng, truth, count))
            blocked.append(np.mean(ranges < clear - 0.05))
            scans.append(scan_to_points(ranges, lidar.angle_min, lidar.angle_increment, lidar.range_min,
                                        lidar.range_max, sensor_pose=lidar.mount))
        cells = []
        for options in VARIANTS.values():
            localizer = Localizer(plan, tuple(recording.truth[0]), **options)
            poses = np.array([localizer.update(s, tuple(o)).pose for s, o in zip(scans, recording.odometry_in_odom)])
            err = np.hypot(*(poses[:, :2] - recording.truth[:, :2]).T)
            cells.append(f"{100 * np.sqrt(np.mean(err ** 2)):8.2f} / {100 * err.max():6.1f} cm")
        print(f"{count:6d} {100 * np.mean(blocked):7.0f}%  " + "  ".join(f"{c:>22s}" for c in cells))


if __name__ == "__main__":
    main()
