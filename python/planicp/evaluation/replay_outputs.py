"""What `planicp replay` and `planicp evaluate-log` write: trajectories, figures, the EOG, metrics."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from ..io.trajectory_files import write_tum
from ..mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid
from ..plans.plan_map import PlanMap
from . import figures
from .log_replay import TrackedLog


def write_outputs(
    tracked: TrackedLog, plan: PlanMap, grid: EnhancedOccupancyGrid | None, out: Path, extra: dict[str, Any]
) -> dict[str, Any]:
    """Writes into `out`:

    - trajectory.tum: planicp's T_map_base per scan (TUM: `t x y z qx qy qz qw`);
    - odometry.tum, reference.tum: the odometry (anchored at the start pose) and the reference,
      where the log has them (for `evo_ape tum reference.tum trajectory.tum`);
    - paths.png (paths over the plan), quality.png (inlier ratio, RMSE, rejections over time),
      position_error.png and heading_error.png (when there is a reference);
    - eog.png, eog.yaml + eog.pgm (the enhanced occupancy grid, when `grid` is given);
    - metrics.json: `tracked.metrics()` plus `extra`.

    Returns the metrics.
    """
    out.mkdir(parents=True, exist_ok=True)
    write_tum(out / "trajectory.tum", tracked.times, tracked.estimate)
    has_odometry = bool(np.isfinite(tracked.odometry).all(axis=1).any())
    if has_odometry:
        rows = np.isfinite(tracked.odometry).all(axis=1)
        write_tum(out / "odometry.tum", tracked.times[rows], tracked.odometry[rows])
    paths: dict[str, Any] = {}
    if tracked.reference is not None:
        rows = np.isfinite(tracked.reference).all(axis=1)
        write_tum(out / "reference.tum", tracked.times[rows], tracked.reference[rows])
        paths["truth"] = tracked.reference[rows]
    if has_odometry:
        paths["odometry"] = tracked.odometry[np.isfinite(tracked.odometry).all(axis=1)]
    paths["planicp"] = tracked.estimate
    figures.plot_paths(plan, paths).savefig(out / "paths.png")
    figures.plot_quality(tracked.times, tracked.inlier_ratio, tracked.rmse, tracked.accepted).savefig(
        out / "quality.png"
    )
    metrics = tracked.metrics()
    if tracked.reference is not None and "planicp" in metrics:
        from .trajectory_metrics import pose_errors

        series = {"planicp": tracked.estimate}
        if has_odometry:
            series = {"odometry": tracked.odometry, **series}
        position = {k: pose_errors(v, tracked.reference)[0] for k, v in series.items()}
        heading = {k: pose_errors(v, tracked.reference)[1] for k, v in series.items()}
        figures.plot_position_error(tracked.times, position).savefig(out / "position_error.png")
        figures.plot_heading_error(tracked.times, heading).savefig(out / "heading_error.png")
    if grid is not None:
        figures.plot_eog(grid, title="enhanced occupancy grid from planicp's poses").savefig(out / "eog.png")
        grid.to_ros_map(out / "eog.yaml")
    metrics.update(extra)
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, default=_json_default) + "\n")
    return metrics


def _json_default(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def print_summary(metrics: dict[str, Any], out: Path, stream: TextIO) -> None:
    """A few lines: scans, acceptance, speed and, with a reference, the error table."""
    print(
        f"{metrics['scans']} scans, {100 * metrics['accepted_share']:.1f} % accepted, "
        f"{metrics['scans_per_second']:.0f} scans/s in the localizer",
        file=stream,
    )
    if "planicp" in metrics:
        header = f"{'':10s} {'ATE RMS':>9s} {'worst':>9s} {'heading RMS':>12s} {'lost (>0.3 m)':>14s}"
        print(header, file=stream)
        print("-" * len(header), file=stream)
        for label in ("odometry", "planicp"):
            if label in metrics:
                m = metrics[label]
                print(
                    f"{label:10s} {_metres(m['ate_rms_m']):>9s} {_metres(m['position_max_m']):>9s} "
                    f"{m['heading_rms_deg']:>8.2f} deg {100 * m['lost_share']:>12.1f} %",
                    file=stream,
                )
    print(f"wrote trajectory.tum, figures, metrics.json to {out}", file=stream)


def _metres(value: float) -> str:
    if not math.isfinite(value):
        return "nan"
    return f"{100 * value:.1f} cm" if value < 1.0 else f"{value:.2f} m"
