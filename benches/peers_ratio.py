#!/usr/bin/env python3
"""planicp's single alignment against the ICP peers, as ratios to a baseline timed in the same run.

Issue 8 asks that planicp's fastest mode align a 1080-point scan (30 fixed iterations) in at most
1/15 of small_gicp ICP's median time, with the same or better success rate, that `planicp_default`
(its own termination) be faster still, and that the per-alignment time grow less than 2x from a
10k- to a 1M-point plan. Absolute times move with the machine's state from run to run (they did
by a factor of 1.5 between sessions on the development machine), so this bench reports each
peer's median as a ratio to the baseline's median *of the same repeat*, over several repeats.

It runs `../shared/bench/peers.py`'s test case (imported by path, nothing copied): the seeded
40 x 25 m floor with 10 rooms, 1080-beam scans with furniture, starts 0.2 m and 3 degrees off,
max correspondence distance 0.4 m, 50 trials. Each repeat times every available peer on the same
trials, one after the other; then the scale sweep (10k / 100k / 1M map points) once.

    peers-venv/bin/python benches/peers_ratio.py                 # 3 repeats and the sweep
    peers-venv/bin/python benches/peers_ratio.py --repeats 5 --no-scale

The peers are not planicp dependencies: run it from an environment with small_gicp (and
optionally Open3D, KISS-ICP) and planicp installed, see `../shared/bench/README.md`. The baseline
is small_gicp ICP when it can be imported, else the numpy + SciPy cKDTree ICP of the same file.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

# One thread everywhere, as peers.py pins it, before numpy starts its pools.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import numpy as np  # noqa: E402

from peers_module import DEFAULT_PEERS_FILE, load_peers_module  # noqa: E402  (benches/ is on sys.path)

PLANICP = ("planicp", "planicp_default")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--peers-file", type=Path, default=DEFAULT_PEERS_FILE)
    p.add_argument("--repeats", type=int, default=3, help="timings of the main case")
    p.add_argument("--trials", type=int, default=50)
    p.add_argument(
        "--others",
        default="open3d,kiss_icp",
        help="further peers to time when importable (comma-separated peers.py names)",
    )
    p.add_argument("--no-scale", action="store_true", help="skip the 10k / 100k / 1M sweep")
    p.add_argument("--scale-reps", type=int, default=15, help="poses per cell of the sweep (peers.py: 7)")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    peers_mod = load_peers_module(args.peers_file)
    # peers.py's own defaults make the case; only the trial count is ours.
    case = peers_mod.parse_args(["--trials", str(args.trials), "--threads", "1", "--scale-reps", str(args.scale_reps)])
    rng = np.random.default_rng(case.seed)
    floor = peers_mod.make_floor_plan(rng, case.width, case.height, case.res, case.rooms, case.clutter_per_room)
    map_xy = floor.map_points()
    sampler = peers_mod.PoseSampler(floor, clearance=case.clearance)
    trials = peers_mod.make_trials(rng, floor, sampler, case.trials, case, case.beams)
    cfg = argparse.Namespace(
        max_corr=case.max_corr,
        max_iter=case.max_iter,
        trim=case.trim,
        trim_start=case.trim_start,
        threads=1,
        res=case.res,
    )
    wanted = ["small_gicp_icp", "numpy", *PLANICP, *[o for o in args.others.split(",") if o]]
    peers, skipped = peers_mod.load_peers(wanted, cfg)
    names = [p.name for p in peers]
    baseline = "small_gicp ICP" if "small_gicp ICP" in names else "numpy+cKDTree"
    missing = [n for n in PLANICP if n not in names]
    if missing:
        raise SystemExit(f"planicp cannot be imported here ({skipped})")
    print(
        f"# {case.trials} trials of {case.beams} beams on peers.py's floor ({len(map_xy)} wall points), "
        f"30 fixed iterations for all but planicp_default; baseline: {baseline}"
    )
    for name, why in skipped.items():
        print(f"# skipped {name}: {why}")

    medians: dict[str, list[float]] = {p.name: [] for p in peers}
    success: dict[str, float] = {}
    for _ in range(args.repeats):
        for peer in peers:
            row = peers_mod.run_accuracy(peer, map_xy, trials, 1)
            medians[peer.name].append(row["align_s"]["p50"])
            success[peer.name] = row["success_rate"]
    base = medians[baseline]
    print("\n| peer | align ms p50, per repeat | ratio to the baseline, per repeat | success |")
    print("|---|---|---|---|")
    for name, times in medians.items():
        ms = " / ".join(f"{t * 1e3:.2f}" for t in times)
        ratios = " / ".join(f"1/{b / t:.1f}" if t < b else f"{t / b:.2f}" for t, b in zip(times, base))
        print(f"| {name} | {ms} | {ratios} | {success[name] * 100:.0f} % |")
    worst = max(t / b for t, b in zip(medians["planicp"], base))
    faster = all(d < f for d, f in zip(medians["planicp_default"], medians["planicp"]))
    print(
        f"\n# planicp (30 fixed iterations): at most 1/{1 / worst:.1f} of {baseline} over the repeats "
        f"(bar 1/15); planicp_default faster than planicp in every repeat: {faster}; success "
        f"{success['planicp'] * 100:.0f} % against {success[baseline] * 100:.0f} %"
    )

    if args.no_scale:
        return
    started = time.perf_counter()
    timed = [p for p in peers if p.name in (*PLANICP, baseline)]
    rows = peers_mod.run_scale(timed, floor, map_xy, sampler, case, rng)
    print("\n| peer | map points | 360 beams | 1080 beams | 4000 beams |")
    print("|---|---|---|---|---|")
    by: dict[tuple[str, int], dict[int, float]] = {}
    for r in rows:
        if "error" not in r:
            by.setdefault((r["peer"], r["map_points"]), {})[r["scan_beams"]] = r["align_s_median"]
    for (name, points), t in by.items():
        cells = " | ".join(f"{t[b] * 1e3:.2f} ms" if b in t else "-" for b in case.scan_sizes)
        print(f"| {name} | {points} | {cells} |")
    smallest, largest = min(case.map_sizes), max(case.map_sizes)
    for name in (*PLANICP, baseline):
        growth = [
            by[(name, largest)][b] / by[(name, smallest)][b]
            for b in case.scan_sizes
            if b in by.get((name, largest), {}) and b in by.get((name, smallest), {})
        ]
        if growth:
            print(
                f"# {name}: {largest} / {smallest} map points, time grows "
                + " / ".join(f"{g:.2f}x" for g in growth)
                + f" ({', '.join(map(str, case.scan_sizes))} beams; "
                f"median of {case.scale_reps} poses each)"
            )
    print(f"# sweep took {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    sys.exit(main())
