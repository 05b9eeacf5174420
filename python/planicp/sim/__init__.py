"""Simulation: synthetic floors, a simulated LIDAR, and a robot driving through a furnished plan.

Reproduces the thesis set-up: an EtaBot-class differential-drive robot with 100 Hz wheel odometry drives
through a furnished floor; an error generator adds +5e-5 m and +5e-5 rad to every odometry message, so
odometry drifts while plan-based localization does not. Which file holds what:

* `floor` -- `Floor`, a raster of walls (the plan) and clutter (what the plan does not show);
* `floor_generation` -- `generate_floor`: seeded furnished floors in the `LAYOUTS`
  ``"office"``, ``"hall"`` and ``"diagonal"``, drawn on the rasteriser of `floor_canvas`;
* `simulated_lidar` -- `simulate_ranges` / `simulate_scan`: LaserScan ranges in a floor
  (the native ray caster, ``planicp._core.OccupancyGrid``) and `ranges_to_points`;
* `pose_perturbation` -- `perturb_pose`, a guess a given distance and angle off;
* `world` -- `World`: a plan raster (or a drawing's wall points rasterised) furnished with seeded
  furniture and walking people;
* `building_outline` -- where the building is on a plan raster: an open outline closed with a
  warning, or refused;
* `crowd` -- people standing around the robot, placed anew for every scan;
* `diff_drive` -- `DiffDriveLimits`, `DiffDriveState`, exact arc integration `step`;
* `route_planner` -- clearance-inflated A* routes (`plan_route`) and random tours (`tour`);
* `waypoint_follower` -- the pure-pursuit `WaypointFollower`;
* `odometry` -- `Odometry` with `OdometryNoise` and the thesis' `ErrorGenerator`;
* `drive` -- `simulate_drive` returning a ground-truth `Trajectory`;
* `experiment` -- `run_experiment`: the drive, its scans and odometry fed to a ``Localizer``;
  `replay` runs the recorded scans through other settings.

``planicp.synthetic`` is this package under the name the floors and the LIDAR had before they moved here.

Frames and units follow REP-103/105: metres, seconds, radians; x forward, y left, yaw counter-clockwise;
truth poses are T_map_base, odometry poses T_odom_base with the odom frame at the robot's start pose.
"""

from __future__ import annotations

from .diff_drive import DiffDriveLimits, DiffDriveState, arc_increment, step
from .drive import Trajectory, simulate_drive
from .floor import Floor
from .floor_generation import LAYOUTS, generate_floor
from .odometry import ErrorGenerator, Odometry, OdometryNoise
from .pose_perturbation import perturb_pose
from .route_planner import clearance_distance, plan_route, reachable, tour, traversable
from .simulated_lidar import ranges_to_points, simulate_ranges, simulate_scan
from .waypoint_follower import WaypointFollower

__all__ = [
    "LAYOUTS",
    "DiffDriveLimits",
    "DiffDriveState",
    "ErrorGenerator",
    "Floor",
    "Odometry",
    "OdometryNoise",
    "Trajectory",
    "WaypointFollower",
    "arc_increment",
    "clearance_distance",
    "generate_floor",
    "perturb_pose",
    "plan_route",
    "ranges_to_points",
    "reachable",
    "simulate_drive",
    "simulate_ranges",
    "simulate_scan",
    "step",
    "tour",
    "traversable",
]
