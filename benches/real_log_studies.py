"""Studies on the real CARMEN logs, through the peer harness's own loading (the even-numbered
scans draw the map_server plan, the odd-numbered ones are tracked from its synthetic odometry):

    python benches/real_log_studies.py search       # global search settings: right places, nodes
    python benches/real_log_studies.py visibility   # the Localizer with and without visibility
    python benches/real_log_studies.py seeds        # the Localizer over other draws of the odometry
    python benches/real_log_studies.py nees         # how honest Estimate.covariance is on real logs
    python benches/real_log_studies.py alignments   # one alignment: ray-cast view against the index's masks
    python benches/real_log_studies.py views        # tracking's view cast, to the scan's range or per direction
    python benches/real_log_studies.py refinement   # the Localizer with and without the posterior refinement
    python benches/real_log_studies.py field        # a SLAM map's likelihood field: density or nearest cell
    python benches/real_log_studies.py scan-sets    # other scan sets of the same logs: swapped, reversed
    python benches/real_log_studies.py junk         # corrupted scans: how far they move the estimates
    python benches/real_log_studies.py faults       # the Localizer with and without the odometry-fault sweep
    python benches/real_log_studies.py slam-visibility  # a SLAM map's visibility: the index's masks or a cast
    python benches/real_log_studies.py log-odometry     # the logs' own odometry: the masks or a cast
    python benches/real_log_studies.py reference        # the scans off the reference: whose error is it
    python benches/real_log_studies.py beyond           # returns a cast from the reference puts beyond the walls
    python benches/real_log_studies.py bars             # the gate's and lost rule's bars: relaxed or as set
    python benches/real_log_studies.py kidnap           # a robot carried elsewhere: noticed, found again
    python benches/real_log_studies.py catch-up         # a recovery's alignment against a search node, in time

`search` runs `planicp.relocalize` (the whole plan, no guess) on 12 evenly spaced tracked scans of
each log at the search settings compared in docs/benchmarks.md; a search is right when its best
candidate lies within 0.5 m of the reference pose and is not ambiguous. `visibility` tracks each log
with the `Localizer`'s defaults and with `IcpConfig.for_tracking(use_visibility=False)`. `seeds`
tracks each log with the defaults from the harness's synthetic odometry drawn with other seeds
(`--seeds`; the harness uses 7): one draw of the drift and the faults decides much on a hard log.
`nees` tracks each log with the defaults and, over the accepted estimates that are not relocalized
nor lost, gives the normalised estimation error squared e^T P^-1 e of `Estimate.covariance` (and of
the fit's own `IcpResult.covariance`, and of the odometry prediction's, `Prediction.covariance`)
against the reference pose: a consistent estimator's median is the chi-square's, 2.366 (the
reference poses' own error counts as the estimator's here).
`refinement` tracks each log from the odometry of each of `--seeds` with the `Localizer`'s defaults
(on these map_server maps: the pose refined in the plan's likelihood field) and with
`PosteriorRefinement(enabled=False)`, and gives the ATE and the share of scans more than 0.3 m off.
`field` tracks each log from the odometry of each of `--seeds` with the `Localizer`'s defaults
(on these map_server maps the plan's likelihood field is a density of the occupied cells, peaked
on the middle of a band of cells) and with the plan's field replaced by the nearest-cell field
(`exp(-d^2 / 2 sigma^2)` of the distance to the nearest occupied cell, what walls drawn as
surfaces get), and gives the range of the ATE over the draws and the mean share of scans more than
0.3 m off.
`alignments` aligns 60 evenly spaced tracked scans of each log from guesses off the reference pose
by a normal error (0.15 m per axis, 2.3 degrees; the size of a search candidate's or a followed
place's error) with the `Localizer`'s settings, once through the view ray cast from the guess (the
KD-tree search) and once through the nearest-wall index's visibility masks (no cast), and gives the
time per alignment and the share of fits left more than 0.3 m off. `views` casts the view a
tracking update casts (`OcclusionFilter.view`: the scan's arc, its visible points only) from the
reference pose of every 10th tracked scan, once out to the scan's farthest return plus the largest
stage distance in every direction and once only as far as a return could pair in each direction
(`pair_distance`), and gives the median time and the visible points of each; then it times making
a `Localizer` on a fresh copy of the plan (its nearest-wall index and occlusion grid).

`scan-sets` tracks each log, with the defaults and the harness's odometry seed, on scan sets the
harness does not use, so that what is tuned on its eight runs is checked on others: "swapped", the
plan drawn from the odd-numbered scans and the even-numbered ones tracked; "reversed", the
harness's plan and its tracked scans in reverse order (the robot driving the log backwards, its
odometry drawn anew for that drive). It gives ATE, the share of scans more than 0.3 m off, the
first of them, and the 99th percentile of the time per update. With `--no-ceiling` the searches
have no ceiling in time (`RecoveryConfig(search_time=None)`): only their nodes and the update's
spare time bound them. With `--memory-load` a second process streams through 512 MiB of memory
while the study runs, as another job on the machine does: a search node's cost grows with it.

`slam-visibility` tracks each log from the odometry of each of `--seeds` with the `Localizer`'s
defaults (on these map_server maps: pairs through the nearest-wall index's masks) and with the
view cast from the prediction (`IcpConfig.for_tracking(correspondence_search="kd_tree")`, what a
drawn plan gets), on the harness's plan and on two noisier ones drawn from the same scans (every
cell one end point falls in; 10 cm cells), and gives the mean ATE, the mean share of scans more
than 0.3 m off and the worst draw's. `seeds --search kd_tree` tracks with the cast too;
`seeds --odometry-noise 3` from odometry whose Gaussian noise (not its drift) is three times the
harness's; `seeds --stride 2` on every other one of the harness's tracked scans (with the odometry
drawn for all of them): steps twice as long between scans, as a log that keeps fewer scans gives.
`log-odometry` tracks each log from its own odometry (the robot's wheels, not the harness's
synthetic drift), as `planicp evaluate-log --odometry log` does, on the harness's scan sets and the
swapped and reversed ones, with the masks and with the cast.

`faults` tracks each log from the odometry of each of `--seeds` with the `Localizer`'s defaults
and with `PosteriorRefinement(fault_probability=0)` (no sweep for an odometry fault), and gives the
ATE and the share of scans more than 0.3 m off.
`junk` tracks each log with the defaults clean and with corrupted scans: the middle scan's points
shifted 3 m along the base x axis; one scan in five (from the tenth on) turned by 30 degrees (within
the heading window of the odometry-fault sweep, which a turned scan looks like) or by 90 degrees;
one scan in five replaced by as many points uniform in a 20 x 20 m square around the robot. It
gives how far a corrupted scan moved the estimate from the update's prediction (the largest over
the corrupted scans: what the scan itself did), the largest distance between a corrupted run's
estimates and the clean run's, over all scans and over the valid scans only (at a corrupted scan
the odometry is all there is, and its step may be off by more than the bar), and the share of the
corrupted run's scans more than 0.3 m off.
`junk-draws` gives that share for each odometry draw of `--seeds` (the junk drawn with the same
seed), per kind of corruption that recurs (one scan in five), its mean over the draws (where one
draw's outcome turns on a few scans, the mean says more), and the largest over the draws of the
99th percentile of the time per update; with `--bars-as-set`, with the gate's and the lost
rule's bars on the share of a scan a fit explains as set, not learned. With `--no-spare-time` the
recovery's searches score only the nodes of each update (`RecoveryConfig(search_time=None, search_spare_time=None)`):
what it finds, and when, is then the same on any machine and under any load (`faults --no-spare-time` and
`seeds --no-spare-time` likewise).
`junk-repeats` tracks each odometry draw of `--seeds` with one scan in five random clouds
`--repeats` times in one process (the plan loaded once): with the spare time a run depends on how
far each update's searches get, and one run of a draw says little of the next. Per draw, the share
of the scans more than 0.3 m off in each run, their range and their mean.

`reference` asks, at every tracked scan planicp's default `Localizer` leaves more than 0.3 m off
the reference pose (from the harness's odometry, `--seed`, default 7), whether the reference
itself is sound there (`--filter-out`, a harness output folder, adds how far MRPT's particle
filter was off there). The reference poses are a SLAM solution, not ground truth: the scan
is registered (small_gicp's point-to-point ICP, 1 m pairs, from the reference pose; a
registration independent of planicp) against the map scans within 10 m of it at their
reference poses, apart: those of the same pass (within 30 scans of it in the log) and those of
other passes. Where its own pass places it far from its reference, the reference is off there
(the tracked scan and its neighbours, taken a fraction of a second apart, disagree with it); where
both agree with the reference, the tracker is off. It also gives where the plan's likelihood field
puts the scan: the cost (`w sum (1 - g)^2`, no prior) of the field's mode climbed to from the
reference pose and from planicp's estimate; a lower cost at planicp's estimate is the plan
preferring that place.

`beyond` classifies the returns of every third tracked scan from its reference pose as the
occlusion rule does (`OcclusionFilter.classify`: a ray cast through the plan from the pose, a
return more than the rule's margin short of the wall in its direction is in front of it, more than
the margin past it beyond it), and gives the median and 90th percentile share of each: at the
true pose a wall that stops every beam has neither but for clutter in front.

`bars` tracks each log, from the odometry of each of `--seeds`, on the harness's plan drawn with
`--min-hits` end points per cell of `--resolution` metres, with the `Localizer`'s defaults (the
gate's and the lost rule's bars on the share of a scan a fit explains relaxed to what the track's
sound fits make likely, `Recovery.explained_bar`) and with them as set (`AcceptanceGate(relaxes=
False)`, `LostRule(relaxes=False)`), and gives for each the ATE, the share of scans more than
0.3 m off, the fits refused and the 99th percentile of the time per update, and for the defaults
the bar learned (`Recovery.explained_seen`) from the 20th update on: its least value and its median, and the share
of updates whose bars were relaxed.

`kidnap` tracks each log (harness odometry seed 7, plan drawn with `--min-hits` end points per cell)
to six evenly spaced scans K, then feeds the scans from the first scan J at least 20 scans later
and more than 8 m from scan K's reference pose, with odometry that continues smoothly (the robot
carried there without telling the localizer), for 25 updates, with the `Localizer`'s defaults
(with `--no-spare-time`, the searches' spare time off: the same on any machine), with the bars
learned and as set (`AcceptanceGate(relaxes=False)`, `LostRule(relaxes=False)`). It gives the updates until the
localizer said lost and until its estimate was back within 0.3 m of the reference and not lost
("-": not within the 25; `--updates` feeds more), and the updates after it said lost that it
reported tracked (not lost) more than 0.3 m off, of them how many `provisional` (on trial: the
whole plan searched beside the pose).

`kidnap-trace` follows one kidnap of `kidnap` (`--kidnap`: which of the six K, from 0; `--updates`
fed after it) update by update: how far the estimate is from the reference, whether the localizer
says lost, and the nodes each of the recovery's searches has scored (the one near the lost pose,
the whole plan's; a new search near the pose when the count restarts), and when each ends.

`catch-up` times what the recovery counts against an update's search budget on each log's plan:
the alignment of a place (`Recovery._follow`: ICP from the odometry's prediction and the check
against returns beyond the walls) of every 7th tracked scan from its reference pose, and a search
node of `relocalize` of the whole plan (every 60th tracked scan), and gives their medians and how
many nodes an alignment takes as long as (`ALIGNMENT_NODES` counts 2,000).

`overlaps` gives, per log, how much of each tracked scan lies on the scan before it and on the
one two before (`ContinuityRule.overlap`: placed by the harness's odometry motion, aligned with a
small correction), and how much of a random cloud put in its place (`junk`'s, one scan in five)
lies on the scan before it: quantiles over the log, what `Recovery._soundest` tells a sound scan
from a corrupted one by (`SOUND_OVERLAP`).

The harness (`real_logs.py`) and the logs live in the team's shared benchmarks, outside this
repository: `--harness` gives its path (default `../shared/bench/real_logs.py`).
"""

