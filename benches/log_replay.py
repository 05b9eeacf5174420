#!/usr/bin/env python3
"""Throughput of `planicp replay` on a 10,000-scan CARMEN log, end to end.

Simulates a robot touring the shipped office plan for --scans / 10 seconds with a SICK-like
181-beam, 180-degree, 1-degree LIDAR at 10 Hz (80 m, 1 cm noise; furniture and people that the plan
does not show) and drifting 100 Hz odometry, and writes what a CARMEN logger would have recorded:
PARAM lines, ODOM at 10 Hz and FLASER lines carrying the true laser pose (a "corrected" log) and
the odometry. Then runs `planicp replay LOG --plan office_plan.yaml` as a separate process and
reports its wall time (Python start-up, reading, localizing every scan, the EOG, figures and files)
as scans per second, next to the localizer's own rate from metrics.json.

    python benches/log_replay.py [--scans 10000]
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from planicp.plans.default_plan import default_plan_path, load_default_plan
from planicp.se2 import compose
from planicp.sim.experiment import ExperimentConfig, LidarModel, run_experiment


def write_carmen_log(path: Path, scans: int, seed: int) -> None:
    lidar = LidarModel(fov=math.pi, beams=181, range_max=80.0, range_min=0.02, range_sigma=0.01, mount=(0.0, 0.0, 0.0))
    config = ExperimentConfig(duration_s=(scans - 1) / lidar.rate_hz, seed=seed, lidar=lidar)
    recording, _ = run_experiment(load_default_plan(), config)
    assert recording.ranges is not None
    lines = [
        "# message formats defined: PARAM SYNC ODOM FLASER RLASER TRUEPOS",
        "PARAM robot_frontlaser_offset 0.0 nohost 0",
        "PARAM robot_front_laser_max 80.0 nohost 0",
    ]
    for t, ranges, truth, odom in zip(recording.times, recording.ranges, recording.truth, recording.odometry_in_odom):
        laser = compose((float(truth[0]), float(truth[1]), float(truth[2])), lidar.mount)
        text = " ".join("81.91" if not math.isfinite(r) else f"{r:.3f}" for r in ranges)
        lines.append(f"ODOM {odom[0]:.6f} {odom[1]:.6f} {odom[2]:.6f} 0 0 0 {t:.6f} bench {t:.6f}")
        lines.append(
            f"FLASER {len(ranges)} {text} {laser[0]:.6f} {laser[1]:.6f} {laser[2]:.6f} {odom[0]:.6f} "
            f"{odom[1]:.6f} {odom[2]:.6f} {t:.6f} bench {t:.6f}"
        )
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scans", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "office.log"
        began = time.perf_counter()
        write_carmen_log(log, args.scans, args.seed)
        print(
            f"simulated and wrote {args.scans} scans ({log.stat().st_size / 1e6:.1f} MB) in "
            f"{time.perf_counter() - began:.1f} s"
        )
        out = Path(tmp) / "out"
        began = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "planicp.cli",
                "replay",
                str(log),
                "--plan",
                str(default_plan_path()),
                "--out",
                str(out),
            ],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        wall = time.perf_counter() - began
        metrics = json.loads((out / "metrics.json").read_text())
    n = metrics["scans"]
    print(
        f"planicp replay, end to end: {n} scans in {wall:.1f} s = {n / wall:.0f} scans/s "
        f"(localizer alone: {metrics['scans_per_second']:.0f} scans/s)"
    )
    print(
        f"accepted {100 * metrics['accepted_share']:.1f} %; ATE {100 * metrics['planicp']['ate_rms_m']:.2f} cm, "
        f"worst {100 * metrics['planicp']['position_max_m']:.1f} cm; odometry ATE "
        f"{metrics['odometry']['ate_rms_m']:.2f} m"
    )


if __name__ == "__main__":
    main()
