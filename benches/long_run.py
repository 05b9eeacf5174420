#!/usr/bin/env python3
"""Long run: many `Localizer.update` calls on simulated scans, with the process's memory sampled.

The robot does a random walk through the free space of the shipped default plan; every scan is cast
by the native ray caster (`planicp._core.OccupancyGrid.cast`, 360 beams, 1 cm noise) through the
plan's own wall raster, and odometry is the true pose with a small drift. Resident memory (VmRSS) is
read every `--sample-every` updates. Memory is flat when it grows by less than `--max-growth-mb`
between the 10 % mark (after warm-up: caches, allocator pools) and the end.

    python benches/long_run.py                  # 10^5 updates (issue 7), a few minutes
    python benches/long_run.py --updates 2000   # quick look

`tests/test_long_run.py` runs a short version in CI.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import planicp
from planicp import Localizer, _core, se2
from planicp.plans.default_plan import load_default_plan

BEAMS = 360


def rss_mb() -> float:
    """Resident set size of this process, MB (Linux /proc; peak RSS elsewhere)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


@dataclass
class Simulator:
    """Scans of the default plan from a random walk through its free space."""

    seed: int = 0
    plan: Any = field(default=None)

    def __post_init__(self) -> None:
        self.plan = load_default_plan()
        raster = self.plan.raster
        assert raster is not None and raster.origin[2] == 0.0
        # PlanRaster is in image order (row 0 at the top); the ray caster's rows grow with +y.
        self.grid = _core.OccupancyGrid(
            np.ascontiguousarray(raster.walls[::-1]), raster.resolution, (raster.origin[0], raster.origin[1])
        )
        self.rng = np.random.default_rng(self.seed)
        x0, y0, x1, y1 = self.plan.extent
        self.box = (x0, y0, x1, y1)
        self.truth = self._free_pose()
        self.odom = (0.0, 0.0, 0.0)

    def _scan(self, pose: tuple[float, float, float], noisy: bool = True) -> np.ndarray:
        return self.grid.cast(
            pose,
            -math.pi,
            2 * math.pi / BEAMS,
            BEAMS,
            0.05,
            30.0,
            range_sigma=0.01 if noisy else 0.0,
            seed=int(self.rng.integers(2**32)),
        )

    def _ok(self, pose: tuple[float, float, float]) -> bool:
        r = self._scan(pose, noisy=False)
        finite = np.isfinite(r)
        return bool(finite.mean() > 0.7 and r[finite].min() > 0.3)

    def _free_pose(self) -> tuple[float, float, float]:
        x0, y0, x1, y1 = self.box
        while True:
            p = (
                float(self.rng.uniform(x0, x1)),
                float(self.rng.uniform(y0, y1)),
                float(self.rng.uniform(-math.pi, math.pi)),
            )
            if self._ok(p):
                return p

    def step(self) -> tuple[np.ndarray, tuple[float, float, float], tuple[float, float, float]]:
        """Moves the robot; returns (scan points in the robot frame, odometry pose, true pose)."""
        motion = (float(self.rng.uniform(0.0, 0.15)), 0.0, float(self.rng.normal(0.0, 0.1)))
        nxt = se2.compose(self.truth, motion)
        if not self._ok(nxt):
            nxt = se2.compose(self.truth, (0.0, 0.0, float(self.rng.uniform(1.0, 3.0))))
        moved = se2.between(self.truth, nxt)
        drift = (moved[0] * 1.01, moved[1] + float(self.rng.normal(0.0, 0.002)), moved[2] * 1.01)
        self.odom = se2.compose(self.odom, drift)
        self.truth = nxt
        pts = planicp.scan_to_points(self._scan(self.truth), -math.pi, 2 * math.pi / BEAMS, 0.05, 30.0)
        return pts, self.odom, self.truth


def run(
    updates: int, sample_every: int = 1000, seed: int = 0, keep: list[Any] | None = None, log: Any = None
) -> dict[str, Any]:
    """Runs `updates` Localizer updates; `keep` (a list) holds every scan, to simulate a leak."""
    sim = Simulator(seed=seed)
    loc = Localizer(sim.plan, sim.truth)
    samples: list[tuple[int, float]] = [(0, rss_mb())]
    accepted = 0
    errors: list[float] = []
    t0 = time.perf_counter()
    for i in range(1, updates + 1):
        pts, odom, truth = sim.step()
        est = loc.update(pts, odom)
        accepted += est.accepted
        if keep is not None:
            keep.append(pts.copy())
        if i % 100 == 0:
            d = se2.between(truth, est.pose)
            errors.append(math.hypot(d[0], d[1]))
            if errors[-1] > 1.0:  # lost (a kidnap-like jump at a blocked step): put it back
                loc.reset(truth)
        if i % sample_every == 0 or i == updates:
            samples.append((i, rss_mb()))
            if log is not None:
                print(
                    f"{i:>7} updates  RSS {samples[-1][1]:8.1f} MB  {time.perf_counter() - t0:7.1f} s",
                    file=log,
                    flush=True,
                )
    mark = max(1, updates // 10)
    at_mark = min(samples, key=lambda s: abs(s[0] - mark))
    return {
        "updates": updates,
        "seconds": time.perf_counter() - t0,
        "accepted": accepted,
        "median_error_m": float(np.median(errors)) if errors else math.nan,
        "rss_start_mb": samples[0][1],
        "rss_mark_mb": at_mark[1],
        "mark": at_mark[0],
        "rss_end_mb": samples[-1][1],
        "rss_max_mb": max(s[1] for s in samples),
        "growth_mb": samples[-1][1] - at_mark[1],
        "samples": samples,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--updates", type=int, default=100_000)
    ap.add_argument("--sample-every", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-growth-mb", type=float, default=5.0)
    args = ap.parse_args(argv)
    r = run(args.updates, args.sample_every, args.seed, log=sys.stdout)
    flat = r["growth_mb"] < args.max_growth_mb
    print(
        f"\n{r['updates']} updates in {r['seconds']:.0f} s ({1e3 * r['seconds'] / r['updates']:.2f} ms each), "
        f"{r['accepted']} accepted, median position error {100 * r['median_error_m']:.1f} cm (every 100th)"
    )
    print(
        f"RSS: start {r['rss_start_mb']:.1f} MB, at update {r['mark']} {r['rss_mark_mb']:.1f} MB, "
        f"end {r['rss_end_mb']:.1f} MB, max {r['rss_max_mb']:.1f} MB"
    )
    print(
        f"growth from the 10 % mark to the end: {r['growth_mb']:+.2f} MB -> "
        f"{'FLAT' if flat else 'GROWING'} (bound {args.max_growth_mb} MB)"
    )
    return 0 if flat else 1


if __name__ == "__main__":
    sys.exit(main())
