"""Pure-pursuit waypoint follower for a differential-drive robot.

Map frame, metres, seconds, radians (REP-103: x forward, y left, yaw counter-clockwise). The follower turns a
polyline of waypoints into velocity commands ``(v, w)`` for `planicp.sim.diff_drive.step`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import positive, real_number
from ..se2 import wrap_angle
from .diff_drive import DiffDriveLimits, DiffDriveState

__all__ = ["WaypointFollower"]

_MIN_SPEED = 0.05  # m/s: creep speed so braking profiles never stall before a switch/goal radius
_TURN_GAIN = 2.0  # 1/s: proportional gain of the in-place turn
_ALIGNED = math.radians(20.0)  # an in-place turn ends when the heading error falls below this
_SWITCH_FRACTION = 0.5  # an intermediate waypoint counts as reached within this share of goal_tolerance
_MAX_BULGE = 0.05  # metres: largest sideways bulge of a pure-pursuit arc onto a segment
_MIN_LOOKAHEAD = 0.15  # metres
_TURN_RAMP = 0.2  # seconds: the arc speed allows the yaw rate reached within this time at full angular accel


class WaypointFollower:
    """Follows ``waypoints`` with a pure-pursuit controller that does not cut corners.

    The path is the polyline through the waypoints (the robot first drives to ``waypoints[0]`` unless it is
    within ``goal_tolerance`` of it at the first `command`). Each command:

    1. Advances to the next segment once the robot is within ``goal_tolerance / 2`` of the current segment's
       end or has passed it (its projection lies beyond the end).
    2. Aims at the *carrot*: the point ``L`` metres ahead of the robot's projection on the CURRENT segment's
       line (beyond the segment's end if need be; clamped to the last waypoint on the last segment). The
       carrot never moves onto the next segment before the robot reaches the corner, so the robot does not
       cut the inside of a corner (where the obstacles that bend a route are). ``L`` is the longest of
       ``lookahead`` times 1, 0.75, 0.5, 0.35, 0.25 (and at least 0.15 m) whose pure-pursuit arc, from the
       robot's current offset and heading, never gets farther from the segment's line than
       ``max(current offset, 5 cm)`` (closed-form extreme of the circular arc); if none does, the shortest.
       So turning onto a new segment after a corner bulges at most about 5 cm to its side, and an offset
       never grows.
    3. If the heading error to the carrot exceeds ``turn_in_place_angle`` (60 deg), stops and turns in place
       until the error is below 20 deg (hysteresis); the yaw rate brakes so that it can stop within the
       remaining angle (``w <= sqrt(2 * max_angular_accel * |error|)``).
    4. Otherwise drives the pure-pursuit arc through the carrot, curvature ``k = 2 sin(error) / distance``,
       ``w = k v``, at ``v = max_linear_speed * cos(error)`` limited by

       * ``w_reach / |k|`` with ``w_reach`` the yaw rate the robot can have within 0.2 s (its current yaw rate
         in the arc's direction plus ``0.2 s * max_angular_accel``, at most ``max_angular_speed``), so the
         robot does not run ahead of its turning;
       * a braking profile to the final goal (it arrives at rest);
       * slowing down for sharp turns: a braking profile to the corner's switch point that arrives at the
         speed this law will command right after the corner (``max_linear_speed * cos(turn)`` or less, the
         sharper the turn the slower) and at rest before a turn sharper than ``turn_in_place_angle``
         (which it then makes in place);
       * a creep speed of 0.05 m/s from below, so braking never stalls short of a switch point.

       Braking profiles use half of ``max_linear_accel``.

    `done` becomes True (and the commands ``(0, 0)``) once the robot is within ``goal_tolerance`` of
    the last waypoint.
    """

    def __init__(
        self,
        waypoints: Any,
        limits: DiffDriveLimits | None = None,
        lookahead: float = 0.6,
        goal_tolerance: float = 0.15,
        *,
        turn_in_place_angle: float = math.radians(60.0),
    ) -> None:
        """
        Args:
            waypoints: ``(N, 2)`` positions in metres (map frame), N >= 1; consecutive duplicates are dropped.
            limits: the robot's limits (None: ``DiffDriveLimits()``).
            lookahead: carrot distance in metres, > 0.
            goal_tolerance: radius in metres around the last waypoint that counts as arrived, > 0.
            turn_in_place_angle: heading error in radians above which the robot turns in place, in (0, pi).

        Raises:
            ValueError: bad waypoints or parameters (the message names the argument).
        """
        pts = np.asarray(waypoints, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 1:
            raise ValueError(f"waypoints must be an (N, 2) array with N >= 1, got shape {pts.shape}")
        if not np.isfinite(pts).all():
            raise ValueError("waypoints must be finite")
        if limits is None:
            limits = DiffDriveLimits()
        if not isinstance(limits, DiffDriveLimits):
            raise TypeError(f"limits must be a DiffDriveLimits, got {type(limits).__name__}")
        self.limits = limits
        self.lookahead = positive(lookahead, "lookahead", "metres")
        self.goal_tolerance = positive(goal_tolerance, "goal_tolerance", "metres")
        angle = real_number(turn_in_place_angle, "turn_in_place_angle")
        if not 0.0 < angle < math.pi:
            raise ValueError(f"turn_in_place_angle must be in (0, pi) radians, got {turn_in_place_angle!r}")
        self.turn_in_place_angle = angle
        keep = np.ones(len(pts), dtype=np.bool_)
        keep[1:] = np.hypot(*(pts[1:] - pts[:-1]).T) > 1e-9
        self._waypoints: NDArray[np.float64] = pts[keep]
        self._path: list[tuple[float, float]] = []  # set at the first command
        self._segment = 0
        self._turning = False
        self._done = False

    @property
    def done(self) -> bool:
        """True once the robot reached the last waypoint (within ``goal_tolerance``)."""
        return self._done

    @property
    def waypoints(self) -> NDArray[np.float64]:
        """The ``(N, 2)`` waypoints being followed (metres, map frame; a copy)."""
        return self._waypoints.copy()

    @property
    def segment(self) -> int:
        """Index of the path segment being followed (0 before the first command)."""
        return self._segment

    def command(self, state: DiffDriveState) -> tuple[float, float]:
        """The velocity command ``(v, w)`` (m/s, rad/s) for the robot in ``state`` (map frame).

        Call once per control period; the follower keeps its progress along the path between calls.
        """
        if not isinstance(state, DiffDriveState):
            raise TypeError(f"state must be a DiffDriveState, got {type(state).__name__}")
        if self._done:
            return 0.0, 0.0
        px, py = state.x, state.y
        if not self._path:
            wp = [(float(x), float(y)) for x, y in self._waypoints]
            if math.hypot(wp[0][0] - px, wp[0][1] - py) > self.goal_tolerance:
                wp.insert(0, (px, py))
            self._path = wp
        path = self._path
        goal = path[-1]
        d_goal = math.hypot(goal[0] - px, goal[1] - py)
        if d_goal <= self.goal_tolerance:
            self._done = True
            return 0.0, 0.0
        if len(path) == 1:  # a single waypoint farther than the tolerance: drive straight at it
            return self._pursue(state, goal, d_goal, 0.0, d_goal)

        switch = _SWITCH_FRACTION * self.goal_tolerance
        while True:
            ax, ay = path[self._segment]
            bx, by = path[self._segment + 1]
            seg_len = math.hypot(bx - ax, by - ay)
            ux, uy = (bx - ax) / seg_len, (by - ay) / seg_len
            s = (px - ax) * ux + (py - ay) * uy
            last = self._segment + 2 == len(path)
            if last or not (math.hypot(bx - px, by - py) <= switch or s >= seg_len):
                break
            self._segment += 1
            self._turning = False
        d_end = math.hypot(bx - px, by - py)
        if last:
            turn = 0.0
            if s >= seg_len:  # passed the goal sideways: head straight back to it
                return self._pursue(state, goal, d_end, 0.0, d_goal)
        else:
            cx, cy = path[self._segment + 2]
            turn = abs(wrap_angle(math.atan2(cy - by, cx - bx) - math.atan2(uy, ux)))
        psi = wrap_angle(state.yaw - math.atan2(uy, ux))
        lateral = ux * (py - ay) - uy * (px - ax)  # left of the segment is positive
        s_carrot = max(s, 0.0) + self._choose_lookahead(lateral, psi)
        if last:
            s_carrot = min(s_carrot, seg_len)
        carrot = (ax + ux * s_carrot, ay + uy * s_carrot)
        return self._pursue(state, carrot, max(d_end - switch, 0.0), turn, d_goal)

    def _choose_lookahead(self, lateral: float, psi: float) -> float:
        """The longest carrot distance (of ``lookahead`` times 1, 0.75, 0.5, 0.35, 0.25, at least 0.15 m)
        whose pure-pursuit arc stays within ``max(|lateral|, _MAX_BULGE)`` of the segment's line, for a robot
        ``lateral`` metres left of the line heading ``psi`` radians from its direction; else the shortest."""
        candidates = [self.lookahead * f for f in (1.0, 0.75, 0.5, 0.35, 0.25)]
        floor = min(_MIN_LOOKAHEAD, self.lookahead)
        chosen = floor
        for reach in candidates:
            if reach < floor:
                break
            if _arc_excursion(lateral, psi, reach) <= max(abs(lateral), _MAX_BULGE):
                chosen = reach
                break
        return chosen

    def _lookahead_for(self, psi: float) -> float:
        """Carrot distance (metres) whose arc bulges ``_MAX_BULGE`` for a robot ON the line heading ``psi``
        radians from it (``(L / 2) tan(|psi| / 2)`` is the bulge); a continuous version of
        `_choose_lookahead` used to predict the speed after a corner."""
        half = 0.5 * abs(psi)
        if half < 1e-9:
            return self.lookahead
        return max(min(self.lookahead, 2.0 * _MAX_BULGE / math.tan(min(half, 0.5 * math.pi - 1e-9))),
                   min(_MIN_LOOKAHEAD, self.lookahead))  # fmt: skip

    def _corner_speed(self, turn: float) -> float:
        """Speed (m/s) the pursuit law commands right after a corner of ``turn`` radians (robot on the path)."""
        lim = self.limits
        if turn >= self.turn_in_place_angle:
            return 0.0
        if turn <= 0.0:
            return lim.max_linear_speed
        curvature = 2.0 * math.sin(turn) / self._lookahead_for(turn)
        rate = min(lim.max_angular_speed, lim.max_angular_accel * _TURN_RAMP)
        return min(lim.max_linear_speed * math.cos(turn), rate / curvature)

    def _pursue(
        self, state: DiffDriveState, carrot: tuple[float, float], d_end: float, turn: float, d_goal: float
    ) -> tuple[float, float]:
        lim = self.limits
        dx, dy = carrot[0] - state.x, carrot[1] - state.y
        dist = math.hypot(dx, dy)
        error = wrap_angle(math.atan2(dy, dx) - state.yaw) if dist > 1e-9 else 0.0
        if abs(error) > self.turn_in_place_angle:
            self._turning = True
        elif abs(error) < _ALIGNED:
            self._turning = False
        if self._turning:
            rate = min(lim.max_angular_speed, _TURN_GAIN * abs(error),
                       math.sqrt(2.0 * lim.max_angular_accel * abs(error)))  # fmt: skip
            return 0.0, math.copysign(rate, error)
        curvature = 2.0 * math.sin(error) / dist if dist > 1e-9 else 0.0
        brake = 0.5 * lim.max_linear_accel
        v = lim.max_linear_speed * math.cos(error)
        if curvature != 0.0:
            # a yaw rate the robot has (or reaches within _TURN_RAMP), so the arc is driven as planned
            rate = max(0.0, state.w if curvature > 0.0 else -state.w) + lim.max_angular_accel * _TURN_RAMP
            v = min(v, min(lim.max_angular_speed, rate) / abs(curvature))
        v = min(v, math.sqrt(2.0 * brake * d_goal))
        if turn > 0.0:
            v_turn = self._corner_speed(turn)
            v = min(v, math.sqrt(v_turn * v_turn + 2.0 * brake * d_end))
        v = max(v, min(_MIN_SPEED, lim.max_linear_speed))
        w = max(-lim.max_angular_speed, min(lim.max_angular_speed, curvature * v))
        return v, w


def _arc_excursion(lateral: float, psi: float, reach: float) -> float:
    """Largest ``|lateral offset|`` (metres) along the circular arc from a robot ``lateral`` metres left of a
    line, heading ``psi`` radians from it, to the point ``reach`` metres ahead on the line (pure pursuit)."""
    beta = math.atan2(-lateral, reach)  # direction of the carrot relative to the line
    alpha = wrap_angle(beta - psi)  # tangent-chord angle; the heading turns by 2 * alpha along the arc
    end_heading = psi + 2.0 * alpha
    extreme = abs(lateral)
    if abs(alpha) > 1e-12 and (psi > 0.0 > end_heading or psi < 0.0 < end_heading):
        radius = math.hypot(reach, lateral) / (2.0 * abs(math.sin(alpha)))
        extreme = max(extreme, abs(lateral + math.copysign(radius * (1.0 - math.cos(psi)), psi)))
    return extreme
