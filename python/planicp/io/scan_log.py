"""The common form every log reader returns: time-stamped scans with odometry and reference poses.

Frames (REP-105): `odometry` is T_odom_base, the robot's odometry pose at the scan's time;
`reference` is T_map_base, a corrected or ground-truth pose when the log carries one; `laser_pose`
is T_base_laser, the laser's mounting pose in the robot (base) frame. Poses are (x, y, yaw) in
metres and radians, yaw counter-clockwise; times are seconds.

Ranges follow REP-117: +inf means "no return" (nothing within range), -inf "too close", NaN an
erroneous reading. `ScanFrame.points` drops all of them.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import overload

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose, as_pose
from ..laser_scan import scan_to_points
from .log_times import TimeRepair


@dataclass(frozen=True, eq=False)
class ScanFrame:
    """One laser scan as a robot recorded it.

    Attributes:
        time: seconds (the scan's own timestamp, e.g. `header.stamp` or CARMEN's `ts` field).
        ranges: (B,) float64 ranges, metres, REP-117 (+inf no return, -inf too close, NaN erroneous).
            Read-only.
        angle_min: angle of the first beam in the laser frame, radians.
        angle_increment: angle between consecutive beams, radians.
        range_min, range_max: valid range interval, metres.
        laser_pose: T_base_laser, (x, y, yaw) of the laser in the robot (base) frame.
        odometry: T_odom_base at `time`, or None when the log has no odometry for this scan.
        reference: T_map_base at `time` (corrected or ground-truth pose), or None.
    """

    time: float
    ranges: NDArray[np.float64]
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    laser_pose: Pose = (0.0, 0.0, 0.0)
    odometry: Pose | None = None
    reference: Pose | None = None

    def __post_init__(self) -> None:
        ranges = np.array(self.ranges, dtype=np.float64)
        if ranges.ndim != 1 or ranges.size == 0:
            raise ValueError(f"ranges must be a non-empty (B,) array, got shape {ranges.shape}")
        ranges.setflags(write=False)
        object.__setattr__(self, "ranges", ranges)
        for name in ("time", "angle_min", "angle_increment", "range_min", "range_max"):
            value = float(getattr(self, name))
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value!r}")
            object.__setattr__(self, name, value)
        if not 0.0 <= self.range_min < self.range_max:
            raise ValueError(f"need 0 <= range_min < range_max, got {self.range_min}, {self.range_max}")
        object.__setattr__(self, "laser_pose", as_pose(self.laser_pose, "laser_pose"))
        if self.odometry is not None:
            object.__setattr__(self, "odometry", as_pose(self.odometry, "odometry"))
        if self.reference is not None:
            object.__setattr__(self, "reference", as_pose(self.reference, "reference"))

    @property
    def beams(self) -> int:
        """Number of beams B."""
        return int(self.ranges.shape[0])

    def points(self) -> NDArray[np.float64]:
        """(M, 2) valid returns in the robot (base) frame, metres, in beam order."""
        return scan_to_points(
            self.ranges,
            self.angle_min,
            self.angle_increment,
            self.range_min,
            self.range_max,
            sensor_pose=self.laser_pose,
        )


@dataclass(frozen=True)
class BadLine:
    """A record a reader could not use.

    Attributes:
        line: 1-based line number in the file (0 for records without lines, e.g. bag messages).
        kind: the record's type as the file names it (e.g. "FLASER").
        reason: what was wrong.
    """

    line: int
    kind: str
    reason: str


@dataclass(eq=False)
class ScanLog(Sequence[ScanFrame]):
    """Scans and odometry read from one log file, in time order (a sequence of its `frames`).

    Attributes:
        source: the file or bag folder read.
        frames: the scans.
        odometry_times: (K,) seconds of the raw odometry stream.
        odometry_poses: (K, 3) T_odom_base of the raw odometry stream.
        skipped: record kinds the reader left out and how many of each (unknown types, malformed lines,
            placeholder odometry, other lasers, ...).
        bad_lines: every malformed record with its line number and the reason.
        params: settings the log carries (CARMEN `PARAM` lines, bag metadata), as text.
        time_repair: how the reader repaired the scans' timestamps (see `planicp.io.log_times`;
            None when the reader does not repair them).
    """

    source: Path
    frames: list[ScanFrame]
    odometry_times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    odometry_poses: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    skipped: dict[str, int] = field(default_factory=dict)
    bad_lines: list[BadLine] = field(default_factory=list)
    params: dict[str, str] = field(default_factory=dict)
    time_repair: TimeRepair | None = None

    def __len__(self) -> int:
        return len(self.frames)

    @overload
    def __getitem__(self, index: int) -> ScanFrame: ...

    @overload
    def __getitem__(self, index: slice) -> list[ScanFrame]: ...

    def __getitem__(self, index: int | slice) -> ScanFrame | list[ScanFrame]:
        return self.frames[index]

    def __iter__(self) -> Iterator[ScanFrame]:
        return iter(self.frames)

    def times(self) -> NDArray[np.float64]:
        """(N,) scan times, seconds."""
        return np.array([f.time for f in self.frames], dtype=np.float64)

    @property
    def has_reference(self) -> bool:
        """Whether at least one scan carries a reference pose."""
        return any(f.reference is not None for f in self.frames)

    @property
    def has_odometry(self) -> bool:
        """Whether at least one scan carries an odometry pose."""
        return any(f.odometry is not None for f in self.frames)

    def reference_poses(self) -> NDArray[np.float64]:
        """(N, 3) T_map_base reference pose of every scan; rows of NaN where a scan has none.

        Raises:
            ValueError: no scan of the log has a reference pose.
        """
        if not self.has_reference:
            raise ValueError(f"log {self.source} carries no reference poses")
        return _pose_rows([f.reference for f in self.frames])

    def odometry_at_scans(self) -> NDArray[np.float64]:
        """(N, 3) T_odom_base of every scan at its time; rows of NaN where a scan has none.

        Raises:
            ValueError: no scan of the log has odometry.
        """
        if not self.has_odometry:
            raise ValueError(f"log {self.source} carries no odometry")
        return _pose_rows([f.odometry for f in self.frames])


def _pose_rows(poses: list[Pose | None]) -> NDArray[np.float64]:
    out = np.full((len(poses), 3), np.nan)
    for k, pose in enumerate(poses):
        if pose is not None:
            out[k] = pose
    return out
