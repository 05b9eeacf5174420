"""`planicp demo`: align simulated scans to a generated floor plan and report the errors.

A seeded office floor (rooms, corridor, doors, furniture that is not in the plan) is generated;
from random poses a 1080-beam LIDAR scan is simulated, the pose is perturbed (0.2 m, 3 deg by
default) to make the initial guess, and `localize` recovers it. The same scans are aligned with
planicp's default settings and with the visibility step turned off, to show what it buys.
"""

from __future__ import annotations

import json
import math
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

import numpy as np

from . import synthetic
from ._validation import Pose
from .icp_config import IcpConfig
from .localize import localize
from .plan_map import PlanMap
from .se2 import wrap_angle

SUCCESS_TRANSLATION_M = 0.05
SUCCESS_ROTATION_RAD = math.radians(0.5)


@dataclass
class VariantStats:
    """Errors and timings of one configuration over all trials."""

    name: str
    translation_errors: list[float] = field(default_factory=list)
    rotation_errors: list[float] = field(default_factory=list)
    seconds: list[float] = field(default_factory=list)

    def add(self, estimate: Pose, truth: Pose, seconds: float) -> None:
        self.translation_errors.append(math.hypot(estimate[0] - truth[0], estimate[1] - truth[1]))
        self.rotation_errors.append(abs(wrap_angle(estimate[2] - truth[2])))
        self.seconds.append(seconds)

    @property
    def success_rate(self) -> float:
        ok = [
            t < SUCCESS_TRANSLATION_M and r < SUCCESS_ROTATION_RAD
            for t, r in zip(self.translation_errors, self.rotation_errors)
        ]
        return sum(ok) / len(ok)

    def summary(self) -> dict[str, float | str]:
        return {
            "name": self.name,
            "success_rate": self.success_rate,
            "translation_error_median_m": statistics.median(self.translation_errors),
            "translation_error_p90_m": float(np.percentile(self.translation_errors, 90)),
            "rotation_error_median_deg": math.degrees(statistics.median(self.rotation_errors)),
            "rotation_error_p90_deg": math.degrees(float(np.percentile(self.rotation_errors, 90))),
            "align_ms_median": 1e3 * statistics.median(self.seconds),
        }


def run_demo(
    *,
    seed: int = 0,
    layout: str = "office",
    trials: int = 100,
    offset_m: float = 0.2,
    offset_deg: float = 3.0,
    out: Path | None = None,
    stream: TextIO | None = None,
) -> dict[str, object]:
    """Runs the demo and returns its metrics (also written to `out/metrics.json` if given)."""

    def say(text: str) -> None:
        if stream is not None:
            print(text, file=stream, flush=True)

    if trials < 1:
        raise ValueError(f"trials must be at least 1, got {trials}")
    rng = np.random.default_rng(seed)
    floor = synthetic.generate_floor(seed, layout)
    t0 = time.perf_counter()
    plan = PlanMap.from_points(floor.wall_points())
    build_s = time.perf_counter() - t0
    xmin, ymin, xmax, ymax = plan.extent
    say(
        f"floor: {layout}, seed {seed}, {xmax - xmin:.1f} x {ymax - ymin:.1f} m, "
        f"{len(plan)} wall points (prepared in {build_s * 1e3:.0f} ms)"
    )
    variants = {
        "planicp (default)": IcpConfig(),
        "planicp, no visibility": IcpConfig(use_visibility=False),
    }
    stats = {name: VariantStats(name) for name in variants}
    clutter_shares = []
    for _ in range(trials):
        truth = floor.sample_pose(rng, clearance=0.6)
        scan, is_clutter = synthetic.simulate_scan(floor, truth, rng)
        clutter_shares.append(float(is_clutter.mean()) if len(is_clutter) else 0.0)
        guess = synthetic.perturb_pose(truth, rng, offset_m, math.radians(offset_deg))
        for name, config in variants.items():
            t = time.perf_counter()
            result = localize(scan, plan, guess, config)
            stats[name].add(result.pose, truth, time.perf_counter() - t)
    say(
        f"{trials} scans of 1080 beams, {100 * statistics.mean(clutter_shares):.0f} % of returns from "
        f"furniture not in the plan; initial guess {offset_m} m and {offset_deg} deg off\n"
        f"success = error < {SUCCESS_TRANSLATION_M * 100:.0f} cm and < "
        f"{math.degrees(SUCCESS_ROTATION_RAD):.1f} deg\n"
    )
    header = f"{'variant':<26}{'success':>9}{'t.err cm p50':>14}{'p90':>8}{'r.err deg p50':>15}{'p90':>8}{'ms p50':>8}"
    say(header)
    say("-" * len(header))
    summaries = [s.summary() for s in stats.values()]
    for s in summaries:
        say(
            f"{s['name']:<26}{100 * float(s['success_rate']):>8.0f}%"
            f"{100 * float(s['translation_error_median_m']):>14.2f}{100 * float(s['translation_error_p90_m']):>8.2f}"
            f"{float(s['rotation_error_median_deg']):>15.3f}{float(s['rotation_error_p90_deg']):>8.3f}"
            f"{float(s['align_ms_median']):>8.2f}"
        )
    metrics: dict[str, object] = {
        "seed": seed,
        "layout": layout,
        "trials": trials,
        "initial_offset_m": offset_m,
        "initial_offset_deg": offset_deg,
        "wall_points": len(plan),
        "clutter_share_mean": statistics.mean(clutter_shares),
        "variants": summaries,
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
        say(f"\nwrote {out / 'metrics.json'}")
    return metrics
