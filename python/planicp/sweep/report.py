"""A study's summary: error distributions per setting, success rates against clutter and drift, and
a Markdown report. Plots return matplotlib Figures (drawn with the Agg backend, no display)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .study import Study

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["AXES", "markdown_report", "plot_error_distributions", "plot_success_rates", "summary_by_setting"]

AXES = (
    ("plan", "plan"),
    ("furniture", "furniture density (x demo)"),
    ("people", "people per 100 m$^2$"),
    ("sensor", "sensor model"),
    ("odometry", "odometry errors"),
    ("icp", "ICP setting"),
)
"""The table's axis columns and their labels."""

MAX_FAILED_SHOWN = 50
"""Failed runs listed in the report; the table has them all."""


def _figure(width: float, height: float) -> Figure:
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), dpi=100, layout="constrained")


Order = Mapping[str, Sequence[Any]]
"""The study's order of the values of an axis column (e.g. setting names as the study lists them)."""


def _values(rows: Sequence[dict[str, Any]], column: str, order: Order | None = None) -> list[Any]:
    """Distinct values of a column: numbers ascending, names in the study's `order` (else in order
    of appearance)."""
    seen = list(dict.fromkeys(r[column] for r in rows))
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in seen):
        return sorted(seen)
    if order is not None and column in order:
        rank = {v: i for i, v in enumerate(order[column])}
        seen.sort(key=lambda v: rank.get(v, len(rank)))
    return seen


def _label(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    text = str(value)
    return text if len(text) <= 18 else "..." + text[-15:]


def summary_by_setting(rows: Sequence[dict[str, Any]], column: str, order: Order | None = None) -> list[dict[str, Any]]:
    """Per value of `column` (in the study's `order`): runs, failed runs, success rate, and the median
    and 95th percentile of planicp's largest position error (metres) and the median of odometry's,
    over finished runs."""
    out = []
    for value in _values(rows, column, order):
        group = [r for r in rows if r[column] == value]
        finished = [r for r in group if r["status"] == "ok"]
        p = np.array([r["planicp_position_max_m"] for r in finished], dtype=float)
        o = np.array([r["odometry_position_max_m"] for r in finished], dtype=float)
        lost = np.array([r["lost_scans"] for r in finished], dtype=float)
        out.append(
            {
                "value": value,
                "runs": len(group),
                "failed": len(group) - len(finished),
                "success_rate": sum(bool(r["success"]) for r in group) / len(group),
                "planicp_max_median_m": float(np.median(p)) if len(p) else math.nan,
                "planicp_max_p95_m": float(np.percentile(p, 95)) if len(p) else math.nan,
                "odometry_max_median_m": float(np.median(o)) if len(o) else math.nan,
                "lost_scans_mean": float(lost.mean()) if len(lost) else math.nan,
            }
        )
    return out


def plot_error_distributions(
    rows: Sequence[dict[str, Any]], threshold_m: float | None = None, order: Order | None = None
) -> Figure:
    """Box plots of planicp's largest position error per run (metres, log scale) for each setting of
    every axis that varies, odometry's beside them in grey; the success threshold as a dashed line.
    Failed runs have no error and are left out."""
    axes_used = [(c, t) for c, t in AXES if rows and len(_values(rows, c)) > 1] or [AXES[0]]
    fig = _figure(4.0 * len(axes_used), 3.6)
    subplots = fig.subplots(1, len(axes_used), squeeze=False)[0]
    finished = [r for r in rows if r["status"] == "ok"]
    for ax, (column, title) in zip(subplots, axes_used):
        values = _values(rows, column, order) if rows else []
        data_p = [[max(r["planicp_position_max_m"], 1e-4) for r in finished if r[column] == v] for v in values]
        data_o = [[max(r["odometry_position_max_m"], 1e-4) for r in finished if r[column] == v] for v in values]
        positions = np.arange(len(values), dtype=float)
        if any(data_o):
            ax.boxplot(
                [d or [math.nan] for d in data_o],
                positions=positions + 0.2,
                widths=0.3,
                patch_artist=True,
                boxprops={"facecolor": "0.85", "color": "0.5"},
                medianprops={"color": "0.3"},
                whiskerprops={"color": "0.5"},
                capprops={"color": "0.5"},
                flierprops={"markersize": 3},
            )
        if any(data_p):
            ax.boxplot(
                [d or [math.nan] for d in data_p],
                positions=positions - 0.2,
                widths=0.3,
                patch_artist=True,
                boxprops={"facecolor": "tab:blue", "alpha": 0.6},
                medianprops={"color": "navy"},
                flierprops={"markersize": 3},
            )
        if threshold_m is not None:
            ax.axhline(threshold_m, color="tab:red", linestyle="--", linewidth=1)
        ax.set_xticks(positions, [_label(v) for v in values], rotation=20 if column == "plan" else 0)
        ax.set_yscale("log")
        ax.set_xlabel(title)
        ax.grid(True, axis="y", which="both", alpha=0.3)
    subplots[0].set_ylabel("largest position error per run (m)")
    subplots[0].plot([], [], color="tab:blue", linewidth=6, alpha=0.6, label="planicp")
    subplots[0].plot([], [], color="0.75", linewidth=6, label="odometry")
    if threshold_m is not None:
        subplots[0].plot([], [], color="tab:red", linestyle="--", label=f"success below {threshold_m:g} m")
    subplots[0].legend(loc="upper left", fontsize=8)
    fig.suptitle("error distributions per setting")
    return fig


def plot_success_rates(rows: Sequence[dict[str, Any]], order: Order | None = None) -> Figure:
    """Success rate against furniture density (one line per odometry setting) and against the
    odometry's heading drift in degrees per second, log scale (one line per furniture density);
    points are annotated with their number of runs. A failed run is not a success."""
    fig = _figure(9.0, 3.6)
    left, right = fig.subplots(1, 2)
    for name in _values(rows, "odometry", order) if rows else []:
        group = [r for r in rows if r["odometry"] == name]
        xs = _values(group, "furniture")
        _rate_line(left, group, "furniture", xs, str(name))
    left.set_xlabel("furniture density (x the demo's per 100 m$^2$)")
    left.set_title("success rate vs clutter")
    for level in _values(rows, "furniture") if rows else []:
        group = [r for r in rows if r["furniture"] == level]
        xs = _values(group, "odometry_drift_deg_per_s")
        _rate_line(right, group, "odometry_drift_deg_per_s", xs, f"furniture {level:g}")
    drifts = [r["odometry_drift_deg_per_s"] for r in rows]
    if drifts and min(drifts) > 0 and max(drifts) > 2 * min(drifts):
        right.set_xscale("log")
    right.set_xlabel("odometry heading drift (deg/s)")
    right.set_title("success rate vs drift")
    for ax in (left, right):
        ax.set_ylim(-0.05, 1.1)
        ax.set_ylabel("success rate")
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, loc="lower left")
    return fig


