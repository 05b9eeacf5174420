"""Planar trajectories as TUM and KITTI files, the formats `evo` and most SLAM benchmarks read.

TUM: one pose per line, `timestamp tx ty tz qx qy qz qw` (seconds, metres, unit quaternion with the
scalar last), `#` comment lines. KITTI: one pose per line, the 12 entries of the row-major 3x4
matrix [R | t], no timestamps. Planar poses (x, y, yaw) are written with z = 0 and a rotation about
z only; every float is written with `repr`, which reads back bit for bit.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import brief

TUM_HEADER = "# timestamp tx ty tz qx qy qz qw"


def _poses(poses: Any) -> NDArray[np.float64]:
    arr = np.asarray(poses, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"poses must have shape (K, 3) (x, y, yaw), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        row = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
        raise ValueError(f"poses must be finite; row {row} is {arr[row].tolist()}")
    return arr


def write_tum(path: str | Path, times: Any, poses: Any, *, comment: str | None = None) -> Path:
    """Writes (K,) times (seconds) and (K, 3) poses (x, y, yaw) as a TUM trajectory file.

    Args:
        path: the file to write (its folder must exist).
        times: (K,) seconds, strictly increasing (evo rejects anything else).
        poses: (K, 3) x, y (metres), yaw (radians), e.g. T_map_base.
        comment: an extra `#` line after the header (e.g. what the poses are).

    Returns:
        The path written.
    """
    t = np.asarray(times, dtype=np.float64)
    p = _poses(poses)
    if t.shape != (p.shape[0],):
        raise ValueError(f"times must have shape ({p.shape[0]},) to match the poses, got {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
        raise ValueError("times must be finite and strictly increasing")
    lines = [TUM_HEADER]
    if comment:
        lines += [f"# {c}" for c in comment.splitlines()]
    for ti, (x, y, yaw) in zip(t.tolist(), p.tolist()):
        qz, qw = math.sin(yaw / 2.0), math.cos(yaw / 2.0)
        lines.append(f"{ti!r} {x!r} {y!r} 0.0 0.0 0.0 {qz!r} {qw!r}")
    out = Path(path)
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return out


def read_tum(path: str | Path, *, planar_tolerance: float = 1e-6) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(K,) times and (K, 3) planar poses (x, y, yaw) of a TUM trajectory file.

    Raises:
        ValueError: a line without 8 numbers, or a pose that is not planar (|z|, |qx|, |qy| above
            `planar_tolerance`), naming the file and line.
    """
    source = Path(path)
    times: list[float] = []
    poses: list[tuple[float, float, float]] = []
    for number, text in enumerate(source.read_text(encoding="utf-8").splitlines(), start=1):
        fields = text.split()
        if not fields or fields[0].startswith("#"):
            continue
        if len(fields) != 8:
            raise ValueError(f"{source}, line {number}: a TUM line needs 8 numbers, got {len(fields)}")
        try:
            t, x, y, z, qx, qy, qz, qw = (float(v) for v in fields)
        except ValueError:
            raise ValueError(f"{source}, line {number}: a TUM line must hold numbers: {brief(text)}") from None
        if max(abs(z), abs(qx), abs(qy)) > planar_tolerance:
            raise ValueError(f"{source}, line {number}: not a planar pose (z={z}, qx={qx}, qy={qy})")
        times.append(t)
        poses.append((x, y, 2.0 * math.atan2(qz, qw)))
    yaw = np.array([p[2] for p in poses])
    out = np.array(poses, dtype=np.float64).reshape(-1, 3)
    out[:, 2] = np.angle(np.exp(1j * yaw)) if len(poses) else yaw
    return np.array(times, dtype=np.float64), out


def write_kitti(path: str | Path, poses: Any) -> Path:
    """Writes (K, 3) poses (x, y, yaw) as a KITTI pose file (row-major 3x4 [R | t] per line, z = 0)."""
    p = _poses(poses)
    lines = []
    for x, y, yaw in p.tolist():
        c, s = math.cos(yaw), math.sin(yaw)
        row = (c, -s, 0.0, x, s, c, 0.0, y, 0.0, 0.0, 1.0, 0.0)
        lines.append(" ".join(repr(v) for v in row))
    out = Path(path)
    out.write_text("".join(line + "\n" for line in lines), encoding="utf-8")
    return out


def read_kitti(path: str | Path) -> NDArray[np.float64]:
    """(K, 3) planar poses (x, y, yaw) of a KITTI pose file (rotation assumed about z)."""
    source = Path(path)
    rows: list[tuple[float, float, float]] = []
    for number, text in enumerate(source.read_text(encoding="utf-8").splitlines(), start=1):
        fields = text.split()
        if not fields:
            continue
        if len(fields) != 12:
            raise ValueError(f"{source}, line {number}: a KITTI line needs 12 numbers, got {len(fields)}")
        try:
            m = [float(v) for v in fields]
        except ValueError:
            raise ValueError(f"{source}, line {number}: a KITTI line must hold numbers: {brief(text)}") from None
        rows.append((m[3], m[7], math.atan2(m[4], m[0])))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)
