"""Robot simulation for experiments: a differential-drive robot touring a synthetic floor, and its odometry.

Reproduces the thesis set-up: an EtaBot-class differential-drive robot with 100 Hz wheel odometry drives
through a furnished floor (:mod:`planicp.synthetic`); an error generator adds +5e-5 m and +5e-5 rad to every
odometry message, so odometry drifts while plan-based localization does not.

* :mod:`.diff_drive` -- :class:`DiffDriveLimits`, :class:`DiffDriveState`, exact arc integration :func:`step`;
* :mod:`.route_planner` -- clearance-inflated A* routes (:func:`plan_route`) and random tours (:func:`tour`);
* :mod:`.waypoint_follower` -- the pure-pursuit :class:`WaypointFollower`;
* :mod:`.odometry` -- :class:`Odometry` with :class:`OdometryNoise` and the thesis' :class:`ErrorGenerator`;
* :mod:`.drive` -- :func:`simulate_drive` returning a ground-truth :class:`Trajectory`.

Frames and units follow REP-103/105: metres, seconds, radians; x forward, y left, yaw counter-clockwise;
truth poses are T_map_base, odometry poses T_odom_base with the odom frame at the robot's start pose.
"""

from __future__ import annotations

from .diff_drive import DiffDriveLimits, DiffDriveState, arc_increment, step
from .drive import Trajectory, simulate_drive
from .odometry import ErrorGenerator, Odometry, OdometryNoise
from .route_planner import clearance_distance, plan_route, reachable, tour, traversable
from .waypoint_follower import WaypointFollower

__all__ = [
    "DiffDriveLimits",
    "DiffDriveState",
    "ErrorGenerator",
    "Odometry",
    "OdometryNoise",
    "Trajectory",
    "WaypointFollower",
    "arc_increment",
    "clearance_distance",
    "plan_route",
    "reachable",
    "simulate_drive",
    "step",
    "tour",
    "traversable",
]
