"""An occupancy grid laid out as the ROS message `nav_msgs/OccupancyGrid` (without ROS)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose


@dataclass(frozen=True)
class OccupancyGridMessage:
    """An occupancy grid laid out as `nav_msgs/OccupancyGrid`.

    Attributes:
        data: (height, width) int8, row 0 at the origin (lowest y): -1 unknown, 0 free, 100
            occupied (trinary, as map_saver writes and nav2's static layer reads). Flatten it
            row-major (`data.ravel()`) for the message's `data` field.
        resolution: metres per cell (`info.resolution`).
        origin: (x, y, yaw) of the lower-left corner of cell (0, 0) in the map frame
            (`info.origin`; yaw is always 0 here).
    """

    data: NDArray[np.int8]
    resolution: float
    origin: Pose

    @property
    def width(self) -> int:
        """Cells along x (`info.width`)."""
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        """Cells along y (`info.height`)."""
        return int(self.data.shape[0])