from __future__ import annotations

import argparse
import importlib.util
import inspect
import math
import multiprocessing
import os
import sys
import tempfile
import time
import warnings
from typing import Any

import numpy as np

import planicp
from planicp import (
    AcceptanceGate,
    IcpConfig,
    Localizer,
    LostRule,
    PlanMap,
    PosteriorRefinement,
    RecoveryConfig,
    RelocalizationConfig,
    SearchInSteps,
    _core,
    localize,
    relocalize,
    se2,
)
from planicp.tracking.continuity_rule import ContinuityRule
from planicp.tracking.decisions import Prediction
from planicp.tracking.odometry_fault import climb
from planicp.tracking.recovery import Hypothesis

SEARCH_SETTINGS = {
    "0.1 m, heading step from the scan, 200 points": RelocalizationConfig(
        resolution=0.1, sigma=0.1, levels=7, angular_step=None, max_scan_points=200
    ),
    "0.2 m, heading step from the scan, 100 points": RelocalizationConfig(angular_step=None),
    "0.2 m, 2 degrees, 100 points (the defaults)": RelocalizationConfig(),
}


def log_path(harness: Any, name: str) -> str:
    """The path of the harness's CARMEN log `name`."""
    return harness.INTEL_LOG if name == "intel" else os.path.join(harness.LOGS_DIR, f"{name}-corrected.log.gz")