def _rate_line(ax: Any, group: Sequence[dict[str, Any]], column: str, xs: list[Any], label: str) -> None:
    rates, counts = [], []
    for x in xs:
        cell = [r for r in group if r[column] == x]
        counts.append(len(cell))
        rates.append(sum(bool(r["success"]) for r in cell) / len(cell))
    ax.plot(xs, rates, marker="o", label=label)
    for x, rate, n in zip(xs, rates, counts):
        ax.annotate(f"{n}", (x, rate), textcoords="offset points", xytext=(0, 5), fontsize=7, ha="center")


def markdown_report(
    study: Study,
    rows: Sequence[dict[str, Any]],
    *,
    expected_runs: int,
    figures: Sequence[str],
    command: str = "",
    version: str = "",
    order: Order | None = None,
) -> str:
    """The study's report: what ran, overall success, a table per axis, the failed runs, figures."""
    done = len(rows)
    failed = [r for r in rows if r["status"] != "ok"]
    successes = sum(bool(r["success"]) for r in rows)
    criterion = study.success
    lost_rule = "" if criterion.allow_lost_at_end else " and the localizer not lost after the last scan"
    lines = [
        f"# Study: {study.name}",
        "",
        f"planicp {version}. {done} of {expected_runs} runs recorded"
        + (f" ({expected_runs - done} not run yet: rerun the command to finish)" if done < expected_runs else "")
        + f", {len(failed)} failed. Each run simulates {study.duration_s:g} s.",
    ]
    if command:
        lines += ["", f"Command: `{command}`"]
    if done:
        lines += [
            "",
            f"**Success: {successes} of {done} runs ({100 * successes / done:.1f} %)**: the run finished, "
            f"planicp's largest position error stayed below {criterion.max_position_error_m:g} m{lost_rule}.",
        ]
    for column, title in AXES:
        summary = summary_by_setting(rows, column, order) if rows else []
        if not summary:
            continue
        lines += [
            "",
            f"## By {title.replace('$^2$', '²')}",
            "",
            "| setting | runs | failed | success | planicp max error, median | planicp max error, 95th pct "
            "| odometry max error, median | lost scans, mean |",
            "|---|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for s in summary:
            lines.append(
                f"| {_label(s['value']) if column != 'plan' else s['value']} | {s['runs']} | {s['failed']} | "
                f"{100 * s['success_rate']:.0f} % | {_m(s['planicp_max_median_m'])} | "
                f"{_m(s['planicp_max_p95_m'])} | {_m(s['odometry_max_median_m'])} | "
                f"{_n(s['lost_scans_mean'])} |"
            )
    if failed:
        lines += ["", "## Failed runs", "", "| run | plan | seed | error |", "|---|---|---:|---|"]
        shown = failed[:MAX_FAILED_SHOWN]
        for r in shown:
            error = str(r["error"]).replace("|", "\\|").replace("\n", " ")
            lines.append(f"| {r['run_id']} | {r['plan']} | {r['seed']} | {error} |")
        if len(failed) > len(shown):
            lines += ["", f'... and {len(failed) - len(shown)} more (status "failed" in results.csv).']
    if figures:
        lines += ["", "## Figures", ""] + [f"![{name}]({name})" for name in figures]
    lines += ["", "All numbers per run: results.csv (one row per run, sorted by run id).", ""]
    return "\n".join(lines)


def _m(value: float) -> str:
    return "–" if not math.isfinite(value) else f"{value:.3f} m"


def _n(value: float) -> str:
    return "–" if not math.isfinite(value) else f"{value:.1f}"
