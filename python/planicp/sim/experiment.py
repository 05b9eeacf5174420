"""The thesis experiment: a robot drives through a furnished floor; odometry drifts; planicp does not.

A differential-drive robot tours the plan's building (100 Hz control), its wheel odometry runs at
100 Hz with Gaussian noise plus the thesis's error generator (+5e-5 m and +5e-5 rad on every
message), and a LIDAR at 10 Hz scans walls, furniture and walking people (none but the walls are in
the plan). Every scan and the odometry pose at its time go to a `Localizer`, exactly as a robot
stack would feed it. Ground truth, odometry (expressed in the map through the known start pose),
estimates and their quality are recorded.

Frames (REP-105): truth and estimates are T_map_base; odometry is T_odom_base with the odom frame at
the start pose, so the odometry's map pose is start * T_odom_base. Metres, radians, seconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import Pose, as_pose, positive, whole_number
from ..io.scan_log import ScanFrame
from ..laser_scan import scan_to_points
from ..mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid
from ..plans.plan_map import PlanMap
from ..plans.plan_raster import PlanRaster
from ..se2 import compose, wrap_angle
from ..tracking.acceptance_gate import AcceptanceGate
from ..tracking.icp_config import IcpConfig
from ..tracking.localizer import Localizer
from .diff_drive import DiffDriveLimits
from .drive import simulate_drive
from .odometry import ErrorGenerator, Odometry, OdometryNoise
from .world import GIVE_WAY_HORIZON, Furnishing, World


@dataclass(frozen=True)
class LidarModel:
    """A 2D LIDAR (default: a 270-degree, 1081-beam, 30 m scanner with 1 cm noise, like a Hokuyo UTM-30LX).

    Attributes:
        fov: field of view, radians, centred on the laser's x axis.
        beams: number of beams (>= 2).
        range_min, range_max: valid range, metres.
        range_sigma: Gaussian range noise, metres.
        dropout: probability that a beam returns nothing.
        rate_hz: scans per second.
        mount: (x, y, yaw) of the laser in the robot (base) frame.
    """

    fov: float = math.radians(270.0)
    beams: int = 1081
    range_min: float = 0.05
    range_max: float = 30.0
    range_sigma: float = 0.01
    dropout: float = 0.0
    rate_hz: float = 10.0
    mount: Pose = (0.15, 0.0, 0.0)

    def __post_init__(self) -> None:
        fov = positive(self.fov, "fov", "radians")
        if fov > 2 * math.pi:
            raise ValueError(f"fov must be at most 2 pi radians, got {fov}")
        whole_number(self.beams, "beams", 2, 1 << 20)
        positive(self.range_max, "range_max", "metres")
        if not 0.0 <= self.range_min < self.range_max:
            raise ValueError(f"need 0 <= range_min < range_max, got {self.range_min}, {self.range_max}")
        if not (math.isfinite(self.range_sigma) and self.range_sigma >= 0.0):
            raise ValueError(f"range_sigma must be >= 0 metres, got {self.range_sigma}")
        if not 0.0 <= self.dropout <= 1.0:
            raise ValueError(f"dropout must be in [0, 1], got {self.dropout}")
        positive(self.rate_hz, "rate_hz", "Hz")
        object.__setattr__(self, "mount", as_pose(self.mount, "mount"))

    @property
    def angle_min(self) -> float:
        """Angle of the first beam, radians."""
        return -self.fov / 2.0

    @property
    def angle_increment(self) -> float:
        """Angle between beams, radians (a full circle does not repeat its first beam)."""
        return self.fov / self.beams if math.isclose(self.fov, 2 * math.pi) else self.fov / (self.beams - 1)


@dataclass(frozen=True)
class ExperimentConfig:
    """Everything one run depends on; the same config and seed give the same run."""

    duration_s: float = 300.0
    seed: int = 0
    lidar: LidarModel = field(default_factory=LidarModel)
    furnishing: Furnishing = field(default_factory=Furnishing)
    odometry_rate_hz: float = 100.0
    odometry_noise: OdometryNoise = field(default_factory=OdometryNoise)
    error_generator: ErrorGenerator | None = field(default_factory=ErrorGenerator)
    limits: DiffDriveLimits = field(default_factory=DiffDriveLimits)
    icp: IcpConfig = field(default_factory=IcpConfig.for_tracking)
    gate: AcceptanceGate = field(default_factory=AcceptanceGate)

    def __post_init__(self) -> None:
        positive(self.duration_s, "duration_s", "seconds")
        whole_number(self.seed, "seed", 0, 2**63 - 1)
        positive(self.odometry_rate_hz, "odometry_rate_hz", "Hz")
        if self.odometry_rate_hz < self.lidar.rate_hz:
            raise ValueError(
                f"odometry_rate_hz ({self.odometry_rate_hz}) must be at least the LIDAR rate ({self.lidar.rate_hz})"
            )


@dataclass
class Recording:
    """What a run produced, one row per scan.

    Attributes:
        times: (K,) seconds.
        truth, odometry, estimate: (K, 3) map-frame poses (x, y, yaw) of the base.
        accepted: (K,) whether the Localizer accepted the ICP result.
        inlier_ratio, rmse: (K,) quality of the ICP result (NaN where there was none).
        scans: the K scans (robot frame, metres), kept for re-runs and figures.
        odometry_in_odom: (K, 3) T_odom_base fed to the Localizer.
        ranges: the K scans as the LIDAR measured them (REP-117 ranges of `lidar`), or None.
        lidar: the LIDAR model that measured them, or None.
        odometry_stream_times: (M,) seconds of every odometry message (the odometry rate, not only
            the scan times), or None.
        odometry_stream: (M, 3) T_odom_base of every odometry message, or None: what a robot
            publishes on its odometry topic, e.g. to replay the drive to a ROS node.
        lost: (K,) whether the Localizer was lost after each scan (`Estimate.lost`), or None.
        person_gap: (K,) metres between the robot's footprint and the nearest walking person's
            disc at each scan (negative: they overlap; inf: no people), or None.
    """

    times: NDArray[np.float64]
    truth: NDArray[np.float64]
    odometry: NDArray[np.float64]
    estimate: NDArray[np.float64]
    accepted: NDArray[np.bool_]
    inlier_ratio: NDArray[np.float64]
    rmse: NDArray[np.float64]
    scans: list[NDArray[np.float64]]
    odometry_in_odom: NDArray[np.float64]
    ranges: list[NDArray[np.float64]] | None = None
    lidar: LidarModel | None = None
    odometry_stream_times: NDArray[np.float64] | None = None
    odometry_stream: NDArray[np.float64] | None = None
    lost: NDArray[np.bool_] | None = None
    person_gap: NDArray[np.float64] | None = None

    def errors(self, which: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(position error m, heading error rad) over time of "odometry" or "estimate"."""
        if which not in ("odometry", "estimate"):
            raise ValueError(f"which must be 'odometry' or 'estimate', got {which!r}")
        poses = self.poses(which)
        d = poses[:, :2] - self.truth[:, :2]
        dyaw = np.array([wrap_angle(a) for a in poses[:, 2] - self.truth[:, 2]])
        return np.hypot(d[:, 0], d[:, 1]), dyaw

    def scan_frames(self) -> list[ScanFrame]:
        """The scans as a robot would have logged them (`planicp.io.ScanFrame`: ranges, the LIDAR's
        beam geometry and mount, odometry T_odom_base and the ground truth as reference), e.g. to
        write a bag with `planicp.io.bag.write_bag`.

        Raises:
            ValueError: the recording kept no ranges (it was not made by `run_experiment`).
        """
        if self.ranges is None or self.lidar is None:
            raise ValueError("this recording has no ranges and LIDAR model (record it with run_experiment)")
        lidar = self.lidar
        return [
            ScanFrame(
                float(t),
                r,
                lidar.angle_min,
                lidar.angle_increment,
                lidar.range_min,
                lidar.range_max,
                lidar.mount,
                _pose(odom),
                _pose(truth),
            )
            for t, r, odom, truth in zip(self.times, self.ranges, self.odometry_in_odom, self.truth)
        ]

    def poses(self, which: str) -> NDArray[np.float64]:
        """(K, 3) map-frame poses of "truth", "odometry" or "estimate"."""
        table = {"truth": self.truth, "odometry": self.odometry, "estimate": self.estimate}
        if which not in table:
            raise ValueError(f"which must be one of {sorted(table)}, got {which!r}")
        return table[which]

    def occupancy_grid(
        self, plan: PlanMap, which: str, sensor_offset: Pose, resolution: float = 0.05, **options: Any
    ) -> EnhancedOccupancyGrid:
        """The enhanced occupancy grid of every scan placed at the poses of `which` ("truth",
        "odometry" or "estimate"); `sensor_offset` is the laser's mount in the base frame (the
        LIDAR model's `mount`), `options` go to `EnhancedOccupancyGrid`."""
        poses = self.poses(which)
        grid = EnhancedOccupancyGrid(plan, resolution, **options)
        for scan, pose in zip(self.scans, poses):
            grid.integrate(scan, pose, sensor_offset)
        return grid

    def metrics(self) -> dict[str, float]:
        """RMS, maximum and final errors of odometry and planicp (metres, degrees), acceptance
        statistics and, when the recording has them, the scans after which the Localizer was lost
        (`lost_scans`) and whether it was lost after the last one (`lost_at_end`, 0 or 1), and the
        closest a walking person came to the robot's footprint (`closest_person_m`, metres)."""
        out: dict[str, float] = {}
        for label, which in (("odometry", "odometry"), ("planicp", "estimate")):
            pos, yaw = self.errors(which)
            out[f"{label}_position_rms_m"] = float(np.sqrt(np.mean(pos**2)))
            out[f"{label}_position_max_m"] = float(pos.max())
            out[f"{label}_position_final_m"] = float(pos[-1])
            out[f"{label}_heading_rms_deg"] = math.degrees(float(np.sqrt(np.mean(yaw**2))))
            out[f"{label}_heading_max_deg"] = math.degrees(float(np.abs(yaw).max()))
            out[f"{label}_heading_final_deg"] = math.degrees(abs(float(yaw[-1])))
        out["scans"] = float(len(self.times))
        out["accepted_share"] = float(self.accepted.mean())
        steps = np.hypot(*np.diff(self.estimate[:, :2], axis=0).T) if len(self.times) > 1 else np.zeros(1)
        true_steps = np.hypot(*np.diff(self.truth[:, :2], axis=0).T) if len(self.times) > 1 else np.zeros(1)
        out["largest_estimate_jump_beyond_truth_m"] = float(np.max(steps - true_steps)) if len(steps) else 0.0
        if self.person_gap is not None and len(self.person_gap):
            out["closest_person_m"] = float(self.person_gap.min())
        if self.lost is not None:
            out["lost_scans"] = float(self.lost.sum())
            out["lost_at_end"] = float(bool(self.lost[-1])) if len(self.lost) else 0.0
        return out


