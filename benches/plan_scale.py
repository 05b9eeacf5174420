"""A plan whose scale is off, in simulation: when the Localizer flags it, and what the scans say.

The robot drives the default office (and generated floors) at its true scale; planicp tracks it on
the plan scaled by 0.90, 0.97, 1.03 and 1.10 about the map origin, starting at the scaled true
pose (where a user would click on the drawing), and on the correct plan. For each: the scan at
which `Estimate.scale_suspect` first holds (of the first `--scans`), the running `ScaleEstimate`
there, `planicp.estimate_scale` from the first 30 scans, and the update's time with the check and
without it.

    python benches/plan_scale.py [--seeds 0 1 2] [--scans 50] [--floors] [--estimate]
    python benches/plan_scale.py --timing --seeds 0 1 2
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import planicp
from planicp.plans.default_plan import load_default_plan
from planicp.sim.experiment import ExperimentConfig, run_experiment
from planicp.sim.floor_generation import generate_floor


def _plans(floors: bool) -> list[tuple[str, planicp.PlanMap]]:
    out = [("office", load_default_plan())]
    if floors:
        for layout in ("office", "hall"):
            floor = generate_floor(7, layout)
            plan = planicp.PlanMap.from_image(
                floor.to_image(), resolution=floor.resolution, origin=(*floor.origin, 0.0), cache=False
            )
            out.append((f"generated {layout}", plan))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--scans", type=int, default=50)
    parser.add_argument("--floors", action="store_true", help="generated floors too")
    parser.add_argument("--estimate", action="store_true", help="run planicp.estimate_scale as well")
    parser.add_argument("--timing", action="store_true", help="only the update's time, check on and off, interleaved")
    args = parser.parse_args()
    if args.timing:
        _timing(args.seeds)
        return
    print(
        "| plan | seed | plan scale | first flagged scan | running factor (truth) | estimate_scale "
        "| ms/update p50 / p99 (check off: p50 / p99) |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, plan in _plans(args.floors):
        for seed in args.seeds:
            recording, _ = run_experiment(plan, ExperimentConfig(duration_s=args.scans / 10.0 + 0.5, seed=seed))
            scans = recording.scans[: args.scans]
            odometry = recording.odometry_in_odom[: args.scans]
            for s in (1.0, 0.97, 0.9, 1.03, 1.1):
                scaled = plan.scaled(s) if s != 1.0 else plan
                start = (recording.truth[0, 0] * s, recording.truth[0, 1] * s, recording.truth[0, 2])
                times = {}
                flagged, running = None, None
                for enabled in (True, False):
                    loc = planicp.Localizer(scaled, start, scale=planicp.ScaleRule(enabled=enabled))
                    t = []
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", planicp.PlanScaleWarning)
                        for k, (scan, odom) in enumerate(zip(scans, odometry)):
                            t0 = time.perf_counter()
                            est = loc.update(scan, tuple(odom))
                            t.append(time.perf_counter() - t0)
                            if enabled and est.scale is not None:
                                running = est.scale
                                if flagged is None and est.scale_suspect:
                                    flagged = k
                    times[enabled] = np.array(t[1:]) * 1e3
                estimated = ""
                if args.estimate:
                    found = planicp.estimate_scale(scaled, scans[:30], odometry[:30], start)
                    estimated = f"{found.factor:.4f} +- {found.std:.4f}"
                run_text = f"{running.factor:.4f}" if running is not None else "-"
                on, off = times[True], times[False]
                print(
                    f"| {name} | {seed} | {s:.2f} | {flagged if flagged is not None else 'never'} "
                    f"| {run_text} ({1 / s:.4f}) "
                    f"| {estimated} | {np.percentile(on, 50):.2f} / {np.percentile(on, 99):.2f} "
                    f"({np.percentile(off, 50):.2f} / {np.percentile(off, 99):.2f}) |",
                    flush=True,
                )


def _timing(seeds: list[int]) -> None:
    """`Localizer.update` with the scale check on and off, the two localizers fed the same scans
    alternately (so that they share the machine's load): 300 scans of the office per seed, on the
    correct plan and on the plan 3 % small."""
    plan = load_default_plan()
    print("| plan scale | updates | check on: p50 / p99 / max ms | check off: p50 / p99 / max ms |")
    print("|---|---|---|---|")
    for s in (1.0, 0.97):
        scaled = plan.scaled(s) if s != 1.0 else plan
        on_t: list[float] = []
        off_t: list[float] = []
        for seed in seeds:
            recording, _ = run_experiment(plan, ExperimentConfig(duration_s=30.5, seed=seed))
            start = (recording.truth[0, 0] * s, recording.truth[0, 1] * s, recording.truth[0, 2])
            on = planicp.Localizer(scaled, start)
            off = planicp.Localizer(scaled, start, scale=planicp.ScaleRule(enabled=False))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", planicp.PlanScaleWarning)
                for k, (scan, odom) in enumerate(zip(recording.scans[:300], recording.odometry_in_odom)):
                    for localizer, times in ((on, on_t), (off, off_t)) if k % 2 else ((off, off_t), (on, on_t)):
                        t0 = time.perf_counter()
                        localizer.update(scan, tuple(odom))
                        if k:
                            times.append(time.perf_counter() - t0)
        a, b = np.array(on_t) * 1e3, np.array(off_t) * 1e3
        print(
            f"| {s:.2f} | {len(a)} | {np.percentile(a, 50):.2f} / {np.percentile(a, 99):.2f} / {a.max():.2f} "
            f"| {np.percentile(b, 50):.2f} / {np.percentile(b, 99):.2f} / {b.max():.2f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
