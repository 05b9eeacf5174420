"""Timestamps of real logs as they are: coarse, repeated, missing or out of order.

Real logs do not always carry usable scan times. Some CARMEN logs print UNIX times with six
significant digits (`1.10287e+09`: a stamp that changes every 100 s), some write 0 on every line,
and a log stitched from two runs can step back in time. `repair_times` turns such stamps into
increasing times and says what it did, instead of refusing the log:

1. A stamp below an earlier one is a glitch of the clock (the file's order is the recording's). When
   at most `MAX_DISORDERED_SHARE` of the steps go back, such a record is kept and its stamp becomes
   the middle of its in-order neighbours' (and counted); when more do, the stamps say nothing and
   are replaced by one `nominal_period` per record.
2. When every (remaining) stamp is the same, the log has no timing: one `nominal_period` per record.
3. Runs of equal stamps (coarse printing) make a clock that ticks over now and then. Between its
   first and its last tick the records span exactly the stamps' difference: that gives the scan
   period, and the records are taken that far apart (at `nominal_period` when it ticks fewer than
   twice).

Times are seconds; the result is strictly increasing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

DEFAULT_SCAN_PERIOD = 0.2
"""Seconds per scan assumed when a log's stamps carry no timing (a SICK LMS 200 logged at 5 Hz, as
in the CARMEN logs of the Radish collection)."""

MAX_DISORDERED_SHARE = 0.05
"""Largest share of steps going back in time for the stamps to be kept (those steps re-stamped)."""

TimeFallback = Literal["none", "coarse", "missing", "disordered"]


@dataclass(frozen=True)
class TimeRepair:
    """What `repair_times` did.

    Attributes:
        fallback: "none" (the stamps were strictly increasing), "coarse" (runs of equal stamps were
            spread), "missing" (every stamp equal: `nominal_period` per record), "disordered" (too
            many steps back: `nominal_period` per record).
        out_of_order: records whose stamp went back in time and was replaced.
        repeated: records whose stamp repeated the previous one (before spreading).
        message: one sentence for a warning ("" when nothing was done).
    """

    fallback: TimeFallback
    out_of_order: int
    repeated: int
    message: str


POSE_METRES_PER_RADIAN = 1.0
"""How `late_copies` weighs a turn against a translation when it measures a jump of the pose: one
radian counts as one metre (a robot's size, the distance at which a turn moves its outline as much)."""


def late_copies(times: NDArray[np.float64], poses: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which records are late copies of earlier messages (dropped by the readers), from their stamps
    (seconds, in file order) and the (N, 3) odometry poses (x, y, yaw) they carry.

    A record stamped before an earlier one is either a glitch of the clock (the record is in its
    place and only its stamp is wrong: `repair_times` re-stamps it) or a message written late (its
    stamp is right and the file's order is wrong: the tracker has long passed that time, and feeding
    it would send the odometry back and forth). The poses tell which: a late copy continues the motion
    where its stamp puts it, a glitched stamp where the file puts it. A record is a late copy when the
    detour through its pose is shorter at its stamp's place than at its place in the file (a jump
    weighs metres plus `POSE_METRES_PER_RADIAN` per radian); on a tie it stays.
    """
    t = np.asarray(times, dtype=np.float64)
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    late = np.zeros(t.shape[0], dtype=bool)
    if t.shape[0] < 3:
        return late
    earlier_max = np.maximum.accumulate(np.concatenate([[-np.inf], t[:-1]]))
    candidates = np.flatnonzero(t < earlier_max)
    if candidates.shape[0] == 0 or candidates.shape[0] > MAX_DISORDERED_SHARE * (t.shape[0] - 1):
        return late  # none, or so many that the stamps say nothing (`repair_times` ignores them)

    def jump(a: int, b: int) -> float:
        turn = math.remainder(float(p[b, 2] - p[a, 2]), math.tau)
        return float(np.hypot(*(p[b, :2] - p[a, :2]))) + POSE_METRES_PER_RADIAN * abs(turn)

    def detour(a: int, k: int, b: int | None) -> float:
        return jump(a, k) if b is None else jump(a, k) + jump(k, b) - jump(a, b)

    in_order = np.flatnonzero(t >= earlier_max)  # their stamps never decrease
    in_order_times = t[in_order]
    for k in candidates:
        after = int(k) + 1 if k + 1 < t.shape[0] else None
        here = detour(int(k) - 1, int(k), after)
        # Its stamp's place: between the last in-order record stamped at or before it and the next,
        # among the in-order records written before it (a prefix of `in_order`).
        slot = int(np.searchsorted(in_order_times, t[k], side="right"))
        written_before = int(np.searchsorted(in_order, k))
        if slot >= written_before:
            continue
        nxt = int(in_order[slot])
        there = jump(int(k), nxt) if slot == 0 else detour(int(in_order[slot - 1]), int(k), nxt)
        late[k] = there < here
    return late


def repair_times(
    times: NDArray[np.float64], nominal_period: float = DEFAULT_SCAN_PERIOD
) -> tuple[NDArray[np.float64], TimeRepair]:
    """(times, repair): strictly increasing times for the records stamped `times` (seconds, in
    record order), following the module's rules; every record keeps its place.

    Raises:
        ValueError: `nominal_period` is not a positive finite number, or a stamp is not finite.
    """
    if not (np.isfinite(nominal_period) and nominal_period > 0.0):
        raise ValueError(f"nominal_period must be a positive number of seconds, got {nominal_period!r}")
    t = np.asarray(times, dtype=np.float64)
    if not np.isfinite(t).all():
        raise ValueError("timestamps must be finite")
    if t.shape[0] < 2:
        return t.copy(), TimeRepair("none", 0, 0, "")
    steps = np.diff(t)
    if np.all(steps > 0.0):
        return t.copy(), TimeRepair("none", 0, 0, "")
    backward = int(np.count_nonzero(steps < 0.0))
    if backward > MAX_DISORDERED_SHARE * steps.shape[0]:
        even = t[0] + nominal_period * np.arange(t.shape[0], dtype=np.float64)
        return even, TimeRepair(
            "disordered",
            0,
            0,
            f"{backward} of {steps.shape[0]} timestamps go back in time: they are ignored, "
            f"and the scans are taken {nominal_period:g} s apart",
        )
    # A record whose stamp is below the latest one before it has a glitched stamp: the file's order
    # is the recording's, so the record is kept and takes the middle of its in-order neighbours.
    earlier_max = np.maximum.accumulate(np.concatenate([[-np.inf], t[:-1]]))
    late = t < earlier_max
    out_of_order = int(np.count_nonzero(late))
    u = t.copy()
    if out_of_order:
        index = np.arange(t.shape[0], dtype=np.float64)
        u[late] = np.interp(index[late], index[~late], t[~late])
        steps_in_order = np.diff(t[~late])
        step = float(np.median(steps_in_order[steps_in_order > 0])) if np.any(steps_in_order > 0) else nominal_period
        for k in np.flatnonzero(late):  # after the last stamp in order: one step on
            if u[k] <= u[k - 1]:
                u[k] = u[k - 1] + step
    repeated = int(np.count_nonzero(np.diff(u) == 0.0))
    restamped = (
        (
            f"{out_of_order} timestamp(s) earlier than the one before replaced by the middle of their "
            f"neighbours' (the records are kept in the log's order); "
        )
        if out_of_order
        else ""
    )
    if repeated == 0:
        return u, TimeRepair("none", out_of_order, 0, restamped.rstrip("; "))
    if u[-1] == u[0]:
        even = u[0] + nominal_period * np.arange(u.shape[0], dtype=np.float64)
        return even, TimeRepair(
            "missing",
            out_of_order,
            repeated,
            f"{restamped}every timestamp is {u[0]:g}: the scans are taken {nominal_period:g} s apart",
        )
    # A coarse clock ticks over between two records: from the first tick over to the last, the
    # records span exactly the stamps' difference, which gives the scan period.
    ticks = np.flatnonzero(np.diff(u) != 0.0) + 1
    if ticks.shape[0] < 2:
        period, start, anchor, how = nominal_period, 0, u[0], f"the scans are taken {nominal_period:g} s apart"
    else:
        first, last = int(ticks[0]), int(ticks[-1])
        period, start, anchor = (u[last] - u[first]) / (last - first), first, u[first]
        how = f"the scans are taken {period:.4g} s apart, the mean period between the stamps' changes"
    out = anchor + period * (np.arange(u.shape[0], dtype=np.float64) - start)
    return out, TimeRepair(
        "coarse",
        out_of_order,
        repeated,
        f"{restamped}{repeated} of {u.shape[0]} timestamps repeat the one before (coarse stamps): {how}",
    )
