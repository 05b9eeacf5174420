"""A synthetic CARMEN log in the real line formats, with known geometry, for the reader tests.

A robot drives through a 10 m x 6 m rectangular room (walls x = 0, x = 10, y = 0, y = 6) while its
front laser, mounted `MOUNT` in the base frame, scans 180 beams 1 degree apart from -90 degrees.
Ranges are exact ray-to-wall distances written with 4 decimals; every 17th beam reports 81.91 m (the
SICK "no return" value). FLASER lines carry the laser's true pose (a corrected log) and the drifting
odometry; ODOM lines run at five times the scan rate. NEFF lines (an unknown type) follow each scan.
"""

from __future__ import annotations

import math

import numpy as np

ROOM = (0.0, 10.0, 0.0, 6.0)
MOUNT = (0.25, 0.05, 0.0)
BEAMS = 180
NO_RETURN_EVERY = 17
SCANS = 40
ODOM_PER_SCAN = 5
SCAN_DT = 0.2


def wall_distance(x: float, y: float, angle: float) -> float:
    """Distance from (x, y) inside the room to its wall along `angle`."""
    dx, dy = math.cos(angle), math.sin(angle)
    xmin, xmax, ymin, ymax = ROOM
    hits = []
    if dx > 1e-12:
        hits.append((xmax - x) / dx)
    if dx < -1e-12:
        hits.append((xmin - x) / dx)
    if dy > 1e-12:
        hits.append((ymax - y) / dy)
    if dy < -1e-12:
        hits.append((ymin - y) / dy)
    return min(hits)


def distance_to_walls(points: np.ndarray) -> np.ndarray:
    """(N,) distance of map-frame points to the nearest wall line of the room."""
    xmin, xmax, ymin, ymax = ROOM
    return np.min(
        np.abs(np.stack([points[:, 0] - xmin, points[:, 0] - xmax, points[:, 1] - ymin, points[:, 1] - ymax])), axis=0
    )


def true_pose(t: float) -> tuple[float, float, float]:
    """T_map_base of the robot at time t (a slow arc through the room)."""
    return (2.0 + 0.5 * t, 2.0 + 0.25 * t, 0.3 + 0.1 * t)


def odom_pose(t: float) -> tuple[float, float, float]:
    """T_odom_base: the true motion with a growing drift (odom frame = map frame at t = 0)."""
    x, y, yaw = true_pose(t)
    return (x - 2.0 + 0.01 * t, y - 2.0 - 0.02 * t, yaw + 0.005 * t)


def laser_world(t: float) -> tuple[float, float, float]:
    x, y, yaw = true_pose(t)
    mx, my, myaw = MOUNT
    c, s = math.cos(yaw), math.sin(yaw)
    return (x + c * mx - s * my, y + s * mx + c * my, yaw + myaw)


def flaser_line(t: float) -> str:
    lx, ly, lyaw = laser_world(t)
    ranges = []
    for i in range(BEAMS):
        if i % NO_RETURN_EVERY == 0:
            ranges.append("81.91")
        else:
            ranges.append(f"{wall_distance(lx, ly, lyaw - math.pi / 2 + i * math.pi / 180):.4f}")
    ox, oy, oyaw = odom_pose(t)
    return (
        f"FLASER {BEAMS} {' '.join(ranges)} {lx:.6f} {ly:.6f} {lyaw:.6f} {ox:.6f} {oy:.6f} {oyaw:.6f} "
        f"{t:.6f} nohost {t:.6f}"
    )


def odom_line(t: float) -> str:
    x, y, yaw = odom_pose(t)
    return f"ODOM {x:.6f} {y:.6f} {yaw:.6f} 0.5 0.1 0 {t:.6f} nohost {t:.6f}"


def log_lines() -> list[str]:
    """The whole log, one string per line (about 250 lines)."""
    lines = [
        "# message formats defined: PARAM SYNC ODOM FLASER RLASER TRUEPOS",
        "# PARAM param_name param_value",
        f"PARAM robot_frontlaser_offset {MOUNT[0]} nohost 0",
        f"PARAM robot_frontlaser_side_offset {MOUNT[1]} nohost 0",
        "PARAM robot_rearlaser_offset 0.0 nohost 0",
    ]
    for k in range(SCANS):
        t0 = 1.0 + k * SCAN_DT
        for j in range(ODOM_PER_SCAN):
            lines.append(odom_line(t0 + j * SCAN_DT / ODOM_PER_SCAN - 0.02))
        lines.append(flaser_line(t0))
        lines.append(f"NEFF {15 - 0.1 * k:.4f}")
    lines.append(odom_line(1.0 + SCANS * SCAN_DT))
    return lines
