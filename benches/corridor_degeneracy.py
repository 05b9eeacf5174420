#!/usr/bin/env python3
"""A long featureless corridor: does the localizer keep odometry along it instead of sliding?

A 100 m x 2 m corridor without doors, seen by a 10 m LIDAR (so its ends are out of sight except
near them), no furniture or people; good odometry (1 % noise, no drift). For three seeds and
120 simulated seconds it prints the RMS errors along the corridor (x), across it (y) and of the
heading for odometry, for planicp (the default `Localizer`, which fuses each fit with the odometry
prediction and so keeps the prediction along an axis the fit does not constrain) and for the fit
alone (`FusionRule(max_innovation=0)`, `DegeneracyRule(min_constraint=0)`: as a plain ICP tracker),
from the same scans and odometry.

    python benches/corridor_degeneracy.py
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from planicp import DegeneracyRule, FusionRule, Localizer, PlanMap, PlanRaster
from planicp.sim.experiment import ExperimentConfig, LidarModel, run_experiment
from planicp.sim.world import Furnishing

RESOLUTION = 0.05
LENGTH, WIDTH = 100.0, 2.0


def corridor() -> PlanMap:
    cols, rows = int((LENGTH + 0.4) / RESOLUTION), int((WIDTH + 0.4) / RESOLUTION)
    walls = np.zeros((rows, cols), dtype=bool)
    walls[:4, :] = walls[-4:, :] = walls[:, :4] = walls[:, -4:] = True
    return PlanMap.from_raster(PlanRaster(walls, RESOLUTION, (0.0, 0.0, 0.0)))


def rms_errors(poses: NDArray[np.float64], truth: NDArray[np.float64]) -> str:
    d = poses - truth
    yaw = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
    along, across = np.sqrt(np.mean(d[:, 0] ** 2)), np.sqrt(np.mean(d[:, 1] ** 2))
    heading = np.degrees(np.sqrt(np.mean(yaw**2)))
    return f"along {100 * along:6.2f} cm, across {100 * across:5.2f} cm, heading {heading:.3f} deg"


def main() -> None:
    plan = corridor()
    for seed in range(3):
        config = ExperimentConfig(
            duration_s=120.0,
            seed=seed,
            lidar=LidarModel(range_max=10.0),
            furnishing=Furnishing(0, 0, 0, 0),
            error_generator=None,
        )
        recording, _ = run_experiment(plan, config)
        sliding = Localizer(
            plan,
            tuple(recording.truth[0]),
            degeneracy=DegeneracyRule(min_constraint=0.0),
            fusion=FusionRule(max_innovation=0.0),
        )
        poses = np.array(
            [sliding.update(s, tuple(o)).pose for s, o in zip(recording.scans, recording.odometry_in_odom)]
        )
        print(f"seed {seed}  odometry:            {rms_errors(recording.odometry, recording.truth)}")
        print(f"        planicp:             {rms_errors(recording.estimate, recording.truth)}")
        print(f"        the fit alone:       {rms_errors(poses, recording.truth)}")


if __name__ == "__main__":
    main()
