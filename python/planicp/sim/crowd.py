"""People crowding the sensor: the scans of a recorded drive again, with a crowd around the robot.

`Crowd` stands people (discs) at random free places around the robot's true pose, placed anew for
every scan (they move between scans faster than any tracker could follow them), and
`crowded_scans` casts the drive's scans through them. It is the scene of `benches/crowd.py` and of
the crowd test: with 25 people 0.7-3 m around the robot, about half of the returns hit people.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import positive, whole_number
from ..laser_scan import scan_to_points
from ..se2 import compose
from .experiment import LidarModel, Recording
from .floor import Floor


@dataclass(frozen=True)
class Crowd:
    """How many people stand around the robot, and where.

    Attributes:
        people: discs per scan (>= 0).
        min_distance, max_distance: metres from the robot's centre to a person's centre.
        min_radius, max_radius: a person's radius, metres.
    """

    people: int
    min_distance: float = 0.7
    max_distance: float = 3.0
    min_radius: float = 0.18
    max_radius: float = 0.25

    def __post_init__(self) -> None:
        whole_number(self.people, "people", 0, 100_000)
        positive(self.min_distance, "min_distance", "metres")
        positive(self.min_radius, "min_radius", "metres")
        if not self.min_distance <= self.max_distance:
            raise ValueError(f"need min_distance <= max_distance, got {self.min_distance}, {self.max_distance}")
        if not self.min_radius <= self.max_radius:
            raise ValueError(f"need min_radius <= max_radius, got {self.min_radius}, {self.max_radius}")

    def place(self, rng: np.random.Generator, position: tuple[float, float], floor: Floor) -> NDArray[np.float64]:
        """(people, 3) discs (x, y, radius) in the map frame, metres: centres at uniform distances
        and bearings around `position`, on free cells of `floor`."""
        free = ~floor.occupied()
        (ox, oy), res = floor.origin, floor.resolution
        discs = np.zeros((self.people, 3))
        placed = attempts = 0
        while placed < self.people:
            attempts += 1
            if attempts > 1000 * (self.people + 1):
                raise ValueError(f"found free places for only {placed} of {self.people} people around {position}")
            r, a = rng.uniform(self.min_distance, self.max_distance), rng.uniform(-math.pi, math.pi)
            x, y = position[0] + r * math.cos(a), position[1] + r * math.sin(a)
            col, row = int((x - ox) / res), int((y - oy) / res)
            if 0 <= row < free.shape[0] and 0 <= col < free.shape[1] and free[row, col]:
                discs[placed] = (x, y, rng.uniform(self.min_radius, self.max_radius))
                placed += 1
        return discs


def crowded_scans(
    recording: Recording, floor: Floor, lidar: LidarModel, crowd: Crowd, seed: int = 0
) -> tuple[list[NDArray[np.float64]], NDArray[np.float64]]:
    """The scans of `recording` cast again from its true poses through `floor` (the world's walls
    and clutter) with `crowd` around the robot, seeded by `seed`. Returns the scans (base-frame
    points, metres, as `Recording.scans`) and, per scan, the share of beams a person blocked."""
    grid = _core.OccupancyGrid(np.ascontiguousarray(floor.occupied()), floor.resolution, floor.origin)
    rng = np.random.default_rng(seed)
    scans: list[NDArray[np.float64]] = []
    blocked = np.zeros(len(recording.truth))
    for k, truth in enumerate(recording.truth):
        sensor = compose((float(truth[0]), float(truth[1]), float(truth[2])), lidar.mount)
        args = (sensor, lidar.angle_min, lidar.angle_increment, lidar.beams, lidar.range_min, lidar.range_max)
        noise_seed = int(rng.integers(2**63))
        clear = grid.cast(*args, lidar.range_sigma, 0.0, noise_seed)
        discs = crowd.place(rng, (float(truth[0]), float(truth[1])), floor) if crowd.people else None
        ranges = grid.cast(*args, lidar.range_sigma, 0.0, noise_seed, discs)
        blocked[k] = np.mean(ranges < clear - 0.05)
        scans.append(
            scan_to_points(
                ranges,
                lidar.angle_min,
                lidar.angle_increment,
                lidar.range_min,
                lidar.range_max,
                sensor_pose=lidar.mount,
            )
        )
    return scans, blocked
