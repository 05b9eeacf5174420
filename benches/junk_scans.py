#!/usr/bin/env python3
"""Corrupted scans in a drive: how far do they move the estimate?

A drive through the demo's furnished office (`run_experiment`, the demo's sensor and odometry) is
tracked by a `Localizer` with its defaults three ways besides the clean run: one scan in the middle
with every point shifted 3 m along the base x axis; one scan in five replaced by a random cloud (as
many points, uniform in a 20 x 20 m square around the robot); one scan in five turned by 90
degrees. Printed: the clean run's position error RMS / max, and for each corrupted run its error
RMS / max and its largest distance from the clean run's estimates (metres).

    python benches/junk_scans.py [--duration 200] [--seed 1]
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from numpy.typing import NDArray

from planicp import IcpConfig
from planicp.plans.default_plan import load_default_plan
from planicp.sim.experiment import ExperimentConfig, Recording, replay, run_experiment


def position_errors(recording: Recording) -> NDArray[np.float64]:
    """(K,) metres between the estimates and the truth."""
    return np.asarray(np.hypot(*(recording.estimate[:, :2] - recording.truth[:, :2]).T), dtype=np.float64)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=float, default=200.0, help="simulated seconds")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=args.duration, seed=args.seed))
    config = IcpConfig.for_tracking()
    clean = replay(plan, recording, config)
    errors = position_errors(clean)
    print(f"{len(recording.scans)} scans; clean run: RMS {np.sqrt(np.mean(errors**2)):.4f} m, max {errors.max():.4f} m")
    rng = np.random.default_rng(args.seed)
    turn = np.array([[0.0, 1.0], [-1.0, 0.0]])  # row vectors times this: +90 degrees
    middle = len(recording.scans) // 2
    cases = {
        f"scan {middle} shifted 3 m": [
            s + np.array([3.0, 0.0]) if k == middle else s for k, s in enumerate(recording.scans)
        ],
        "1 in 5 random clouds": [
            rng.uniform(-10.0, 10.0, s.shape) if k % 5 == 0 and k > 0 else s for k, s in enumerate(recording.scans)
        ],
        "1 in 5 turned 90 deg": [s @ turn if k % 5 == 0 and k > 0 else s for k, s in enumerate(recording.scans)],
    }
    for name, scans in cases.items():
        run = replay(plan, dataclasses.replace(recording, scans=scans), config)
        e = position_errors(run)
        apart = np.hypot(*(run.estimate[:, :2] - clean.estimate[:, :2]).T)
        print(
            f"{name:24s} RMS {np.sqrt(np.mean(e**2)):.4f} m, max {e.max():.4f} m, "
            f"largest distance from the clean run {apart.max():.4f} m (scan {int(np.argmax(apart))})"
        )


if __name__ == "__main__":
    main()
