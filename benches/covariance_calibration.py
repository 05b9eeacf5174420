#!/usr/bin/env python3
"""Is the localizer's covariance honest? Normalised estimation error squared (NEES) in simulation.

Runs the drift experiment (furniture, people, drifting odometry) on the shipped office plan and on
generated floors for several seeds, and for every accepted estimate computes
NEES = e^T P^-1 e, with e the (x, y, yaw) error against ground truth and P the `Estimate.covariance`
the `Localizer` reports. For a consistent 3-dof estimator NEES follows a chi-square distribution
with 3 degrees of freedom: mean 3, 95 % of the values below 7.81. The table shows the mean, the
median and that share for the raw point-to-wall covariance (`covariance_scale=1`) and for the
default scale.

    python benches/covariance_calibration.py [--seeds 10] [--duration 60]
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from planicp import IcpConfig, Localizer, PlanMap, PlanRaster, sim
from planicp.plans.default_plan import load_default_plan
from planicp.sim.experiment import ExperimentConfig, run_experiment

CHI2_3_95 = 7.8147


def nees_of_run(plan: PlanMap, seed: int, duration: float, scales: list[float]) -> dict[float, list[float]]:
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=duration, seed=seed))
    out: dict[float, list[float]] = {}
    for scale in scales:
        localizer = Localizer(plan, tuple(recording.truth[0]), IcpConfig.for_tracking(covariance_scale=scale))
        values = []
        for k, (scan, odom) in enumerate(zip(recording.scans, recording.odometry_in_odom)):
            estimate = localizer.update(scan, tuple(odom))
            if not estimate.accepted:
                continue
            e = np.array(estimate.pose) - recording.truth[k]
            e[2] = (e[2] + math.pi) % (2 * math.pi) - math.pi
            values.append(float(e @ np.linalg.solve(estimate.covariance, e)))
        out[scale] = values
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--duration", type=float, default=60.0)
    args = parser.parse_args()
    default_scale = IcpConfig.for_tracking().covariance_scale
    scales = sorted({1.0, 3.0, 4.0, 5.0, default_scale})
    plans = {"office plan (shipped)": load_default_plan()}
    for layout in ("office", "hall", "diagonal"):
        floor = sim.generate_floor(11, layout)
        raster = PlanRaster(floor.walls[::-1], floor.resolution, (floor.origin[0], floor.origin[1], 0.0))
        plans[f"generated {layout}"] = PlanMap.from_raster(raster)
    print(f"{'plan':24s} {'scale':>5s} {'estimates':>9s} {'mean NEES':>9s} {'median':>7s} {'< 7.81':>7s}")
    totals: dict[float, list[float]] = {s: [] for s in scales}
    for name, plan in plans.items():
        per_scale: dict[float, list[float]] = {s: [] for s in scales}
        for seed in range(args.seeds):
            for scale, values in nees_of_run(plan, seed, args.duration, scales).items():
                per_scale[scale] += values
        for scale in scales:
            v = np.array(per_scale[scale])
            totals[scale] += per_scale[scale]
            print(
                f"{name:24s} {scale:5.1f} {len(v):9d} {v.mean():9.2f} {np.median(v):7.2f} "
                f"{100 * np.mean(v < CHI2_3_95):6.1f}%"
            )
    for scale in scales:
        v = np.array(totals[scale])
        print(
            f"{'all':24s} {scale:5.1f} {len(v):9d} {v.mean():9.2f} {np.median(v):7.2f} "
            f"{100 * np.mean(v < CHI2_3_95):6.1f}%"
        )
    print("consistent: mean 3.00, median 2.37, 95.0 % below 7.81")


if __name__ == "__main__":
    main()
