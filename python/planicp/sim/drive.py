"""Ground-truth drives: a differential-drive robot touring a synthetic floor under closed-loop control.

Map frame of the floor, metres, seconds, radians (REP-103).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import positive, real_number
from .diff_drive import DiffDriveLimits, DiffDriveState, step
from .floor import Floor
from .route_planner import reachable, tour
from .waypoint_follower import WaypointFollower

__all__ = ["Trajectory", "simulate_drive"]

_LEGS_PER_TOUR = 3
_MIN_LEG_LENGTH = 5.0  # metres: long legs take the robot through doorways into other rooms
_START_CANDIDATES = 8  # start positions tried; the one with the largest reachable area wins


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A sampled ground-truth trajectory.

    Attributes:
        times: ``(N,)`` float64 seconds from the start, strictly increasing (``k / control_rate_hz``).
        poses: ``(N, 3)`` float64 ``(x, y, yaw)`` of the robot base in the map frame (metres, radians in
            ``(-pi, pi]``).
        velocities: ``(N, 2)`` float64 ``(v, w)`` (m/s, rad/s) the robot had when it reached each pose (the
            velocities applied during the step that ended there; zeros at the start).
        waypoints: ``(M, 2)`` float64 map-frame waypoints of all tours that were driven (metres).

    The arrays are copied and read-only.
    """

    times: NDArray[np.float64]
    poses: NDArray[np.float64]
    velocities: NDArray[np.float64]
    waypoints: NDArray[np.float64]

    def __post_init__(self) -> None:
        times = np.array(self.times, dtype=np.float64)
        poses = np.array(self.poses, dtype=np.float64)
        velocities = np.array(self.velocities, dtype=np.float64)
        waypoints = np.array(self.waypoints, dtype=np.float64).reshape(-1, 2)
        n = times.shape[0] if times.ndim == 1 else -1
        if n < 1 or poses.shape != (n, 3) or velocities.shape != (n, 2):
            raise ValueError(
                f"times must be (N,), poses (N, 3) and velocities (N, 2) with N >= 1, got {times.shape}, "
                f"{poses.shape} and {velocities.shape}"
            )
        if (np.diff(times) <= 0.0).any():
            raise ValueError("times must be strictly increasing")
        for name, arr in (("times", times), ("poses", poses), ("velocities", velocities), ("waypoints", waypoints)):
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.times.shape[0])

    @property
    def duration(self) -> float:
        """Seconds from the first to the last sample."""
        return float(self.times[-1] - self.times[0])

    @property
    def path_length(self) -> float:
        """Metres driven (sum of the straight distances between successive samples)."""
        return float(np.hypot(*np.diff(self.poses[:, :2], axis=0).T).sum())


def simulate_drive(
    floor: Floor,
    rng: np.random.Generator,
    duration_s: float,
    limits: DiffDriveLimits | None = None,
    control_rate_hz: float = 100.0,
    clearance: float = 0.45,
) -> Trajectory:
    """Drive the robot around ``floor`` for ``duration_s`` seconds and return its ground-truth trajectory.

    The start position is drawn with ``floor.sample_pose(rng, clearance)`` (uniform yaw); of
    8 candidates the one whose reachable free space (`reachable`) is
    largest is used, so the robot does not start in a room whose doors are too narrow for the clearance.
    The robot then follows tours of 3 random legs of at least 5 m (`tour`)
    with a `WaypointFollower`, integrating
    `step` at ``control_rate_hz``; when a tour is done a new one starts from
    its last goal, until the duration is reached. The robot starts at rest.

    The routes keep ``clearance`` from walls and clutter; the follower stays close to them (no corner
    cutting), so with the default 0.15 m margin between ``clearance`` and ``limits.radius`` the footprint
    never overlaps a wall or furniture cell.

    Args:
        floor: the floor (walls and clutter are obstacles).
        rng: seeded generator (start, goals).
        duration_s: seconds, > 0.
        limits: the robot (None: ``DiffDriveLimits()``).
        control_rate_hz: control and sampling rate in Hz, > 0.
        clearance: route clearance in metres, >= ``limits.radius``.

    Returns:
        A `Trajectory` with samples at ``k / control_rate_hz`` for
        ``k = 0 .. floor(duration_s * control_rate_hz)``.

    Raises:
        ValueError: non-positive ``duration_s`` or ``control_rate_hz``, ``clearance`` below the robot radius,
            or no free position with the clearance on the floor.
    """
    if not isinstance(floor, Floor):
        raise TypeError(f"floor must be a planicp.sim.Floor, got {type(floor).__name__}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    duration_s = positive(duration_s, "duration_s", "seconds")
    control_rate_hz = positive(control_rate_hz, "control_rate_hz", "Hz")
    if limits is None:
        limits = DiffDriveLimits()
    if not isinstance(limits, DiffDriveLimits):
        raise TypeError(f"limits must be a DiffDriveLimits, got {type(limits).__name__}")
    clearance = real_number(clearance, "clearance")
    if not (math.isfinite(clearance) and clearance >= limits.radius):
        raise ValueError(f"clearance must be a finite number >= limits.radius ({limits.radius} m), got {clearance!r}")

    x0, y0, yaw0 = _pick_start(floor, rng, clearance)
    steps = math.floor(duration_s * control_rate_hz + 1e-9)
    dt = 1.0 / control_rate_hz
    poses = np.empty((steps + 1, 3), dtype=np.float64)
    velocities = np.zeros((steps + 1, 2), dtype=np.float64)
    state = DiffDriveState(x0, y0, yaw0, 0.0, 0.0)
    route = tour(floor, rng, _LEGS_PER_TOUR, clearance, _MIN_LEG_LENGTH, start_xy=(x0, y0))
    all_waypoints = list(route)
    follower = WaypointFollower(route, limits)
    for k in range(steps + 1):
        poses[k] = state.pose
        velocities[k] = state.v, state.w
        if k == steps:
            break
        if follower.done:
            route = tour(floor, rng, _LEGS_PER_TOUR, clearance, _MIN_LEG_LENGTH, start_xy=route[-1])
            all_waypoints.extend(route[1:])
            follower = WaypointFollower(route, limits)
        v, w = follower.command(state)
        state = step(state, v, w, dt, limits)
    times = np.arange(steps + 1, dtype=np.float64) / control_rate_hz
    return Trajectory(times=times, poses=poses, velocities=velocities, waypoints=np.array(all_waypoints))


def _pick_start(floor: Floor, rng: np.random.Generator, clearance: float) -> tuple[float, float, float]:
    """Of a few poses from ``floor.sample_pose``, the first one in the largest reachable region."""
    best: tuple[float, float, float] | None = None
    best_area = -1
    regions: list[Any] = []
    for _ in range(_START_CANDIDATES):
        pose = floor.sample_pose(rng, clearance)
        cell = (
            int(math.floor((pose[1] - floor.origin[1]) / floor.resolution)),
            int(math.floor((pose[0] - floor.origin[0]) / floor.resolution)),
        )
        region = next((r for r in regions if r[cell]), None)
        if region is None:
            region = reachable(floor, pose[:2], clearance)
            regions.append(region)
        area = int(region.sum())
        if area > best_area:
            best, best_area = pose, area
    assert best is not None
    return best
