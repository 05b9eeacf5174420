#!/usr/bin/env python3
"""A drawn plan read as a SLAM map: what the reading of a map_server map's cells costs.

The demo's drive through the shipped office plan (`run_experiment`, the demo's sensor, odometry
and furnished world; the plan shows only the walls) is tracked by a `Localizer` with its defaults
on the same map_server map read four ways: as its YAML says (`planicp_edge_detector: auto`: the
faces of its thick walls, a drawing); with that key taken out of the YAML, as a user's map of a
drawing would come (the reading `PlanMap.from_ros_map` recognises from the cells); as a SLAM map's
cells (`edge_detector="centres"`: every occupied cell's centre, whose likelihood field is the
cells' density, peaked inside a wall's band); and as centres with the nearest-cell field in place
of the density. Printed: the reading and the position error RMS and max of each (centimetres).

`--shares` prints instead, for each map given (a map_server YAML, or an image read as a drawing
with `PlanMap.from_image`'s defaults), the share of its occupied cells inside walls (all four
neighbours occupied: `planicp.plans.ros_map.inside_share`) by which a map that says nothing is
read as a SLAM map or a drawing.

    python benches/plan_reading.py [--duration 60] [--seed 1]
    python benches/plan_reading.py --shares MAP.yaml DRAWING.png ...
"""

from __future__ import annotations

import argparse
import math
import shutil
import tempfile
from pathlib import Path

import numpy as np

from planicp import Localizer, PlanMap, _core
from planicp.plans.default_plan import default_plan_path, load_default_plan
from planicp.plans.ros_map import inside_share, read_ros_map
from planicp.sim.experiment import ExperimentConfig, Recording, run_experiment


def tracked(plan: PlanMap, recording: Recording) -> tuple[float, float]:
    """(RMS, max) of the position error in metres of a default `Localizer` on `plan`."""
    localizer = Localizer(plan, tuple(recording.truth[0]))
    errors = []
    for scan, odom, truth in zip(recording.scans, recording.odometry_in_odom, recording.truth):
        pose = localizer.update(scan, tuple(odom)).pose
        errors.append(math.hypot(pose[0] - truth[0], pose[1] - truth[1]))
    e = np.array(errors)
    return float(np.sqrt(np.mean(e**2))), float(e.max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=60.0, help="seconds of the drive")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--shares", nargs="+", metavar="MAP", help="print the maps' shares of cells inside walls")
    args = parser.parse_args()
    if args.shares:
        for name in args.shares:
            if name.endswith((".yaml", ".yml")):
                walls = read_ros_map(name).wall_raster().walls
            else:
                raster = PlanMap.from_image(name, resolution=0.02, cache=False).raster
                assert raster is not None  # an image's plan keeps its raster
                walls = raster.walls
            print(f"{name}: {100 * inside_share(walls):.1f} % of {int(walls.sum())} occupied cells inside walls")
        return
    recording, _ = run_experiment(load_default_plan(), ExperimentConfig(duration_s=args.duration, seed=args.seed))
    drawn = PlanMap.from_ros_map(default_plan_path(), cache=False)
    with tempfile.TemporaryDirectory() as folder:
        shutil.copy(default_plan_path().with_suffix(".png"), folder)
        keyless = Path(folder) / "office_plan.yaml"
        keyless.write_text(
            "".join(line for line in default_plan_path().read_text().splitlines(True) if "planicp_" not in line)
        )
        unsaid = PlanMap.from_ros_map(keyless, cache=False)
    centres = PlanMap.from_ros_map(default_plan_path(), edge_detector="centres", cache=False)
    nearest = PlanMap.from_ros_map(default_plan_path(), edge_detector="centres", cache=False)
    # The field a drawing gets, in place of the density a SLAM map's cells get (an ablation).
    nearest._likelihood = _core.LikelihoodGrid.within_budget(nearest.points, nearest.spacing, nearest.spacing)
    print(f"{len(recording.scans)} scans")
    for label, plan in (
        ("as the YAML says", drawn),
        ("without the YAML's key", unsaid),
        ("as a SLAM map's cells (density field)", centres),
        ("as a SLAM map's cells, nearest-cell field", nearest),
    ):
        rms, worst = tracked(plan, recording)
        print(f"{label:42s} {plan.edge_detector:8s} RMS {100 * rms:5.2f} cm, max {100 * worst:5.1f} cm", flush=True)


if __name__ == "__main__":
    main()
