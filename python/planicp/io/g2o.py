"""g2o 2D pose graphs with laser scans (`VERTEX_SE2`, `EDGE_SE2`, `ROBOTLASER1`), e.g. MIT Killian Court.

Line formats:

    VERTEX_SE2 id x y theta
    EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33      (measurement T_i_j, upper-triangular information)
    ROBOTLASER1 ...                                        (the CARMEN layout, see `planicp.io.carmen`)

A ROBOTLASER1 line belongs to the VERTEX_SE2 just before it. The vertices of such graphs are chained
from wheel odometry, so every scan gets its vertex pose as odometry (T_odom_base) and no reference
pose; the laser mount is the offset of the line's laser pose from its robot pose, and readings at or
above the line's maximum range are "no return" (+inf). Time is the line's `ts` field, repaired as
`read_carmen` repairs it when stamps are coarse, missing or out of order (`repair_times`). The file
may be plain, gzip-compressed or a zip archive holding one `.g2o` (as `rtb-data` ships
`killian.g2o.zip`).
Bad lines are handled as in `read_carmen` (`errors="skip"` records and counts them).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose
from ..se2 import between
from .carmen import _BadLine, _count, _expect_fields, _finite, _parse_robotlaser, _poses
from .line_records import LineTally, records, skipped_summary
from .log_times import repair_times
from .scan_log import ScanFrame, ScanLog


@dataclass(eq=False)
class G2oGraph:
    """The pose graph of a g2o file.

    Attributes:
        vertex_ids: (V,) int64 vertex ids in file order.
        poses: (V, 3) vertex poses (x, y, yaw).
        edges: (E, 2) int64 (i, j) vertex ids of each edge.
        measurements: (E, 3) T_i_j measured (dx, dy, dyaw).
        information: (E, 3, 3) symmetric information matrices.
    """

    vertex_ids: NDArray[np.int64]
    poses: NDArray[np.float64]
    edges: NDArray[np.int64]
    measurements: NDArray[np.float64]
    information: NDArray[np.float64]


def read_g2o(path: str | Path, *, errors: Literal["skip", "raise"] = "skip") -> ScanLog:
    """Scans of a g2o file with ROBOTLASER1 lines, each with its vertex pose as odometry."""
    return _read(Path(path), errors)[0]


def read_g2o_graph(path: str | Path, *, errors: Literal["skip", "raise"] = "skip") -> G2oGraph:
    """The vertices and edges of a 2D g2o file."""
    return _read(Path(path), errors)[1]


def _read(source: Path, errors: str) -> tuple[ScanLog, G2oGraph]:
    tally = LineTally(source, errors)
    ids: list[int] = []
    poses: list[Pose] = []
    edges: list[tuple[int, int]] = []
    meas: list[tuple[float, ...]] = []
    info: list[tuple[float, ...]] = []
    frames: list[ScanFrame] = []
    scanned: set[int] = set()
    last_vertex_bad = False  # a scan after a malformed VERTEX_SE2 belongs to no vertex read

    for line, kind, fields in records(tally):
        try:
            if kind == "VERTEX_SE2":
                last_vertex_bad = True
                _expect_fields(fields, 5, "VERTEX_SE2 id x y theta")
                vid = _count(fields, 1, "vertex id")
                x, y, yaw = _poses(fields, 2, 1, "the vertex pose")
                ids.append(vid)
                poses.append((x, y, yaw))
                last_vertex_bad = False
            elif kind == "EDGE_SE2":
                _expect_fields(fields, 12, "EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33")
                edges.append((_count(fields, 1, "vertex id i"), _count(fields, 2, "vertex id j")))
                meas.append(_finite(fields, 3, 3, "the measurement"))
                info.append(_finite(fields, 6, 6, "the information matrix"))
            elif kind == "ROBOTLASER1":
                if not ids:
                    raise _BadLine("a ROBOTLASER1 line needs a VERTEX_SE2 before it")
                if last_vertex_bad:
                    raise _BadLine("the VERTEX_SE2 line before it is malformed: the scan has no pose")
                if ids[-1] in scanned:
                    raise _BadLine(f"vertex {ids[-1]} already has a scan")
                rec = _parse_robotlaser(fields, line)
                ranges = rec.ranges.copy()
                with np.errstate(invalid="ignore"):
                    ranges[ranges >= (rec.max_range or math.inf)] = np.inf
                    ranges[ranges <= 0.0] = np.nan
                try:
                    frames.append(
                        ScanFrame(
                            rec.time,
                            ranges,
                            rec.angle_min,
                            rec.angle_increment,
                            0.0,
                            rec.max_range or math.inf,
                            laser_pose=between(rec.robot_world, rec.laser_world),
                            odometry=poses[-1],
                        )
                    )
                except ValueError as exc:  # e.g. a laser mount beyond the coordinate limit
                    raise _BadLine(str(exc)) from None
                scanned.add(ids[-1])
            else:
                tally.skip(kind)
        except _BadLine as exc:
            tally.reject(line, kind, str(exc))
    if not ids:
        raise ValueError(f"{source}: no VERTEX_SE2 line in the file (skipped: {skipped_summary(tally.skipped)})")
    tally.warn(stacklevel=3)
    info_m = np.zeros((len(info), 3, 3))
    for k, (i11, i12, i13, i22, i23, i33) in enumerate(info):
        info_m[k] = [[i11, i12, i13], [i12, i22, i23], [i13, i23, i33]]
    graph = G2oGraph(
        np.array(ids, dtype=np.int64),
        np.array(poses, dtype=np.float64).reshape(-1, 3),
        np.array(edges, dtype=np.int64).reshape(-1, 2),
        np.array(meas, dtype=np.float64).reshape(-1, 3),
        info_m,
    )
    times, repair = repair_times(np.array([f.time for f in frames], dtype=np.float64))
    if repair.message:
        warnings.warn(f"{source}: {repair.message}", stacklevel=3)
        frames = [replace(f, time=float(t)) for f, t in zip(frames, times)]
    odometry = np.array([f.odometry for f in frames], dtype=np.float64).reshape(-1, 3)
    log = ScanLog(source, frames, times, odometry, tally.skipped, tally.bad, {}, repair)
    return log, graph
