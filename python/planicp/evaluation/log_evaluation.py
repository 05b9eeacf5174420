"""Scoring planicp on a real log that carries reference poses (`planicp evaluate-log`).

The protocol (the one `../shared/bench/README.md` uses for the ICP peers and MRPT's particle filter
on the Intel Research Lab log):

1. A plan image is rendered at `resolution` from the EVEN-numbered scans placed at their reference
   poses: a pixel is wall when at least `min_hits` scan end points fall in it; the wall points are
   the centres of those pixels (`edge_detector="centres"`).
2. The ODD-numbered scans are tracked against that plan from the first odd scan's reference pose.
   Their odometry is synthesised from the reference motion between consecutive odd scans, with the
   thesis's drift on every 10 ms odometry message (+5e-5 m forward, +5e-5 rad; `ErrorGenerator`)
   plus Gaussian noise per scan step: 2 % of the step's length on x and y, and 1 deg per radian
   turned + 0.2 deg per metre driven on the heading (`OdometryDrift`). With `odometry="log"` the
   log's own odometry is used instead (when it has one).
3. Translation ATE (RMS), heading RMS, the worst error and the share of scans off by more than
   0.3 m are reported for odometry alone and for planicp (`TrackedLog.metrics`).

Tracking scans the plan was drawn from would be circular; the odd scans were not used for the plan,
but they see the same walls (and the same furniture, which in a real office is in the "plan" too).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose, positive, whole_number
from ..io.scan_log import ScanFrame
from ..mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid, finest_resolution
from ..plans.image_files import MAX_IMAGE_PIXELS
from ..plans.plan_map import PlanMap
from ..plans.plan_raster import PlanRaster
from ..se2 import between, compose, transform_points, wrap_angle
from ..sim.odometry import ErrorGenerator
from ..tracking.icp_config import IcpConfig
from .log_replay import TrackedLog, track_log

ODOMETRY_SOURCES = ("synthetic", "log")


@dataclass(frozen=True)
class OdometryDrift:
    """The synthetic odometry of the evaluation.

    Attributes:
        error_generator: constants added to every odometry message (the thesis's drift).
        message_period_s: seconds between odometry messages (10 ms: 100 Hz).
        translation_noise_fraction: sigma of the x and y noise of a scan step, as a fraction of its length.
        rotation_noise_per_rad: sigma of the heading noise per radian turned in the step (radians per radian).
        rotation_noise_per_m: sigma of the heading noise per metre driven in the step (radians per metre).
    """

    error_generator: ErrorGenerator = field(default_factory=ErrorGenerator)
    message_period_s: float = 0.01
    translation_noise_fraction: float = 0.02
    rotation_noise_per_rad: float = math.radians(1.0)
    rotation_noise_per_m: float = math.radians(0.2)

    def __post_init__(self) -> None:
        positive(self.message_period_s, "message_period_s", "seconds")
        for name in ("translation_noise_fraction", "rotation_noise_per_rad", "rotation_noise_per_m"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")


def plan_from_scans(
    frames: Sequence[ScanFrame], resolution: float = 0.05, min_hits: int = 2, margin: float = 1.0
) -> PlanMap:
    """A plan rendered from scans at their reference poses: a pixel of `resolution` metres is wall
    when at least `min_hits` end points fall in it; the image covers the end points plus `margin`.
    Its points are the wall pixels' centres, and it is `metric` (as a map_server map is).

    Raises:
        ValueError: a scan without a reference pose, or no pixel reaches `min_hits`.
    """
    resolution = positive(resolution, "resolution", "metres")
    min_hits = whole_number(min_hits, "min_hits", 1)
    clouds = []
    for frame in frames:
        if frame.reference is None:
            raise ValueError(f"scan at t={frame.time} has no reference pose: cannot place it in the plan")
        pts = frame.points()
        if len(pts):
            clouds.append(transform_points(frame.reference, pts))
    if not clouds:
        raise ValueError("the scans have no returns to draw a plan from")
    xy = np.concatenate(clouds)
    lo = np.floor((xy.min(axis=0) - margin) / resolution) * resolution
    extent = xy.max(axis=0) + margin - lo
    pixels = float(np.prod(np.ceil(extent / resolution)))
    if pixels > MAX_IMAGE_PIXELS:
        finest = math.sqrt(float(np.prod(extent)) / MAX_IMAGE_PIXELS)
        raise ValueError(
            f"the scans span {extent[0]:.1f} x {extent[1]:.1f} m: a plan of {resolution:g} m pixels "
            f"would have {pixels:.3g} pixels (at most {MAX_IMAGE_PIXELS:.3g}); give a resolution of "
            f"at least {float(f'{finest:.2g}') * 1.1:.2g} m"
        )
    cols, rows = (int(v) for v in np.ceil(extent / resolution))
    c = np.minimum(np.floor((xy[:, 0] - lo[0]) / resolution).astype(np.int64), cols - 1)
    r = np.minimum(np.floor((xy[:, 1] - lo[1]) / resolution).astype(np.int64), rows - 1)
    # Hits per pixel counted over the pixels that have any, not in a full-size counter image.
    cells, hits = np.unique(r * cols + c, return_counts=True)
    flat = np.zeros(rows * cols, dtype=bool)
    flat[cells[hits >= min_hits]] = True
    walls = flat.reshape(rows, cols)
    if not walls.any():
        raise ValueError(f"no pixel of {resolution} m holds {min_hits} scan end points: no walls to draw")
    # Rows grow with +y here; images put the top row first. The wall pixels are where the surfaces
    # were seen, not solid walls: their centres are the surface points.
    raster = PlanRaster(walls[::-1], resolution, (float(lo[0]), float(lo[1]), 0.0))
    plan = PlanMap.from_raster(raster, edge_detector="centres")
    # Drawn in the scans' own metres at their reference poses, as a SLAM map is: metric by
    # construction, so its scale is not watched (its walls, bands of end points, would look like
    # one in small rooms: docs/plans.md, "The flag during tracking").
    plan.metric = True
    return plan


def synthesise_odometry(
    times: NDArray[np.float64], reference: NDArray[np.float64], drift: OdometryDrift, rng: np.random.Generator
) -> NDArray[np.float64]:
    """(N, 3) T_odom_base at the N scan times (odom frame = the first reference pose): the reference
    motion between consecutive scans split into odometry messages of `drift.message_period_s`, each
    with the error generator's constants, plus the step noise of `drift`."""
    t = np.asarray(times, dtype=np.float64)
    ref = np.asarray(reference, dtype=np.float64)
    out = np.zeros((len(t), 3))
    odom: Pose = (0.0, 0.0, 0.0)
    gen = drift.error_generator
    for k in range(1, len(t)):
        a: Pose = (float(ref[k - 1, 0]), float(ref[k - 1, 1]), float(ref[k - 1, 2]))
        b: Pose = (float(ref[k, 0]), float(ref[k, 1]), float(ref[k, 2]))
        messages = max(1, int(round((t[k] - t[k - 1]) / drift.message_period_s)))
        turn = wrap_angle(b[2] - a[2])
        step: Pose = (0.0, 0.0, 0.0)
        previous = a
        for j in range(1, messages + 1):
            f = j / messages
            here: Pose = (a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + turn * f)
            step = compose(step, gen.apply(between(previous, here)))
            previous = here
        length = math.hypot(step[0], step[1])
        sigma_t = drift.translation_noise_fraction * length
        sigma_r = drift.rotation_noise_per_rad * abs(turn) + drift.rotation_noise_per_m * length
        noise = rng.normal(0.0, 1.0, 3) * (sigma_t, sigma_t, sigma_r)
        odom = compose(odom, (step[0] + noise[0], step[1] + noise[1], step[2] + noise[2]))
        out[k] = odom
    return out


@dataclass(eq=False)
class LogEvaluation:
    """The outcome of `evaluate_log`.

    Attributes:
        plan: the plan rendered from the even-numbered scans.
        tracked: the odd-numbered scans tracked against it (with reference and odometry).
        grid: the enhanced occupancy grid of the tracked scans at planicp's poses.
        plan_scans, tracked_scans, skipped_scans: how many scans drew the plan, were tracked, and
            were left out for lack of a reference pose.
        config: the ICP settings the scans were tracked with.
    """

    plan: PlanMap
    tracked: TrackedLog
    grid: EnhancedOccupancyGrid
    plan_scans: int
    tracked_scans: int
    skipped_scans: int
    config: IcpConfig


def evaluate_log(
    frames: Sequence[ScanFrame],
    *,
    resolution: float = 0.05,
    min_hits: int = 2,
    drift: OdometryDrift | None = None,
    odometry: str = "synthetic",
    seed: int = 0,
    icp: Mapping[str, Any] | None = None,
    progress: Callable[[float], None] | None = None,
) -> LogEvaluation:
    """Runs the protocol of the module documentation on `frames` (e.g. a `ScanLog`), tracking
    with the `Localizer`'s default ICP settings for the plan drawn (`IcpConfig.for_tracking(plan)`,
    as a user who loads that plan gets them) changed by `icp` (field names and values).

    Raises:
        ValueError: fewer than 4 scans with reference poses, an unknown `odometry` source, or
            `odometry="log"` on a log without odometry; an unknown or bad `icp` setting.
    """
    if odometry not in ODOMETRY_SOURCES:
        raise ValueError(f"odometry must be one of {ODOMETRY_SOURCES}, got {odometry!r}")
    usable = [f for f in frames if f.reference is not None]
    if len(usable) < 4:
        raise ValueError(f"the log has {len(usable)} scans with reference poses; the evaluation needs at least 4")
    even, odd = usable[0::2], usable[1::2]
    plan = plan_from_scans(even, resolution, min_hits)
    times = np.array([f.time for f in odd])
    reference = np.array([f.reference for f in odd], dtype=np.float64)
    if odometry == "synthetic":
        poses = synthesise_odometry(times, reference, drift or OdometryDrift(), np.random.default_rng(seed))
        tracked_frames = [replace(f, odometry=(float(p[0]), float(p[1]), float(p[2]))) for f, p in zip(odd, poses)]
    else:
        if not any(f.odometry is not None for f in odd):
            raise ValueError("odometry='log' needs a log with odometry; this one has none")
        tracked_frames = odd
    # The grid at the plan's resolution, or as fine as fits where the log spans a campus.
    finest = finest_resolution(plan)
    if finest > resolution:
        warnings.warn(
            f"the scans span more than an occupancy grid of {resolution:g} m cells holds: the enhanced "
            f"occupancy grid is made at {finest:g} m (the plan and the tracking keep {resolution:g} m)",
            stacklevel=2,
        )
    grid = EnhancedOccupancyGrid(plan, max(resolution, finest))
    config = IcpConfig.for_tracking(plan, **dict(icp or {}))
    tracked = track_log(tracked_frames, plan, config=config, grid=grid, progress=progress)
    return LogEvaluation(plan, tracked, grid, len(even), len(odd), len(frames) - len(usable), config)
