#!/usr/bin/env python3
"""People crowding the sensor: tracking error against the share of returns they block.

30 s drives on the shipped office plan without furniture (one per seed); for every scan, N people
(discs of 0.18-0.25 m) stand at random free places 0.7-3 m around the robot, placed anew for every
scan, blocking part of the beams (`planicp.sim.crowd`). For each N the same scans and odometry are
tracked with plain ICP (`IcpConfig(correspondence_search="kd_tree")`, no occlusion rule, the fit
alone), automatic trimming alone (`IcpConfig.for_tracking()`, no occlusion rule), and the
`Localizer`'s defaults (automatic trimming, `OcclusionRule`, fusion with the odometry
prediction). Printed: the mean share of blocked returns and the position error RMS / max in
centimetres over all drives, then the defaults' RMS as a multiple of the empty floor's, per drive
and over all of them.

    python benches/crowd.py [--seeds 1 2 3 4 5] [--people 0 10 20 25 30 40] [--workers 2]

With `--no-spare-time` every variant's recovery scores only the nodes of each update
(`RecoveryConfig(search_time=None, search_spare_time=None)`): where a variant loses track, what it ends at is then
the same on any machine and under any load.
"""

from __future__ import annotations

import argparse
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planicp import FusionRule, IcpConfig, Localizer, RecoveryConfig
from planicp.plans.default_plan import load_default_plan
from planicp.sim.crowd import Crowd, crowded_scans
from planicp.sim.experiment import ExperimentConfig, run_experiment
from planicp.sim.world import Furnishing

VARIANTS: dict[str, dict[str, Any]] = {
    "plain ICP": {
        "config": IcpConfig(correspondence_search="kd_tree"),
        "occlusion": False,
        "fusion": FusionRule(max_innovation=0.0),
    },
    "auto trim only": {"config": IcpConfig.for_tracking(), "occlusion": False},
    "defaults": {},
}


def errors_of(seed: int, people: int, no_spare_time: bool = False) -> tuple[float, dict[str, NDArray[np.float64]]]:
    """(mean blocked share, {variant: position errors in metres}) for one drive and crowd size
    (`no_spare_time`: the recovery's searches held to their nodes)."""
    plan = load_default_plan()
    config = ExperimentConfig(duration_s=30.0, seed=seed, furnishing=Furnishing(0, 0, 0, 0))
    recording, world = run_experiment(plan, config)
    scans, blocked = crowded_scans(recording, world.floor, config.lidar, Crowd(people), seed=seed)
    out = {}
    for name, options in VARIANTS.items():
        recovery = RecoveryConfig(search_time=None, search_spare_time=None) if no_spare_time else None
        localizer = Localizer(plan, tuple(recording.truth[0]), recovery=recovery, **options)
        poses = np.array([localizer.update(s, tuple(o)).pose for s, o in zip(scans, recording.odometry_in_odom)])
        out[name] = np.hypot(*(poses[:, :2] - recording.truth[:, :2]).T)
    return float(np.mean(blocked)), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5], help="one 30 s drive per seed")
    parser.add_argument("--people", type=int, nargs="+", default=[0, 10, 20, 25, 30, 40])
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument(
        "--no-spare-time",
        action="store_true",
        help="RecoveryConfig(search_time=None, search_spare_time=None): the same on any machine",
    )
    args = parser.parse_args()
    jobs = [(seed, people) for people in args.people for seed in args.seeds]
    with ProcessPoolExecutor(args.workers) as pool:
        spare = [args.no_spare_time] * len(jobs)
        results = dict(zip(jobs, pool.map(errors_of, *zip(*jobs), spare)))
    print(f"{'people':>6s} {'blocked':>8s}  " + "  ".join(f"{name:>22s}" for name in VARIANTS))
    rms: dict[tuple[int, int], float] = {}
    for people in args.people:
        blocked = np.mean([results[(seed, people)][0] for seed in args.seeds])
        cells = []
        for name in VARIANTS:
            err = np.concatenate([results[(seed, people)][1][name] for seed in args.seeds])
            cells.append(f"{100 * np.sqrt(np.mean(err**2)):8.3f} / {100 * err.max():6.1f} cm")
        for seed in args.seeds:
            rms[(seed, people)] = float(np.sqrt(np.mean(results[(seed, people)][1]["defaults"] ** 2)))
        print(f"{people:6d} {100 * blocked:7.0f}%  " + "  ".join(f"{c:>22s}" for c in cells))
    if 0 in args.people:
        print("\ndefaults' RMS as a multiple of the empty floor's (per drive; all drives)")
        for people in args.people:
            if people == 0:
                continue
            ratios = [rms[(seed, people)] / rms[(seed, 0)] for seed in args.seeds]
            pooled = np.sqrt(np.mean([rms[(s, people)] ** 2 for s in args.seeds])) / np.sqrt(
                np.mean([rms[(s, 0)] ** 2 for s in args.seeds])
            )
            print(f"{people:6d}  " + " ".join(f"{r:5.2f}" for r in ratios) + f";  {pooled:5.2f}")


if __name__ == "__main__":
    main()