def load(
    harness: Any,
    name: str,
    out: str,
    seed: int = 7,
    scan_set: str = "harness",
    resolution: float = 0.05,
    min_hits: int = 2,
    noise_scale: float = 1.0,
) -> tuple[Any, list[np.ndarray], np.ndarray, np.ndarray]:
    """(plan image, tracked scans, their reference poses, their odometry poses), as the harness
    makes them (its odometry drawn with `seed`; the harness's own is 7; its plan's cells of
    `resolution` metres occupied where `min_hits` end points fall; its odometry's Gaussian noise,
    not its drift, times `noise_scale`), or on another `scan_set` (see the module: "swapped",
    "reversed")."""
    log = harness.read_carmen_log(log_path(harness, name))
    mapped, tracked = np.arange(0, len(log.scans), 2), np.arange(1, len(log.scans), 2)
    if scan_set == "swapped":
        mapped, tracked = tracked, mapped
    ends = np.vstack([harness.transform(log.scans[i], log.poses[i]) for i in mapped])
    plan = harness.render_endpoint_plan(ends, resolution, min_hits)
    harness.save_ros_map(plan, out, f"{name}-plan-{resolution:g}-{min_hits}")
    times, _ = harness.scan_times(log.times, 0.2)
    stamps = times[tracked]
    if scan_set == "reversed":
        tracked, stamps = tracked[::-1], stamps[-1] - stamps[::-1]
    scans = [log.scans[i] for i in tracked]
    ref = log.poses[tracked]
    noise = {} if noise_scale == 1.0 else _odometry_noise(harness, noise_scale)
    _, odom = harness.synthesize_odometry(ref, stamps, np.random.default_rng(seed), **noise)
    return plan, scans, ref, odom


def _odometry_noise(harness: Any, scale: float) -> dict[str, float]:
    """The harness's `synthesize_odometry` noise arguments (not its drift) times `scale`."""
    defaults = inspect.signature(harness.synthesize_odometry).parameters
    names = ("trans_noise", "rot_noise_per_rad", "rot_noise_per_m")
    return {n: scale * float(defaults[n].default) for n in names}


