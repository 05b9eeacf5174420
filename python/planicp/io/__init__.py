"""Real robot data in, trajectories out: log readers and trajectory writers.

Every reader returns a `ScanLog` of `ScanFrame`s (time, REP-117 ranges, laser mount T_base_laser,
odometry T_odom_base, reference T_map_base where the log has one):

* `read_carmen` — CARMEN logs (`.log`, `.clf`, optionally `.gz`),
* `read_g2o` — g2o 2D graphs with ROBOTLASER1 scans (MIT Killian Court),
* `planicp.io.bag.read_bag` / `write_bag` — ROS 1 and ROS 2 bags (needs `pip install planicp[ros]`),
* `open_log` picks one of them from the path.

Timestamps as real logs have them (coarse, missing, out of order): `repair_times` (`log_times`).

Trajectories: `write_tum`, `read_tum`, `write_kitti`, `read_kitti`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .._validation import brief
from .carmen import read_carmen
from .g2o import G2oGraph, read_g2o, read_g2o_graph
from .log_times import DEFAULT_SCAN_PERIOD, TimeRepair, repair_times
from .pose_interpolation import interpolate_poses
from .scan_log import BadLine, ScanFrame, ScanLog
from .trajectory_files import read_kitti, read_tum, write_kitti, write_tum

CARMEN_SUFFIXES = (".log", ".clf", ".carmen")


def open_log(path: str | Path, **options: Any) -> ScanLog:
    """Reads a log with the reader its path calls for; `options` go to that reader.

    * a folder holding `metadata.yaml` (ROS 2 bag) or a `.bag` file (ROS 1 bag) -> `read_bag`,
    * `.g2o` (also `.g2o.gz`, `.g2o.zip`) -> `read_g2o`,
    * `.log`, `.clf`, `.carmen` (also with `.gz`) -> `read_carmen`,
    * anything else: `read_carmen` if the first non-comment line starts with a CARMEN line type,
      `read_g2o` if it starts with `VERTEX_SE2`.

    Raises:
        FileNotFoundError: no such file or folder.
        ValueError: the format cannot be recognised.
    """
    source = Path(path)
    if not source.exists():
        raise FileNotFoundError(f"log not found: {source}")
    if source.is_dir() or source.suffix == ".bag":
        if source.is_dir() and not (source / "metadata.yaml").is_file():
            raise ValueError(f"{source} is a folder without metadata.yaml, so not a ROS 2 bag")
        from .bag import read_bag

        return read_bag(source, **options)
    suffixes = [s.lower() for s in source.suffixes]
    while suffixes and suffixes[-1] in (".gz", ".zip"):
        suffixes.pop()
    last = suffixes[-1] if suffixes else ""
    if last == ".g2o":
        return read_g2o(source, **options)
    if last in CARMEN_SUFFIXES:
        return read_carmen(source, **options)
    first = _first_record(source)
    if first == "VERTEX_SE2":
        return read_g2o(source, **options)
    if first in ("PARAM", "ODOM", "FLASER", "RLASER", "ROBOTLASER1", "SYNC", "TRUEPOS", "RAWLASER1"):
        return read_carmen(source, **options)
    raise ValueError(
        f"cannot tell the format of {source}: expected a CARMEN log (.log, .clf), a g2o file, "
        f"a ROS 1 .bag or a ROS 2 bag folder; its first record is {brief(first)}"
    )


def _first_record(source: Path) -> str | None:
    from .text_source import read_lines

    try:
        for _, text in read_lines(source):
            fields = text.split()
            if fields and not fields[0].startswith("#"):
                return fields[0]
    except (ValueError, OSError):
        return None
    return None


__all__ = [
    "BadLine",
    "DEFAULT_SCAN_PERIOD",
    "G2oGraph",
    "ScanFrame",
    "ScanLog",
    "TimeRepair",
    "interpolate_poses",
    "open_log",
    "read_carmen",
    "read_g2o",
    "read_g2o_graph",
    "read_kitti",
    "read_tum",
    "repair_times",
    "write_kitti",
    "write_tum",
]
