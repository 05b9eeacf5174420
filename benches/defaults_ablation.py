#!/usr/bin/env python3
"""Which ICP defaults, and why: each design choice switched off in turn, on generated floors.

For every layout of `planicp.sim` (office, hall, diagonal) and several seeds, random poses
in free space are scanned (1080 beams, 1.5 cm noise, furniture not in the plan), the pose is
perturbed by --offset m and --offset-deg degrees, and `planicp.localize` recovers it under each
variant. Success = error < 5 cm and < 0.5 deg. Timings are medians from this run only: compare
them with each other, not across machines.

    python benches/defaults_ablation.py            # about a minute on 2 cores
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

import planicp
from planicp import sim

VARIANTS: dict[str, dict[str, object]] = {
    "default": {},
    "kd_tree search": {"correspondence_search": "kd_tree"},
    "no visibility": {"use_visibility": False},
    "single stage (1.0)": {"correspondence_schedule": (1.0,)},
    "no acceleration": {"accelerate": False},
    "trim_ratio 0.9": {"trim_ratio": 0.9},
    "auto_trim": {"auto_trim": True},
    "subsample 2": {"subsample": 2},
    "fixed 30 iterations": {"translation_tolerance": 0.0, "rotation_tolerance": 0.0},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--poses", type=int, default=15, help="poses per floor")
    parser.add_argument("--offset", type=float, default=0.2)
    parser.add_argument("--offset-deg", type=float, default=3.0)
    parser.add_argument("--max-correspondence-distance", type=float, default=0.25)
    args = parser.parse_args()
    base = planicp.IcpConfig(max_correspondence_distance=args.max_correspondence_distance)
    configs = {name: base.replace(**changes) for name, changes in VARIANTS.items()}
    rows = []
    for layout in sim.LAYOUTS:
        stats = {name: ([], [], []) for name in configs}  # ok, iterations, seconds
        for seed in range(args.seeds):
            floor = sim.generate_floor(seed, layout)
            plan = planicp.PlanMap.from_points(floor.wall_points())
            rng = np.random.default_rng(1000 + seed)
            for _ in range(args.poses):
                truth = floor.sample_pose(rng, clearance=0.6)
                scan, _ = sim.simulate_scan(floor, truth, rng)
                guess = sim.perturb_pose(truth, rng, args.offset, math.radians(args.offset_deg))
                # Untimed: the first alignment at a new pose reads the plan's index cold, and
                # would charge that to whichever variant comes first (0.48 against 0.33 ms).
                planicp.localize(scan, plan, guess, base)
                for name, config in configs.items():
                    t0 = time.perf_counter()
                    result = planicp.localize(scan, plan, guess, config)
                    seconds = time.perf_counter() - t0
                    dx, dy, dyaw = planicp.se2.between(truth, result.pose)
                    ok = math.hypot(dx, dy) < 0.05 and abs(dyaw) < math.radians(0.5)
                    stats[name][0].append(ok)
                    stats[name][1].append(result.iterations)
                    stats[name][2].append(seconds)
        for name, (ok, iterations, seconds) in stats.items():
            rows.append(
                (layout, name, 100 * statistics.mean(ok), statistics.mean(iterations), 1e3 * statistics.median(seconds))
            )
    print(
        f"max_correspondence_distance {args.max_correspondence_distance} m, {args.seeds} seeds x "
        f"{args.poses} poses per layout, guess {args.offset} m / {args.offset_deg} deg off\n"
    )
    print("| layout | variant | success | mean iterations | median ms |")
    print("|---|---|---|---|---|")
    for layout, name, success, iterations, ms in rows:
        print(f"| {layout} | {name} | {success:.0f} % | {iterations:.1f} | {ms:.2f} |")


if __name__ == "__main__":
    main()