def _pose(row: NDArray[np.float64]) -> Pose:
    return (float(row[0]), float(row[1]), float(row[2]))


def replay(
    plan: PlanMap, recording: Recording, icp: IcpConfig, gate: AcceptanceGate | None = None, **options: Any
) -> Recording:
    """The same scans and odometry through a Localizer with other settings (for ablations);
    `options` go to the `Localizer` (e.g. `occlusion=False`)."""
    localizer = Localizer(plan, tuple(recording.truth[0]), icp, gate=gate, **options)
    estimate, accepted, ratio, rmse, lost = _track(localizer, recording.scans, recording.odometry_in_odom)
    return Recording(
        recording.times,
        recording.truth,
        recording.odometry,
        estimate,
        accepted,
        ratio,
        rmse,
        recording.scans,
        recording.odometry_in_odom,
        recording.ranges,
        recording.lidar,
        recording.odometry_stream_times,
        recording.odometry_stream,
        lost,
    )


def _track(
    localizer: Localizer, scans: list[NDArray[np.float64]], odometry: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    estimate = np.zeros((len(scans), 3))
    accepted = np.zeros(len(scans), dtype=bool)
    lost = np.zeros(len(scans), dtype=bool)
    ratio = np.full(len(scans), np.nan)
    rmse = np.full(len(scans), np.nan)
    for k, (scan, odom) in enumerate(zip(scans, odometry)):
        est = localizer.update(scan, tuple(odom))
        estimate[k] = est.pose
        accepted[k] = est.accepted
        lost[k] = est.lost
        if est.result is not None:
            ratio[k] = est.result.inlier_ratio
            rmse[k] = est.result.rmse
    return estimate, accepted, ratio, rmse, lost


def run_experiment(
    plan: PlanMap,
    config: ExperimentConfig | None = None,
    progress: Callable[[float], None] | None = None,
    *,
    building: PlanRaster | None = None,
) -> tuple[Recording, World]:
    """Runs the drift experiment on `plan`: an image or ROS map, or a drawing whose wall points are
    rasterised for the simulated building (`World.from_plan`); an open outline is closed first
    (`World.from_raster`, with an `OpenOutlineWarning`).

    `progress`, when given, is called with the simulated time (seconds) after every scan.
    `building`: the walls the robot drives and scans in, in the plan's map frame, when they are
    not the plan's own (a plan extracted from a drawing, tracked in the building's true walls);
    default: the plan's raster, or its wall points rasterised.
    Returns the recording and the furnished world it ran in.
    """
    config = config or ExperimentConfig()
    rng = np.random.default_rng(config.seed)
    if building is not None:
        world = World.from_raster(building, rng, config.furnishing)
    else:
        world = World.from_plan(plan, rng, config.furnishing)
    clearance = config.limits.radius + 0.15
    trajectory = simulate_drive(
        world.floor, rng, config.duration_s, config.limits, control_rate_hz=config.odometry_rate_hz, clearance=clearance
    )
    odometry = Odometry(config.odometry_rate_hz, config.odometry_noise, config.error_generator, rng)
    grid = _core.OccupancyGrid(np.ascontiguousarray(world.floor.occupied()), world.floor.resolution, world.floor.origin)
    lidar = config.lidar
    every = max(1, int(round(config.odometry_rate_hz / lidar.rate_hz)))
    start: Pose = tuple(float(v) for v in trajectory.poses[0])  # type: ignore[assignment]
    world.clear_start((start[0], start[1]), rng, config.limits.radius)
    ahead = int(round(GIVE_WAY_HORIZON * config.odometry_rate_hz))
    localizer = Localizer(plan, start, config.icp, gate=config.gate)
    times, truth, odom_map, odom_odom, scans, measured = [], [], [], [], [], []
    estimate, accepted, ratio, rmse, lost, person_gap = [], [], [], [], [], []
    stream = np.zeros((len(trajectory.times), 3))
    for k, (t, pose) in enumerate(zip(trajectory.times, trajectory.poses)):
        odom_pose = odometry.update(pose)
        stream[k] = odom_pose
        if k % every:
            continue
        true_pose: Pose = (float(pose[0]), float(pose[1]), float(pose[2]))
        world.advance(
            1.0 / lidar.rate_hz,
            rng,
            keep_clear=(true_pose[0], true_pose[1]),
            robot_radius=config.limits.radius,
            robot_ahead=trajectory.poses[k + 1 : k + 1 + ahead : every, :2],
        )
        discs = world.discs()
        gap = np.hypot(discs[:, 0] - true_pose[0], discs[:, 1] - true_pose[1]) - discs[:, 2] - config.limits.radius
        person_gap.append(float(gap.min()) if len(gap) else math.inf)
        sensor = compose(true_pose, lidar.mount)
        ranges = grid.cast(
            sensor,
            lidar.angle_min,
            lidar.angle_increment,
            lidar.beams,
            lidar.range_min,
            lidar.range_max,
            lidar.range_sigma,
            lidar.dropout,
            int(rng.integers(2**63)),
            discs,
        )
        scan = scan_to_points(
            ranges, lidar.angle_min, lidar.angle_increment, lidar.range_min, lidar.range_max, sensor_pose=lidar.mount
        )
        est = localizer.update(scan, odom_pose)
        times.append(float(t))
        truth.append(true_pose)
        odom_odom.append(odom_pose)
        odom_map.append(compose(start, odom_pose))
        scans.append(scan)
        measured.append(ranges)
        estimate.append(est.pose)
        accepted.append(est.accepted)
        lost.append(est.lost)
        ratio.append(est.result.inlier_ratio if est.result is not None else math.nan)
        rmse.append(est.result.rmse if est.result is not None else math.nan)
        if progress is not None:
            progress(float(t))
    recording = Recording(
        np.array(times),
        np.array(truth),
        np.array(odom_map),
        np.array(estimate),
        np.array(accepted),
        np.array(ratio),
        np.array(rmse),
        scans,
        np.array(odom_odom),
        measured,
        lidar,
        np.array(trajectory.times, dtype=np.float64),
        stream,
        np.array(lost, dtype=bool),
        np.array(person_gap, dtype=np.float64),
    )
    return recording, world