def search_study(harness: Any, logs: list[str], out: str) -> None:
    print("| log | settings | right | nodes (median) | nodes (most) | out of nodes |")
    print("|---|---|---|---|---|---|")
    steps: list[tuple[str, list[float]]] = []
    for name in logs:
        plan, scans, ref, _ = load(harness, name, out)
        pm = PlanMap.from_ros_map(plan.yaml_path)
        picked = list(range(5, len(scans), max(1, len(scans) // 12)))[:12]
        for label, config in SEARCH_SETTINGS.items():
            relocalize(scans[picked[0]], pm, config=config)  # the likelihood pyramid, once
            right, nodes, short = 0, [], 0
            for k in picked:
                found = relocalize(scans[k], pm, config=config)
                nodes.append(found.nodes)
                short += not found.complete
                best = found.best
                if best is not None and not found.ambiguous and math.dist(best.pose[:2], ref[k, :2]) < 0.5:
                    right += 1
            print(
                f"| {name} | {label} | {right} of {len(picked)} | {np.median(nodes) / 1e3:.0f}k | "
                f"{max(nodes) / 1e3:.0f}k | {short} |",
                flush=True,
            )
        steps.append((name, step_times(pm, [scans[k] for k in picked])))
    print()
    print(f"One step of {STEP_NODES:,} nodes of a search of the whole plan, the defaults (the `Localizer`'s")
    print("budget per update): median and most over the 12 scans, ms")
    print()
    print("| log | median | most |")
    print("|---|---|---|")
    for name, spent in steps:
        print(f"| {name} | {1e3 * np.median(spent):.1f} | {1e3 * max(spent):.1f} |")


STEP_NODES = 20_000
"""The search nodes a `Localizer` update may score (`RecoveryConfig.search_nodes`)."""


def step_times(pm: PlanMap, scans: list[np.ndarray]) -> list[float]:
    """Seconds of the first `STEP_NODES`-node step of a search of the whole plan for each scan."""
    spent = []
    for scan in scans:
        steps = SearchInSteps(scan, pm)
        start = time.perf_counter()
        steps.advance(STEP_NODES)
        spent.append(time.perf_counter() - start)
    return spent


def track(
    harness: Any,
    plan: Any,
    scans: list[np.ndarray],
    ref: np.ndarray,
    odom: np.ndarray,
    config: IcpConfig | None = None,
    refinement: PosteriorRefinement | None = None,
    plan_map: PlanMap | None = None,
    recovery: RecoveryConfig | None = None,
) -> tuple[dict[str, float], list[float]]:
    """The harness's error metrics (0.3 m for lost) of a `Localizer` started at the first reference
    pose (on `plan_map`, default the plan image read as a user reads it), and the seconds each
    update took."""
    pm = plan_map or PlanMap.from_ros_map(plan.yaml_path)
    loc = Localizer(pm, tuple(map(float, ref[0])), config, refinement=refinement, recovery=recovery)
    loc.update(scans[0], tuple(map(float, odom[0])))
    est, spent = [ref[0]], []
    for k in range(1, len(scans)):
        start = time.perf_counter()
        est.append(np.array(loc.update(np.ascontiguousarray(scans[k]), tuple(map(float, odom[k]))).pose))
        spent.append(time.perf_counter() - start)
    return harness.error_metrics(np.array(est), ref, 0.3), spent


def field_study(harness: Any, logs: list[str], out: str, seeds: list[int]) -> None:
    print(
        "| log | nearest cell: ATE over the draws, mean lost | density (the default): ATE over the draws, mean lost |"
    )
    print("|---|---|---|")
    for name in logs:
        results: dict[str, list[dict[str, float]]] = {"nearest": [], "density": []}
        for seed in seeds:
            data = load(harness, name, out, seed)
            for profile, runs in results.items():
                pm = PlanMap.from_ros_map(data[0].yaml_path)
                if profile == "nearest":  # the field a drawn plan gets, in place of the default
                    pm._likelihood = _core.LikelihoodGrid.within_budget(pm.points, pm.spacing, pm.spacing, "nearest")
                runs.append(track(harness, *data, plan_map=pm)[0])
        cells = []
        for runs in results.values():
            ates = [100 * m["ate_rmse_m"] for m in runs]
            lost = np.mean([100 * m["lost_frac"] for m in runs])
            cells.append(f"{min(ates):.1f}-{max(ates):.1f} cm, {lost:.1f} %")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


def seeds_study(
    harness: Any,
    logs: list[str],
    out: str,
    seeds: list[int],
    search: str | None = None,
    noise_scale: float = 1.0,
    stride: int = 1,
    recovery: RecoveryConfig | None = None,
) -> None:
    print("| log | " + " | ".join(f"seed {s}" for s in seeds) + " | mean lost |")
    print("|---|" + "---|" * (len(seeds) + 1))
    config = None if search is None else IcpConfig.for_tracking(correspondence_search=search)
    for name in logs:
        cells, lost = [], []
        for seed in seeds:
            plan, scans, ref, odom = load(harness, name, out, seed, noise_scale=noise_scale)
            m, _ = track(harness, plan, scans[::stride], ref[::stride], odom[::stride], config, recovery=recovery)
            cells.append(f"{100 * m['ate_rmse_m']:.1f} cm, {100 * m['lost_frac']:.1f} %")
            lost.append(100 * m["lost_frac"])
        print(f"| {name} | " + " | ".join(cells) + f" | {np.mean(lost):.1f} % |", flush=True)


def slam_visibility_study(harness: Any, logs: list[str], out: str, seeds: list[int]) -> None:
    print("| log | plan cells | search | ATE (mean) | lost (mean) | lost (worst draw) |")
    print("|---|---|---|---|---|---|")
    maps = (("5 cm, 2 hits (the harness's)", 0.05, 2), ("5 cm, 1 hit", 0.05, 1), ("10 cm, 2 hits", 0.1, 2))
    searches = (("masks (default)", None), ("cast", IcpConfig.for_tracking(correspondence_search="kd_tree")))
    for name in logs:
        for label, resolution, min_hits in maps:
            for search, config in searches:
                ates, lost = [], []
                for seed in seeds:
                    case = load(harness, name, out, seed, resolution=resolution, min_hits=min_hits)
                    m, _ = track(harness, *case, config)
                    ates.append(100 * m["ate_rmse_m"])
                    lost.append(100 * m["lost_frac"])
                print(
                    f"| {name} | {label} | {search} | {np.mean(ates):.1f} cm | {np.mean(lost):.1f} % | "
                    f"{np.max(lost):.1f} % |",
                    flush=True,
                )


def log_odometry_study(harness: Any, logs: list[str]) -> None:
    from planicp.evaluation.log_evaluation import plan_from_scans
    from planicp.io import open_log

    print("| log | scan set | search | ATE | worst | lost (> 0.3 m) |")
    print("|---|---|---|---|---|---|")
    searches = (("masks (default)", None), ("cast", IcpConfig.for_tracking(correspondence_search="kd_tree")))
    for name in logs:
        path = log_path(harness, name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the logs' repaired timestamps
            usable = [f for f in open_log(path) if f.reference is not None and f.odometry is not None]
        for scan_set in ("harness", "swapped", "reversed"):
            mapped, tracked_frames = usable[0::2], usable[1::2]
            if scan_set == "swapped":
                mapped, tracked_frames = tracked_frames, mapped
            elif scan_set == "reversed":
                tracked_frames = tracked_frames[::-1]
            plan = plan_from_scans(mapped, 0.05, 2)
            ref = np.array([f.reference for f in tracked_frames])
            for search, config in searches:
                loc = Localizer(plan, tuple(map(float, ref[0])), config)
                est = np.array([loc.update(f.points(), f.odometry).pose for f in tracked_frames])
                err = np.hypot(*(est[:, :2] - ref[:, :2]).T)
                print(
                    f"| {name} | {scan_set} | {search} | {100 * np.sqrt(np.mean(err**2)):.1f} cm | "
                    f"{err.max():.2f} m | {100 * np.mean(err > 0.3):.1f} % |",
                    flush=True,
                )


def scan_sets_study(harness: Any, logs: list[str], out: str, recovery: RecoveryConfig | None = None) -> None:
    print("| log | scan set | ATE | lost (> 0.3 m) | first off | p99 ms/update |")
    print("|---|---|---|---|---|---|")
    for scan_set in ("swapped", "reversed"):
        for name in logs:
            m, spent = track(harness, *load(harness, name, out, scan_set=scan_set), recovery=recovery)
            first = "-" if m["first_lost_scan"] is None else str(m["first_lost_scan"])
            print(
                f"| {name} | {scan_set} | {100 * m['ate_rmse_m']:.1f} cm | {100 * m['lost_frac']:.1f} % | {first} | "
                f"{1e3 * np.percentile(spent, 99):.1f} |",
                flush=True,
            )


def localizer(plan: Any, start: np.ndarray, relaxes: bool = True, recovery: RecoveryConfig | None = None) -> Localizer:
    """A `Localizer` on the harness's plan image read as a user reads it, at `start`, with the
    defaults but for `recovery` (when given) and the gate's and lost rule's bars as set unless
    `relaxes`."""
    return Localizer(
        PlanMap.from_ros_map(plan.yaml_path),
        tuple(map(float, start)),
        recovery=recovery,
        gate=AcceptanceGate(relaxes=relaxes),
        lost_rule=LostRule(relaxes=relaxes),
    )


def tracked(
    plan: Any,
    scans: list[np.ndarray],
    ref: np.ndarray,
    odom: np.ndarray,
    seconds: list[float] | None = None,
    recovery: RecoveryConfig | None = None,
    bars_as_set: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) poses of a default `Localizer` (but for `recovery`, when given, and with the gate's
    and the lost rule's bars as set when `bars_as_set`) started at the first reference pose, and
    the (N, 3) poses it predicted from the odometry before each scan (stage 1, `Prediction.pose`);
    each update's time in seconds is appended to `seconds` when given."""
    loc = localizer(plan, ref[0], not bars_as_set, recovery)
    poses, predicted = [], []
    for s, o in zip(scans, odom):
        start = time.perf_counter()
        estimate = loc.update(np.ascontiguousarray(s), tuple(map(float, o)))
        if seconds is not None:
            seconds.append(time.perf_counter() - start)
        poses.append(estimate.pose)
        predicted.append(estimate.decisions[0].pose)  # type: ignore[attr-defined]
    return np.array(poses), np.array(predicted)


def junk_indices(n: int, kind: str) -> np.ndarray:
    """Which of `n` scans `corrupted` corrupts for `kind`."""
    if kind == "shifted 3 m":
        return np.array([n // 2])
    return np.arange(10, n, 5)


def corrupted(scans: list[np.ndarray], kind: str, rng: np.random.Generator) -> list[np.ndarray]:
    """`scans` with some corrupted as `kind` says (see the module's `junk`)."""
    junk = set(junk_indices(len(scans), kind).tolist())
    if kind == "shifted 3 m":
        return [s + np.array([3.0, 0.0]) if k in junk else s for k, s in enumerate(scans)]
    out = []
    for k, s in enumerate(scans):
        if k not in junk:
            out.append(s)
        elif kind == "random clouds":
            out.append(rng.uniform(-10.0, 10.0, size=s.shape))
        else:
            a = math.radians(30.0 if kind == "turned 30 degrees" else 90.0)
            out.append(s @ np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]))
    return out


def junk_study(harness: Any, logs: list[str], out: str) -> None:
    kinds = ("shifted 3 m", "turned 30 degrees", "turned 90 degrees", "random clouds")
    print("| log | clean: lost | " + " | ".join(f"{k}: moved; apart, at valid scans; lost" for k in kinds) + " |")
    print("|---|---|" + "---|" * len(kinds))
    for name in logs:
        plan, scans, ref, odom = load(harness, name, out)
        clean = tracked(plan, scans, ref, odom)[0]
        cells = [f"{100 * harness.error_metrics(clean, ref, 0.3)['lost_frac']:.1f} %"]
        for kind in kinds:
            est, predicted = tracked(plan, corrupted(scans, kind, np.random.default_rng(1)), ref, odom)
            junk = junk_indices(len(scans), kind)
            moved = float(np.max(np.hypot(*(est[junk, :2] - predicted[junk, :2]).T)))
            apart = np.hypot(*(est[:, :2] - clean[:, :2]).T)
            valid = np.ones(len(scans), dtype=bool)
            valid[junk] = False
            lost = harness.error_metrics(est, ref, 0.3)["lost_frac"]
            apart_cm = f"{100 * apart.max():.1f} cm, {100 * apart[valid].max():.1f} cm"
            cells.append(f"{100 * moved:.1f} cm; {apart_cm}; {100 * lost:.1f} %")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


def bars_study(
    harness: Any, logs: list[str], out: str, min_hits: int, seeds: list[int], resolution: float = 0.05
) -> None:
    print(
        "| log | seed | relaxed (default): ATE, off, refused, p99 ms | as set: ATE, off, refused, p99 ms "
        "| bar learned: least, median | updates relaxed |"
    )
    print("|---|---|---|---|---|---|")
    for name in logs:
        for seed in seeds:
            plan, scans, ref, odom = load(harness, name, out, seed, resolution=resolution, min_hits=min_hits)
            cells, learned, relaxed = [], [], 0
            for relaxes in (True, False):
                loc = localizer(plan, ref[0], relaxes)
                loc.update(scans[0], tuple(map(float, odom[0])))
                est, refused, spent = [ref[0]], 0, []
                for k in range(1, len(scans)):
                    bar = loc._recovery.explained_bar
                    start = time.perf_counter()
                    e = loc.update(np.ascontiguousarray(scans[k]), tuple(map(float, odom[k])))
                    spent.append(time.perf_counter() - start)
                    est.append(np.array(e.pose))
                    refused += not e.accepted
                    if relaxes and k >= 20 and bar is not None:
                        learned.append(bar)
                        relaxed += bar < max(AcceptanceGate().min_inlier_ratio, LostRule().min_score)
                m = harness.error_metrics(np.array(est), ref, 0.3)
                p99 = 1e3 * float(np.percentile(spent, 99))
                cells.append(f"{100 * m['ate_rmse_m']:.1f} cm, {100 * m['lost_frac']:.1f} %, {refused}, {p99:.1f}")
            a = np.array(learned) if learned else np.array([math.nan])
            share = 100 * relaxed / max(1, len(learned))
            print(
                f"| {name} | {seed} | " + " | ".join(cells) + f" | {a.min():.2f}, {np.median(a):.2f} | {share:.0f} % |",
                flush=True,
            )


def kidnap_study(
    harness: Any, logs: list[str], out: str, min_hits: int, recovery: RecoveryConfig | None = None, updates: int = 25
) -> None:
    print(
        "| log | K | J | learned: lost after, back after, tracked off (provisional) "
        "| as set: lost after, back after, tracked off (provisional) |"
    )
    print("|---|---|---|---|---|")
    for name in logs:
        plan, scans, ref, odom = load(harness, name, out, min_hits=min_hits)
        for k, j in kidnaps(ref, updates):
            cells = []
            for relaxes in (True, False):
                loc = localizer(plan, ref[0], relaxes, recovery)
                lost_at = back_at = None
                off = provisional = 0  # after the loss: reported tracked (not lost) more than 0.3 m off
                for i, moved in enumerate(kidnapped(loc, scans, odom, k, j, updates)):
                    e = loc.update(np.ascontiguousarray(scans[j + i]), moved)
                    far = math.dist(e.pose[:2], ref[j + i][:2]) >= 0.3
                    if lost_at is None and e.lost:
                        lost_at = i + 1
                    if back_at is None and not e.lost and not far:
                        back_at = i + 1
                    if lost_at is not None and not e.lost and far:
                        off, provisional = off + 1, provisional + e.provisional
                noticed, back = ("-" if at is None else str(at) for at in (lost_at, back_at))
                cells.append(f"{noticed}, {back}, {off} ({provisional})")
            print(f"| {name} | {k} | {j} | " + " | ".join(cells) + " |", flush=True)


def kidnaps(ref: np.ndarray, updates: int) -> list[tuple[int, int]]:
    """The kidnaps of the `kidnap` study: (K, J) at six evenly spaced K, J the first scan at least
    20 after K and more than 8 m from its reference pose with `updates` scans left after it."""
    n, pairs = len(ref), []
    for k in np.linspace(30, n - 60, 6).astype(int):
        j = next((j for j in range(k + 20, n - updates) if math.dist(ref[j][:2], ref[k][:2]) > 8.0), None)
        if j is not None:
            pairs.append((int(k), j))
    return pairs


def kidnapped(loc: Localizer, scans: list[np.ndarray], odom: np.ndarray, k: int, j: int, updates: int) -> Any:
    """Tracks scans 0..K with `loc`, then yields for each of the `updates` scans from J the
    odometry pose that goes on smoothly from K's (the caller updates `loc` with it)."""
    for i in range(k + 1):
        loc.update(np.ascontiguousarray(scans[i]), tuple(map(float, odom[i])))
    last, origin = tuple(map(float, odom[k])), tuple(map(float, odom[j - 1]))
    for i in range(updates):
        yield se2.compose(last, se2.between(origin, tuple(map(float, odom[j + i]))))


def kidnap_trace_study(
    harness: Any, name: str, out: str, kidnap: int, recovery: RecoveryConfig | None = None, updates: int = 25
) -> None:
    plan, scans, ref, odom = load(harness, name, out)
    k, j = kidnaps(ref, updates)[kidnap]
    loc = localizer(plan, ref[0], True, recovery)
    print(f"{name}: kidnapped after scan {k}, fed from scan {j}")
    print("| update | off, m | lost | near the pose: nodes | whole plan: nodes | ended |")
    print("|---|---|---|---|---|---|")
    rec = loc._recovery
    for i, moved in enumerate(kidnapped(loc, scans, odom, k, j, updates)):
        runs = (rec._near, rec._whole)
        searching = [r is not None and r.places is None for r in runs]
        e = loc.update(np.ascontiguousarray(scans[j + i]), moved)
        ended = [
            what
            for what, run, was in zip(("near the pose", "whole plan"), runs, searching)
            if was and run is not None and run.places is not None
        ]
        nodes = ["-" if r is None else f"{r.steps.nodes:,}" for r in (rec._near, rec._whole)]
        off = math.dist(e.pose[:2], ref[j + i][:2])
        print(f"| {i + 1} | {off:.1f} | {'yes' if e.lost else 'no'} | {nodes[0]} | {nodes[1]} | {', '.join(ended)} |")


def catch_up_study(harness: Any, logs: list[str], out: str) -> None:
    print("| log | alignment ms (median) | node us (median) | nodes an alignment takes as long as |")
    print("|---|---|---|---|")
    for name in logs:
        plan, scans, ref, odom = load(harness, name, out)
        pm = PlanMap.from_ros_map(plan.yaml_path)
        recovery = Localizer(pm, tuple(map(float, ref[0])))._recovery
        recovery.new_update()
        align: list[float] = []
        for j in range(30, len(scans) - 1, 7):
            here = tuple(map(float, ref[j]))
            place = Hypothesis(here, localize(scans[j], pm, here, recovery.icp), 1, 0.9, False)
            motion = se2.between(tuple(map(float, odom[j])), tuple(map(float, odom[j + 1])))
            start = time.perf_counter()
            recovery._follow(place, np.ascontiguousarray(scans[j + 1]), motion)
            align.append(time.perf_counter() - start)
        node = [r.seconds / r.nodes for r in (relocalize(scans[j], pm) for j in range(30, len(scans) - 30, 60))]
        a, b = float(np.median(align)), float(np.median(node))
        print(f"| {name} | {1e3 * a:.2f} | {1e6 * b:.2f} | {a / b:,.0f} |", flush=True)


def overlaps_study(harness: Any, logs: list[str], out: str) -> None:
    rule = ContinuityRule()
    print(
        "| log | on the scan before: 5th percentile, quartiles | on the one two before: the same "
        "| a random cloud on the scan before: median, 95th percentile, largest |"
    )
    print("|---|---|---|---|")
    for name in logs:
        _, scans, _, odom = load(harness, name, out)
        clouds = corrupted(scans, "random clouds", np.random.default_rng(7))
        pose = [tuple(map(float, o)) for o in odom]
        before, two_before, cloud = [], [], []
        for i in range(2, len(scans)):
            before.append(rule.overlap(scans[i], scans[i - 1], se2.between(pose[i - 1], pose[i])))
            two_before.append(rule.overlap(scans[i], scans[i - 2], se2.between(pose[i - 2], pose[i])))
            if clouds[i] is not scans[i]:
                cloud.append(rule.overlap(clouds[i], scans[i - 1], se2.between(pose[i - 1], pose[i])))
        sound = [np.quantile(v, [0.05, 0.25, 0.5, 0.75]) for v in (before, two_before)]
        cells = [", ".join(f"{q:.2f}" for q in qs) for qs in sound]
        junk = np.quantile(cloud, [0.5, 0.95])
        print(f"| {name} | {cells[0]} | {cells[1]} | {junk[0]:.2f}, {junk[1]:.2f}, {max(cloud):.2f} |", flush=True)


def junk_draws_study(
    harness: Any,
    logs: list[str],
    out: str,
    seeds: list[int],
    recovery: RecoveryConfig | None = None,
    bars_as_set: bool = False,
) -> None:
    kinds = ("turned 30 degrees", "turned 90 degrees", "random clouds")
    print("| log | corruption | " + " | ".join(f"seed {s}" for s in seeds) + " | mean | p99 ms (worst draw) |")
    print("|---|---|" + "---|" * (len(seeds) + 2))
    for name in logs:
        lost: dict[str, list[float]] = {kind: [] for kind in kinds}
        p99: dict[str, list[float]] = {kind: [] for kind in kinds}
        for seed in seeds:
            plan, scans, ref, odom = load(harness, name, out, seed)
            for kind in kinds:
                seconds: list[float] = []
                junk = corrupted(scans, kind, np.random.default_rng(seed))
                est, _ = tracked(plan, junk, ref, odom, seconds, recovery, bars_as_set)
                lost[kind].append(100 * harness.error_metrics(est, ref, 0.3)["lost_frac"])
                p99[kind].append(1e3 * float(np.quantile(seconds, 0.99)))
        for kind in kinds:
            cells = " | ".join(f"{v:.1f} %" for v in lost[kind])
            print(f"| {name} | {kind} | {cells} | {np.mean(lost[kind]):.1f} % | {max(p99[kind]):.1f} |", flush=True)


def junk_repeats_study(
    harness: Any, logs: list[str], out: str, seeds: list[int], repeats: int, recovery: RecoveryConfig | None = None
) -> None:
    kind = "random clouds"
    print("| log | seed | runs | range | mean |")
    print("|---|---|---|---|---|")
    for name in logs:
        for seed in seeds:
            plan, scans, ref, odom = load(harness, name, out, seed)
            junk = corrupted(scans, kind, np.random.default_rng(seed))
            lost = []
            for _ in range(repeats):
                est, _ = tracked(plan, junk, ref, odom, None, recovery)
                lost.append(100 * harness.error_metrics(est, ref, 0.3)["lost_frac"])
            runs = ", ".join(f"{v:.1f}" for v in lost)
            print(
                f"| {name} | {seed} | {runs} | {min(lost):.1f}-{max(lost):.1f} % | {np.mean(lost):.1f} % |", flush=True
            )


def refinement_study(
    harness: Any,
    logs: list[str],
    out: str,
    seeds: list[int],
    without: PosteriorRefinement | None = None,
    recovery: RecoveryConfig | None = None,
) -> None:
    """Each log and seed tracked with `without` (default: no refinement) and with the defaults
    (but for `recovery`, in both, when given)."""
    print("| log | seed | without: ATE, lost | with (the default): ATE, lost |")
    print("|---|---|---|---|")
    for name in logs:
        for seed in seeds:
            data = load(harness, name, out, seed)
            cells = []
            for rule in (without or PosteriorRefinement(enabled=False), PosteriorRefinement()):
                m, _ = track(harness, *data, refinement=rule, recovery=recovery)
                cells.append(f"{100 * m['ate_rmse_m']:.1f} cm, {100 * m['lost_frac']:.1f} %")
            print(f"| {name} | {seed} | " + " | ".join(cells) + " |", flush=True)


def nees_study(harness: Any, logs: list[str], out: str) -> None:
    print(
        "| log | estimates | estimate NEES median | times the chi-square's | fit NEES median | times "
        "| prediction NEES median | times |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name in logs:
        plan, scans, ref, odom = load(harness, name, out)
        loc = Localizer(PlanMap.from_ros_map(plan.yaml_path), tuple(map(float, ref[0])))
        loc.update(scans[0], tuple(map(float, odom[0])))
        estimate_nees: list[float] = []
        fit_nees: list[float] = []
        prediction_nees: list[float] = []
        for k in range(1, len(scans)):
            e = loc.update(np.ascontiguousarray(scans[k]), tuple(map(float, odom[k])))
            if not e.accepted or e.result is None or e.relocalized or e.lost:
                continue
            prediction = e.decisions[0]
            assert isinstance(prediction, Prediction)
            for pose, cov, into in (
                (e.pose, e.covariance, estimate_nees),
                (e.result.pose, e.result.covariance, fit_nees),
                (prediction.pose, prediction.covariance, prediction_nees),
            ):
                d = np.array(pose) - ref[k]
                d[2] = (d[2] + math.pi) % (2 * math.pi) - math.pi
                if np.isfinite(cov).all():
                    into.append(float(d @ np.linalg.solve(cov, d)))
        a, b, c = np.median(estimate_nees), np.median(fit_nees), np.median(prediction_nees)
        print(
            f"| {name} | {len(estimate_nees)} | {a:.1f} | {a / CHI2_3_MEDIAN:.1f} "
            f"| {b:.1f} | {b / CHI2_3_MEDIAN:.1f} | {c:.1f} | {c / CHI2_3_MEDIAN:.1f} |",
            flush=True,
        )


CHI2_3_MEDIAN = 2.366
"""The median of a chi-square with 3 degrees of freedom."""


def visibility_study(harness: Any, logs: list[str], out: str) -> None:
    print("| log | visibility | ATE | lost (> 0.3 m) | ms per update |")
    print("|---|---|---|---|---|")
    for name in logs:
        plan, scans, ref, odom = load(harness, name, out)
        for visible in (True, False):
            m, spent = track(harness, plan, scans, ref, odom, IcpConfig.for_tracking(use_visibility=visible))
            print(
                f"| {name} | {'on (default)' if visible else 'off'} | {100 * m['ate_rmse_m']:.1f} cm | "
                f"{100 * m['lost_frac']:.1f} % | {1e3 * np.mean(spent):.2f} |",
                flush=True,
            )


ALIGNMENT_SEARCHES = ("kd_tree", "wall_index")
"""The two visibility paths the `alignments` study compares (`IcpConfig.correspondence_search`)."""


def alignments_study(harness: Any, logs: list[str], out: str) -> None:
    print("| log | search | ms per alignment (median) | 90th percentile | median error | fits > 0.3 m off |")
    print("|---|---|---|---|---|---|")
    for name in logs:
        plan, scans, ref, _ = load(harness, name, out)
        pm = PlanMap.from_ros_map(plan.yaml_path)
        picked = range(10, len(scans), max(1, len(scans) // 60))
        rng = np.random.default_rng(0)
        guesses = [ref[k] + rng.normal(0.0, [0.15, 0.15, math.radians(2.3)]) for k in picked]
        for search in ALIGNMENT_SEARCHES:
            config = IcpConfig.for_tracking(correspondence_search=search)
            localize(scans[picked[0]], pm, tuple(map(float, guesses[0])), config)  # the index, once
            spent, errors = [], []
            for k, guess in zip(picked, guesses):
                start = time.perf_counter()
                fit = localize(scans[k], pm, tuple(map(float, guess)), config)
                spent.append(time.perf_counter() - start)
                errors.append(math.dist(fit.pose[:2], ref[k, :2]))
            print(
                f"| {name} | {search} | {1e3 * np.median(spent):.2f} | {1e3 * np.percentile(spent, 90):.2f} | "
                f"{100 * np.median(errors):.1f} cm | {100 * np.mean(np.array(errors) > 0.3):.0f} % |",
                flush=True,
            )


def views_study(harness: Any, logs: list[str], out: str) -> None:
    print("| log | cast | ms per view (median) | visible points (mean) | making the Localizer, s |")
    print("|---|---|---|---|---|")
    config = IcpConfig.for_tracking()
    pair = _core.largest_pair_distance(config._native)
    casts = (("to the scan's range", None), ("per direction (default)", pair))
    for name in logs:
        plan, scans, ref, _ = load(harness, name, out)
        start = time.perf_counter()
        Localizer(PlanMap.from_ros_map(plan.yaml_path, cache=False), tuple(map(float, ref[0])))
        made = time.perf_counter() - start
        pm = PlanMap.from_ros_map(plan.yaml_path)
        spent: dict[str, list[float]] = {label: [] for label, _ in casts}
        visible: dict[str, list[int]] = {label: [] for label, _ in casts}
        for k in range(0, len(scans), 10):
            points = np.ascontiguousarray(scans[k])
            pose = tuple(map(float, ref[k]))
            reach = _core.visibility_range(points, config._native)
            for label, pair_distance in casts:  # the two casts of one scan one after the other
                start = time.perf_counter()
                view = pm.view_from(pose, reach, 1440, points, False, pair_distance)
                spent[label].append(time.perf_counter() - start)
                visible[label].append(len(view.visible_indices))
        for label, pair_distance in casts:
            print(
                f"| {name} | {label} | {1e3 * np.median(spent[label]):.2f} | {np.mean(visible[label]):.0f} | "
                f"{f'{made:.2f}' if pair_distance is not None else ''} |",
                flush=True,
            )


def reference_study(harness: Any, logs: list[str], out: str, filter_out: str | None, seed: int) -> None:
    """See the module: at the scans off the reference, where the map scans place them."""
    import small_gicp  # the harness's ICP peer: a registration independent of planicp

    print(
        "| log | scan | planicp off | filter off | its own pass: from the reference | other passes: "
        "from the reference | field cost at the mode near the reference / near planicp's |"
    )
    print("|---|---|---|---|---|---|---|")
    for name in logs:
        log = harness.read_carmen_log(log_path(harness, name))
        plan, scans, ref, odom = load(harness, name, out, seed)
        est = tracked(plan, scans, ref, odom)[0]
        off = np.hypot(*(est[:, :2] - ref[:, :2]).T)
        filter_off = np.zeros(len(ref))
        if filter_out is not None:
            text = open(os.path.join(filter_out, f"{name}-plan-mrpt", "pf.out")).read()
            pf = np.array(
                [float(v) for m in harness.MrptPfLocalization.estimate_line.finditer(text) for v in m.groups()]
            ).reshape(-1, 3)
            n = min(len(pf), len(ref))
            filter_off[:n] = np.hypot(*(pf[:n, :2] - ref[:n, :2]).T)
        pm = PlanMap.from_ros_map(plan.yaml_path)
        world = {}
        for k in np.flatnonzero(off > 0.3):
            raw = 2 * int(k) + 1  # the harness tracks the odd-numbered scans
            near = [j for j in range(0, len(log.scans), 2) if math.dist(log.poses[j][:2], log.poses[raw][:2]) < 10.0]
            cells = []
            for own in (True, False):
                group = [j for j in near if (abs(j - raw) <= 30) == own]
                if not group:
                    cells.append("none")
                    continue
                for j in group:
                    if j not in world:
                        world[j] = harness.transform(log.scans[j], log.poses[j])
                target = small_gicp.PointCloud(harness.lift3(np.vstack([world[j] for j in group])))
                result = small_gicp.align(
                    target,
                    small_gicp.PointCloud(harness.lift3(log.scans[raw])),
                    small_gicp.KdTree(target),
                    init_T_target_source=harness.pose_to_matrix4(log.poses[raw]),
                    registration_type="ICP",
                    max_correspondence_distance=1.0,
                    max_iterations=50,
                )
                placed = result.T_target_source[:2, 3]
                cells.append(f"{math.dist(placed, log.poses[raw][:2]):.2f} m ({len(group)} scans)")
            points = np.ascontiguousarray(scans[k])
            costs = [
                climb(points, tuple(map(float, start)), pm, PosteriorRefinement())[1] for start in (ref[k], est[k])
            ]
            print(
                f"| {name} | {k} | {off[k]:.2f} m | "
                + (f"{filter_off[k]:.2f} m" if filter_out is not None else "")
                + f" | {cells[0]} | {cells[1]} | {costs[0]:.1f} / {costs[1]:.1f} |",
                flush=True,
            )


def beyond_study(harness: Any, logs: list[str], out: str) -> None:
    """See the module: the occlusion rule's classification at the reference poses."""
    from planicp.tracking.occlusion_rule import OcclusionFilter, OcclusionRule

    print("| log | in front: median, 90th percentile | beyond: median, 90th percentile |")
    print("|---|---|---|")
    for name in logs:
        plan, scans, ref, _ = load(harness, name, out)
        occlusion = OcclusionFilter(PlanMap.from_ros_map(plan.yaml_path), OcclusionRule())
        shares = np.array(
            [
                [
                    np.mean(side)
                    for side in occlusion.classify(np.ascontiguousarray(scans[k]), tuple(map(float, ref[k])))
                ]
                for k in range(0, len(scans), 3)
            ]
        )
        front, beyond = (np.percentile(shares[:, i], [50, 90]) for i in (0, 1))
        cells = [f"{100 * share[0]:.0f} %, {100 * share[1]:.0f} %" for share in (front, beyond)]
        print(f"| {name} | {cells[0]} | {cells[1]} |", flush=True)


def _stream_memory() -> None:
    """Copies between two arrays of 256 MiB each until the process is ended: another job on the
    machine that takes one core and the memory bandwidth and caches."""
    a = np.ones(2**25)
    b = np.empty_like(a)
    while True:
        np.copyto(b, a)
        np.copyto(a, b)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "study",
        choices=(
            "search",
            "visibility",
            "seeds",
            "nees",
            "alignments",
            "views",
            "refinement",
            "field",
            "scan-sets",
            "junk",
            "junk-draws",
            "junk-repeats",
            "faults",
            "slam-visibility",
            "log-odometry",
            "reference",
            "beyond",
            "bars",
            "kidnap",
            "catch-up",
            "kidnap-trace",
            "overlaps",
        ),
    )
    parser.add_argument("--harness", default=os.path.join("..", "shared", "bench", "real_logs.py"))
    parser.add_argument("--logs", nargs="+", default=["fhw", "freiburg-campus", "intel"])
    parser.add_argument(
        "--seeds",
        nargs="+",
        type=int,
        default=[1, 2, 3, 4, 5, 6, 7],
        help="odometry seeds of the seeds, junk-draws, junk-repeats and bars studies",
    )
    parser.add_argument(
        "--search",
        choices=("kd_tree", "wall_index"),
        default=None,
        help="seeds study: track with IcpConfig.for_tracking(correspondence_search=...) (default: the Localizer's)",
    )
    parser.add_argument("--seed", type=int, default=7, help="reference study: the odometry seed (the harness's is 7)")
    parser.add_argument(
        "--odometry-noise",
        type=float,
        default=1.0,
        help="seeds study: the harness's odometry noise (not its drift) times this",
    )
    parser.add_argument(
        "--stride", type=int, default=1, help="seeds study: track every Nth of the harness's tracked scans"
    )
    parser.add_argument(
        "--no-spare-time",
        action="store_true",
        help="seeds, junk-draws, junk-repeats, faults and kidnap studies: "
        "RecoveryConfig(search_time=None, search_spare_time=None), the same on any machine",
    )
    parser.add_argument(
        "--no-ceiling",
        action="store_true",
        help="scan-sets, seeds, junk-draws, junk-repeats, faults and kidnap studies: RecoveryConfig(search_time=None), "
        "the searches bounded by their nodes and the update's spare time only",
    )
    parser.add_argument(
        "--memory-load",
        action="store_true",
        help="a second process streams through 512 MiB of memory while the study runs (a loaded machine)",
    )
    parser.add_argument(
        "--filter-out",
        default=None,
        help="reference study: a harness output folder (--out) whose MRPT filter's estimates to check too",
    )
    parser.add_argument(
        "--resolution", type=float, default=0.05, help="bars study: the plan cells, metres (the harness: 0.05)"
    )
    parser.add_argument(
        "--bars-as-set",
        action="store_true",
        help="junk-draws study: AcceptanceGate(relaxes=False), LostRule(relaxes=False): the bars not learned",
    )
    parser.add_argument(
        "--min-hits",
        type=int,
        default=2,
        help="bars and kidnap studies: end points per cell of the plan (the harness's is 2)",
    )
    parser.add_argument("--repeats", type=int, default=10, help="junk-repeats study: runs of each draw")
    parser.add_argument("--kidnap", type=int, default=0, help="kidnap-trace study: which of the six K (0-5)")
    parser.add_argument(
        "--updates", type=int, default=25, help="kidnap study: updates fed after the kidnap (the default 25)"
    )
    args = parser.parse_args()
    if args.stride < 1:
        parser.error("--stride must be 1 or more")
    spec = importlib.util.spec_from_file_location("real_logs", args.harness)
    if spec is None or spec.loader is None or not os.path.exists(args.harness):
        sys.exit(f"no harness at {args.harness}: give its path with --harness")
    harness = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(harness)
    print(f"planicp {planicp.__version__}")
    recovery = None
    if args.no_spare_time:
        recovery = RecoveryConfig(search_time=None, search_spare_time=None)
    elif args.no_ceiling:
        recovery = RecoveryConfig(search_time=None)
    if args.memory_load:
        multiprocessing.Process(target=_stream_memory, daemon=True).start()
    with tempfile.TemporaryDirectory() as out:
        if args.study == "seeds":
            seeds_study(harness, args.logs, out, args.seeds, args.search, args.odometry_noise, args.stride, recovery)
        elif args.study == "slam-visibility":
            slam_visibility_study(harness, args.logs, out, args.seeds)
        elif args.study == "log-odometry":
            log_odometry_study(harness, args.logs)
        elif args.study == "beyond":
            beyond_study(harness, args.logs, out)
        elif args.study == "kidnap":
            kidnap_study(harness, args.logs, out, args.min_hits, recovery, args.updates)
        elif args.study == "kidnap-trace":
            kidnap_trace_study(harness, args.logs[0], out, args.kidnap, recovery, args.updates)
        elif args.study == "catch-up":
            catch_up_study(harness, args.logs, out)
        elif args.study == "overlaps":
            overlaps_study(harness, args.logs, out)
        elif args.study == "bars":
            bars_study(harness, args.logs, out, args.min_hits, args.seeds, args.resolution)
        elif args.study == "reference":
            reference_study(harness, args.logs, out, args.filter_out, args.seed)
        elif args.study == "scan-sets":
            scan_sets_study(harness, args.logs, out, recovery)
        elif args.study == "junk":
            junk_study(harness, args.logs, out)
        elif args.study == "junk-draws":
            junk_draws_study(harness, args.logs, out, args.seeds, recovery, args.bars_as_set)
        elif args.study == "junk-repeats":
            junk_repeats_study(harness, args.logs, out, args.seeds, args.repeats, recovery)
        elif args.study == "field":
            field_study(harness, args.logs, out, args.seeds)
        elif args.study == "refinement":
            refinement_study(harness, args.logs, out, args.seeds)
        elif args.study == "faults":
            refinement_study(harness, args.logs, out, args.seeds, PosteriorRefinement(fault_probability=0.0), recovery)
        elif args.study == "nees":
            nees_study(harness, args.logs, out)
        elif args.study == "alignments":
            alignments_study(harness, args.logs, out)
        elif args.study == "views":
            views_study(harness, args.logs, out)
        else:
            (search_study if args.study == "search" else visibility_study)(harness, args.logs, out)


if __name__ == "__main__":
    main()
