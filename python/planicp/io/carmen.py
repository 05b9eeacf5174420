"""CARMEN logs (plain text, optionally gzip-compressed): `ODOM`, `FLASER`/`RLASER`, `ROBOTLASER1`, `PARAM`.

Line formats (fields separated by white space, `#` starts a comment line):

    PARAM name value [host ts]
    ODOM x y theta tv rv accel ts host logger_ts
    FLASER n r1 .. rn x y theta odom_x odom_y odom_theta ts host logger_ts      (RLASER alike)
    ROBOTLASER1 laser_type start_angle fov angular_res max_range accuracy remission_mode
                n r1 .. rn n_rem rem1 .. rem_n_rem laser_x laser_y laser_theta robot_x robot_y robot_theta
                tv rv forward_safety side_safety turn_axis ts host logger_ts

Interpretation:
    * Time is the `ts` field (the sensor's timestamp), seconds. Stamps that are coarse (printed with
      six significant digits), all equal or out of order are repaired with `repair_times` and a
      warning: a stamp that goes back is replaced by its neighbours' middle, a coarse clock gives
      the period between its ticks, a log without timing is taken `DEFAULT_SCAN_PERIOD` apart
      (`ScanLog.time_repair` says which).
    * FLASER/RLASER beams start at -90 degrees; n = 180 or 181 beams are 1 degree apart, 360 or 361
      beams 0.5 degree apart (as CARMEN's `carmen_laser_guess_angle_increment`), any other n spreads
      evenly over 180 degrees. A reading at or above the maximum range (`max_range` argument, else the
      `robot_front_laser_max` / `robot_rear_laser_max` PARAM, else 80 m since SICK scanners report
      81.83 m and up for no return) is "no return" and becomes +inf; a reading <= 0 becomes NaN.
      ROBOTLASER1 carries its own start angle, resolution and maximum range.
    * Laser mount T_base_laser: the `laser_pose` argument, else the PARAMs `robot_frontlaser_offset`,
      `robot_frontlaser_side_offset`, `robot_frontlaser_angular_offset` (front laser; the rear laser's
      `robot_rearlaser_*` with its yaw turned by pi, as it looks backwards); for ROBOTLASER1 without
      such PARAMs, the offset of its laser pose from its robot pose.
    * Reference T_map_base (when `reference=True`): the line's laser pose (`x y theta`, corrected in a
      corrected log) moved back to the base: T_map_base = T_map_laser * inverse(T_base_laser).
    * Odometry T_odom_base: the ODOM stream interpolated to the scan time when the log has ODOM lines
      that are not all (0, 0, 0) placeholders and the scans' stamps were not coarse or missing (scans
      outside the ODOM time span get None); otherwise the robot pose on the laser line itself
      (`odom_x odom_y odom_theta`, `robot_x robot_y robot_theta`).

Bad lines: with `errors="skip"` (the default) a malformed line (truncated, wrong field count, a
field that is not a number, a non-finite pose or time) is left out, recorded in `ScanLog.bad_lines`
with its line number and counted in `ScanLog.skipped` as "<TYPE> (malformed)", and one warning
names the first; every valid line around it is kept. `errors="raise"` stops at the first bad line
with a ValueError naming the file and line. Unknown line types are counted in `skipped` by type.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .._validation import MAX_COORDINATE, Pose, as_pose, brief
from ..se2 import between, compose, inverse
from .line_records import LineTally, records, skipped_summary
from .log_times import late_copies, repair_times
from .pose_interpolation import interpolate_poses
from .scan_log import ScanFrame, ScanLog

LaserKind = Literal["FLASER", "RLASER", "ROBOTLASER1"]
LASER_KINDS: tuple[LaserKind, ...] = ("FLASER", "RLASER", "ROBOTLASER1")
AUTO_ORDER: tuple[LaserKind, ...] = ("ROBOTLASER1", "FLASER", "RLASER")
NO_RETURN_RANGE = 80.0
"""Metres: FLASER/RLASER readings at or above this are "no return" unless the log says otherwise."""


MAX_MOUNT_OFFSET = 100.0
"""Metres: a laser mount PARAM farther from the base than this is a bad line (a robot is not that big)."""

_RANGE_PARAMS = ("robot_front_laser_max", "robot_rear_laser_max")
_MOUNT_PARAMS = tuple(
    f"robot_{laser}_{part}"
    for laser in ("frontlaser", "rearlaser")
    for part in ("offset", "side_offset", "angular_offset")
)


class _BadLine(Exception):
    pass


@dataclass
class _LaserRecord:
    line: int
    kind: LaserKind
    time: float
    ranges: NDArray[np.float64]
    angle_min: float
    angle_increment: float
    max_range: float | None
    laser_world: Pose
    robot_world: Pose


def _number(fields: list[str], index: int) -> float:
    try:
        return float(fields[index])
    except ValueError:
        raise _BadLine(f"field {index + 1} ({brief(fields[index])}) is not a number") from None


def _finite(fields: list[str], start: int, count: int, what: str) -> tuple[float, ...]:
    values = tuple(_number(fields, start + k) for k in range(count))
    if not all(math.isfinite(v) for v in values):
        raise _BadLine(f"{what} must be finite, got {values}")
    return values


def _poses(fields: list[str], start: int, count: int, what: str) -> tuple[float, ...]:
    """`count` consecutive (x, y, yaw) poses: finite, and x, y within `MAX_COORDINATE` metres."""
    values = _finite(fields, start, 3 * count, what)
    for k in range(count):
        for v in values[3 * k : 3 * k + 2]:
            if abs(v) > MAX_COORDINATE:
                raise _BadLine(f"{what}: a coordinate of {v:.6g} m is beyond +-{MAX_COORDINATE:.0e} m")
    return values


def _count(fields: list[str], index: int, what: str) -> int:
    value = _number(fields, index)
    if not (value.is_integer() and 0 <= value <= 1_000_000):
        raise _BadLine(f"{what} must be a whole number >= 0, got {brief(fields[index])}")
    return int(value)


def _check_param(name: str, text: str) -> None:
    """A PARAM planicp reads must hold a usable value; a bad one is a bad line (its default is kept)."""
    if name not in _RANGE_PARAMS and name not in _MOUNT_PARAMS:
        return
    try:
        value = float(text)
    except ValueError:
        raise _BadLine(f"{name} ({brief(text)}) is not a number; the default is used") from None
    if name in _RANGE_PARAMS and not (math.isfinite(value) and value > 0.0):
        raise _BadLine(f"{name} must be a positive number of metres, got {brief(text)}; the default is used")
    if name in _MOUNT_PARAMS and not (math.isfinite(value) and abs(value) <= MAX_MOUNT_OFFSET):
        raise _BadLine(
            f"{name} must be a finite number within +-{MAX_MOUNT_OFFSET:g} (metres or radians), "
            f"got {brief(text)}; the default is used (or pass laser_pose)"
        )


def _expect_fields(fields: list[str], needed: int, layout: str) -> None:
    if len(fields) < needed:
        raise _BadLine(f"truncated: {layout} needs {needed} fields, got {len(fields)}")
    if len(fields) > needed:
        raise _BadLine(f"wrong field count: {layout} needs {needed} fields, got {len(fields)}")


def _ranges(fields: list[str], start: int, n: int) -> NDArray[np.float64]:
    try:
        return np.array(fields[start : start + n], dtype=np.float64)
    except ValueError:
        bad = next(k for k in range(start, start + n) if not _is_float(fields[k]))
        raise _BadLine(f"field {bad + 1} ({brief(fields[bad])}) is not a number") from None


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def flaser_angle_increment(beams: int) -> float:
    """Radians between FLASER/RLASER beams, as CARMEN guesses it from the beam count."""
    if beams in (180, 181):
        return math.pi / 180.0
    if beams in (360, 361):
        return math.pi / 360.0
    return math.pi / (beams - 1)


def _parse_old_laser(kind: LaserKind, fields: list[str], line: int) -> _LaserRecord:
    if len(fields) < 2:
        raise _BadLine("truncated: no beam count")
    n = _count(fields, 1, "beam count n")
    if n < 2:
        raise _BadLine(f"needs at least 2 beams, got {n}")
    _expect_fields(fields, n + 11, f"{kind} with n={n} (n + 11)")
    ranges = _ranges(fields, 2, n)
    pose = _poses(fields, 2 + n, 2, "the laser and odometry poses")
    (t,) = _finite(fields, 8 + n, 1, "the timestamp")
    return _LaserRecord(
        line,
        kind,
        t,
        ranges,
        -math.pi / 2.0,
        flaser_angle_increment(n),
        None,
        (pose[0], pose[1], pose[2]),
        (pose[3], pose[4], pose[5]),
    )


def _parse_robotlaser(fields: list[str], line: int) -> _LaserRecord:
    if len(fields) < 9:
        raise _BadLine(f"truncated: ROBOTLASER1 needs at least 9 fields before its ranges, got {len(fields)}")
    start, fov, res, max_range = _finite(fields, 2, 4, "start_angle, fov, angular_res and max_range")
    if not (res > 0.0 and max_range > 0.0):
        raise _BadLine(f"angular_res and max_range must be positive, got {res}, {max_range}")
    n = _count(fields, 8, "beam count n")
    if n < 2:
        raise _BadLine(f"needs at least 2 beams, got {n}")
    if len(fields) < 10 + n:
        raise _BadLine(f"truncated: ROBOTLASER1 with n={n} ends inside its ranges ({len(fields)} fields)")
    n_rem = _count(fields, 9 + n, "remission count")
    _expect_fields(fields, n + n_rem + 24, f"ROBOTLASER1 with n={n}, n_rem={n_rem} (n + n_rem + 24)")
    ranges = _ranges(fields, 9, n)
    base = 10 + n + n_rem
    pose = _poses(fields, base, 2, "the laser and robot poses")
    (t,) = _finite(fields, base + 11, 1, "the timestamp")
    return _LaserRecord(
        line, "ROBOTLASER1", t, ranges, start, res, max_range, (pose[0], pose[1], pose[2]), (pose[3], pose[4], pose[5])
    )


def _param_float(params: dict[str, str], name: str, default: float) -> float:
    text = params.get(name)
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        return default
    return value if math.isfinite(value) else default


def _param_mount(params: dict[str, str], kind: LaserKind) -> Pose | None:
    prefix = "robot_rearlaser" if kind == "RLASER" else "robot_frontlaser"
    names = (f"{prefix}_offset", f"{prefix}_side_offset", f"{prefix}_angular_offset")
    if not any(n in params for n in names) and kind == "ROBOTLASER1":
        return None
    x, y, yaw = (_param_float(params, n, 0.0) for n in names)
    if abs(x) > MAX_COORDINATE or abs(y) > MAX_COORDINATE:  # no mount: ignored, as an offset that is no number
        x, y = 0.0, 0.0
    if kind == "RLASER":
        yaw += math.pi
    return (x, y, math.atan2(math.sin(yaw), math.cos(yaw)))


def read_carmen(
    path: str | Path,
    *,
    laser: LaserKind | None = None,
    laser_pose: Pose | None = None,
    max_range: float | None = None,
    reference: bool = True,
    errors: Literal["skip", "raise"] = "skip",
) -> ScanLog:
    """Reads a CARMEN log (plain, `.gz` or by content) into a `ScanLog`; see the module doc for the semantics.

    Args:
        path: the log file.
        laser: which laser lines become scans; None picks ROBOTLASER1 if present, else FLASER, else RLASER.
            The other laser types are counted in `skipped`.
        laser_pose: T_base_laser (x, y, yaw), overriding the log's PARAMs.
        max_range: readings at or above it (metres) are "no return" (+inf), overriding the log.
        reference: take the laser lines' laser poses as reference poses (true for corrected logs).
        errors: "skip" bad lines (recorded and counted) or "raise" a ValueError at the first one.

    Raises:
        FileNotFoundError: no such file.
        ValueError: a bad line with errors="raise"; a log without any usable laser line.
    """
    tally = LineTally(Path(path), errors)
    if laser is not None and laser not in LASER_KINDS:
        raise ValueError(f"laser must be one of {LASER_KINDS} or None, got {laser!r}")
    mount_override = as_pose(laser_pose, "laser_pose") if laser_pose is not None else None
    if max_range is not None and not (math.isfinite(max_range) and max_range > 0.0):
        raise ValueError(f"max_range must be a positive number of metres, got {max_range!r}")
    source = tally.source
    params: dict[str, str] = {}
    odom_rows: list[tuple[float, float, float, float]] = []
    lasers: dict[LaserKind, list[_LaserRecord]] = {k: [] for k in LASER_KINDS}

    for line, kind, fields in records(tally):
        try:
            if kind == "PARAM":
                if len(fields) < 3:
                    raise _BadLine(f"truncated: PARAM needs a name and a value, got {len(fields)} fields")
                _check_param(fields[1], fields[2])
                params[fields[1]] = fields[2]
            elif kind == "ODOM":
                _expect_fields(fields, 10, "ODOM x y theta tv rv accel ts host logger_ts")
                x, y, yaw = _poses(fields, 1, 1, "the odometry pose")
                (t,) = _finite(fields, 7, 1, "the timestamp")
                odom_rows.append((t, x, y, yaw))
            elif kind == "FLASER":
                lasers["FLASER"].append(_parse_old_laser("FLASER", fields, line))
            elif kind == "RLASER":
                lasers["RLASER"].append(_parse_old_laser("RLASER", fields, line))
            elif kind == "ROBOTLASER1":
                lasers["ROBOTLASER1"].append(_parse_robotlaser(fields, line))
            else:
                tally.skip(kind)
        except _BadLine as exc:
            tally.reject(line, kind, str(exc))

    present = [k for k in AUTO_ORDER if lasers[k]]
    chosen = laser if laser is not None else (present[0] if present else None)
    if chosen is None or not lasers[chosen]:
        what = chosen or "FLASER, RLASER or ROBOTLASER1"
        raise ValueError(f"{source}: no usable {what} line in the log (skipped: {skipped_summary(tally.skipped)})")
    for other in LASER_KINDS:
        if other != chosen and lasers[other]:
            tally.skip(f"{other} (other laser)", len(lasers[other]))

    kept = lasers[chosen]
    late = late_copies(np.array([r.time for r in kept]), np.array([r.robot_world for r in kept]))
    if late.any():
        tally.skip(f"{chosen} (late copy: stamped before earlier records)", int(np.count_nonzero(late)))
        warnings.warn(
            f"{source}: dropped {int(np.count_nonzero(late))} {chosen} line(s) written late (stamped "
            f"before earlier lines, with an old pose); first at line {kept[int(np.argmax(late))].line}",
            stacklevel=2,
        )
        kept = [r for r, drop in zip(kept, late) if not drop]
    times, repair = repair_times(np.array([r.time for r in kept], dtype=np.float64))
    chosen_records = [replace(r, time=float(t)) for r, t in zip(kept, times)]
    # Stamps made up for coarse or missing ones cannot be matched against the ODOM stream's: each
    # line's own odometry is used.
    stream_rows = odom_rows if repair.fallback == "none" else []
    if repair.fallback != "none" and odom_rows:
        tally.skip("ODOM (scan timestamps repaired: the laser lines' odometry is used)", len(odom_rows))
    frames, odo_t, odo_p = _frames(chosen_records, stream_rows, params, mount_override, max_range, reference, tally)
    if not frames:
        raise ValueError(f"{source}: no usable {chosen} line in the log (skipped: {skipped_summary(tally.skipped)})")
    tally.warn(stacklevel=2)
    if repair.message:
        warnings.warn(f"{source}: {repair.message}", stacklevel=2)
    return ScanLog(source, frames, odo_t, odo_p, tally.skipped, tally.bad, params, repair)


def _frames(
    records: list[_LaserRecord],
    odom_rows: list[tuple[float, float, float, float]],
    params: dict[str, str],
    mount_override: Pose | None,
    max_range: float | None,
    reference: bool,
    tally: LineTally,
) -> tuple[list[ScanFrame], NDArray[np.float64], NDArray[np.float64]]:
    """The scans of `records`; a record whose poses or ranges make no scan (a mount or reference
    pose beyond the coordinate limit, say) is a malformed line of `tally`."""
    kind = records[0].kind
    param_mount = _param_mount(params, kind)
    default_max = _param_float(
        params, "robot_rear_laser_max" if kind == "RLASER" else "robot_front_laser_max", NO_RETURN_RANGE
    )
    if default_max <= 0.0:  # a maximum range of 0 or less is no range: the PARAM is ignored, as text would be
        default_max = NO_RETURN_RANGE
    odom = np.array(odom_rows, dtype=np.float64).reshape(-1, 4)
    use_stream = odom.shape[0] > 0 and bool(np.any(odom[:, 1:] != 0.0))
    if odom.shape[0] and not use_stream:
        tally.skipped["ODOM (all-zero placeholders)"] = int(odom.shape[0])
    if use_stream:
        order = np.argsort(odom[:, 0], kind="stable")
        odo_t, odo_p = odom[order, 0], odom[order, 1:]
        at_scans, inside = interpolate_poses(odo_t, odo_p, np.array([r.time for r in records]))
    frames = []
    kept = []
    for k, rec in enumerate(records):
        mount = mount_override or param_mount or between(rec.robot_world, rec.laser_world)
        limit = max_range or rec.max_range or default_max
        ranges = rec.ranges.copy()
        with np.errstate(invalid="ignore"):
            ranges[ranges >= limit] = np.inf
            ranges[ranges <= 0.0] = np.nan
        if use_stream:
            odometry: Pose | None = (
                (float(at_scans[k, 0]), float(at_scans[k, 1]), float(at_scans[k, 2])) if inside[k] else None
            )
        else:
            odometry = rec.robot_world
        try:
            ref = compose(rec.laser_world, inverse(mount)) if reference else None
            frames.append(
                ScanFrame(
                    rec.time,
                    ranges,
                    rec.angle_min,
                    rec.angle_increment,
                    0.0,
                    limit,
                    laser_pose=mount,
                    odometry=odometry,
                    reference=ref,
                )
            )
        except ValueError as exc:
            tally.reject(rec.line, rec.kind, str(exc))
            continue
        kept.append(rec)
    if not use_stream:
        odo_t = np.array([r.time for r in kept], dtype=np.float64)
        odo_p = np.array([r.robot_world for r in kept], dtype=np.float64).reshape(-1, 3)
    return frames, odo_t, odo_p
