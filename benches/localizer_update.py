#!/usr/bin/env python3
"""Cost of one `Localizer.update` from Python, for a 1081-beam scan (issue 8: under 1 ms).

A simulated drive through the shipped default plan (furniture and people, 1081-beam Hokuyo-like
LIDAR, 100 Hz odometry with the thesis drift; `planicp.sim.run_experiment`) is recorded once. Its
scans are then fed to a fresh `Localizer` exactly as a robot stack would: ranges to points
(`scan_to_points`, the laser mount included) and the odometry pose. Each update is timed with
`time.perf_counter`; the table gives the median and 90th percentile over all updates, per
correspondence search, with the share spent in the conversion. Then, for the same scans and
predictions, the native steps are timed on their own: the occlusion rule (one exact cast through
the plan image and the classification), the view from the prediction over the scan's arc whose
visible points the KD-tree search matches against (`PlanMap.view_from`), and the alignment of the
kept returns given it; the rest of an update is Python.

    python benches/localizer_update.py               # 60 s drive (600 scans)
    python benches/localizer_update.py --duration 20
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import planicp
from planicp import IcpConfig, Localizer, scan_to_points
from planicp.plans.default_plan import load_default_plan
from planicp.sim.experiment import ExperimentConfig, run_experiment


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=60.0, help="simulated drive, seconds")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=args.duration, seed=args.seed))
    frames = recording.scan_frames()
    print(
        f"# planicp {planicp.__version__}: {len(frames)} scans of {len(frames[0].ranges)} beams, "
        f"default plan ({len(plan)} wall points)"
    )
    print("| correspondence search | update p50 | update p90 | of which scan_to_points | RMS error |")
    print("|---|---|---|---|---|")
    truth = recording.poses("truth")
    steps: dict[str, tuple[float, float | None, float]] = {}
    for search in ("wall_index", "kd_tree"):
        config = IcpConfig.for_tracking(correspondence_search=search)
        localizer = Localizer(plan, truth[0], config)
        update_s, convert_s, errors = [], [], []
        replay: list[tuple[np.ndarray, tuple[float, float, float]]] = []
        for k, frame in enumerate(frames):
            assert frame.odometry is not None
            t0 = time.perf_counter()
            points = scan_to_points(
                frame.ranges, frame.angle_min, frame.angle_increment, frame.range_min, frame.range_max, frame.laser_pose
            )
            t1 = time.perf_counter()
            estimate = localizer.update(points, frame.odometry)
            t2 = time.perf_counter()
            update_s.append(t2 - t0)
            convert_s.append(t1 - t0)
            errors.append(np.hypot(estimate.pose[0] - truth[k][0], estimate.pose[1] - truth[k][1]))
            replay.append((points, estimate.predicted_pose))
        p50, p90 = np.percentile(update_s, [50, 90]) * 1e3
        rms = float(np.sqrt(np.mean(np.square(errors))))
        print(f"| {search} | {p50:.3f} ms | {p90:.3f} ms | {np.median(convert_s) * 1e3:.3f} ms | {rms * 100:.2f} cm |")
        steps[search] = _native_steps(plan, config, localizer, replay)
    for search, (classify_ms, view_ms, align_ms) in steps.items():
        view = f"view_from {view_ms:.3f} ms, " if view_ms is not None else ""
        print(f"# {search}: median occlusion rule {classify_ms:.3f} ms, {view}alignment {align_ms:.3f} ms")


def _native_steps(
    plan: planicp.PlanMap,
    config: IcpConfig,
    localizer: Localizer,
    replay: list[tuple[np.ndarray, tuple[float, float, float]]],
) -> tuple[float, float | None, float]:
    """Median milliseconds per update of the occlusion rule (one native cast and classification),
    of the view cast (the KD-tree search's visible points; None for the index, which does not use
    one) and of the alignment of the kept returns given it, done as the localizer does them."""
    occlusion = localizer._occlusion
    assert occlusion is not None
    uses_view = config.correspondence_search == "kd_tree"
    classify_s, view_s, align_s = [], [], []
    for points, predicted in replay:
        t0 = time.perf_counter()
        in_front, _ = occlusion.classify(points, predicted)
        t1 = time.perf_counter()
        view = occlusion.view(points, predicted, config) if uses_view else None
        t2 = time.perf_counter()
        planicp.localize(points[~in_front], plan, predicted, config, view=view)
        t3 = time.perf_counter()
        classify_s.append(t1 - t0)
        view_s.append(t2 - t1)
        align_s.append(t3 - t2)
    return (
        float(np.median(classify_s)) * 1e3,
        float(np.median(view_s)) * 1e3 if uses_view else None,
        float(np.median(align_s)) * 1e3,
    )


if __name__ == "__main__":
    main()
