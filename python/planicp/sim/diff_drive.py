"""Differential-drive (unicycle) robot model: limits, state and one exact integration step.

Frames and units follow REP-103: metres, seconds, radians; the pose ``(x, y, yaw)`` is the robot base
(``base_link``) in the map frame, x forward, y left, yaw counter-clockwise. ``v`` is the forward speed of the
base origin along its x axis (m/s), ``w`` its yaw rate (rad/s, counter-clockwise positive).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .._validation import Pose, positive, real_number
from ..se2 import wrap_angle

__all__ = ["DiffDriveLimits", "DiffDriveState", "arc_increment", "step"]

# |w * dt| below this uses the series of sin(t)/t and (1 - cos(t))/t (their relative error is < 1e-16 there).
_SMALL_ANGLE = 1e-4


@dataclass(frozen=True)
class DiffDriveLimits:
    """Kinematic limits and footprint of a differential-drive robot (defaults: the thesis' EtaBot class).

    Attributes:
        max_linear_speed: largest ``|v|``, m/s (0.5).
        max_angular_speed: largest ``|w|``, rad/s (1.0).
        max_linear_accel: largest ``|dv/dt|``, m/s^2 (0.5); applies to braking too.
        max_angular_accel: largest ``|dw/dt|``, rad/s^2 (2.0).
        wheel_base: distance between the two wheel contact points, m (0.4); used by `wheel_speeds`.
        radius: radius of the circular footprint about the base origin, m (0.3); planning keeps the base
            origin at least this far from walls and furniture.

    Every field must be a positive finite number (``ValueError`` naming the field otherwise; ``TypeError``
    for a non-number).
    """

    max_linear_speed: float = 0.5
    max_angular_speed: float = 1.0
    max_linear_accel: float = 0.5
    max_angular_accel: float = 2.0
    wheel_base: float = 0.4
    radius: float = 0.3

    def __post_init__(self) -> None:
        positive(self.max_linear_speed, "max_linear_speed", "m/s")
        positive(self.max_angular_speed, "max_angular_speed", "rad/s")
        positive(self.max_linear_accel, "max_linear_accel", "m/s^2")
        positive(self.max_angular_accel, "max_angular_accel", "rad/s^2")
        positive(self.wheel_base, "wheel_base", "metres")
        positive(self.radius, "radius", "metres")
        for name in ("max_linear_speed", "max_angular_speed", "max_linear_accel", "max_angular_accel",
                     "wheel_base", "radius"):  # fmt: skip
            object.__setattr__(self, name, float(getattr(self, name)))

    def wheel_speeds(self, v: float, w: float) -> tuple[float, float]:
        """``(left, right)`` wheel rim speeds in m/s for body velocities ``v`` (m/s) and ``w`` (rad/s)."""
        half = 0.5 * self.wheel_base * w
        return v - half, v + half


@dataclass(frozen=True)
class DiffDriveState:
    """Pose and body velocities of the robot.

    Attributes:
        x, y: position of the base origin in the map frame, metres.
        yaw: heading in the map frame, radians, counter-clockwise from +x (kept in ``(-pi, pi]`` by
            `step`).
        v: forward speed along the base x axis, m/s.
        w: yaw rate, rad/s (counter-clockwise positive).
    """

    x: float
    y: float
    yaw: float
    v: float = 0.0
    w: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x", "y", "yaw", "v", "w"):
            value = real_number(getattr(self, name), name)
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value!r}")
            object.__setattr__(self, name, value)

    @property
    def pose(self) -> Pose:
        """``(x, y, yaw)``: metres, metres, radians (T_map_base)."""
        return (self.x, self.y, self.yaw)


def arc_increment(distance: float, angle: float) -> Pose:
    """Motion ``(dx, dy, dyaw)`` in the START frame of the robot after driving an arc.

    The arc has length ``distance`` (metres, along the path; negative = backwards) and turns the heading by
    ``angle`` (radians), i.e. constant ``v = distance/dt`` and ``w = angle/dt`` over any ``dt``. Closed form:
    ``dx = distance * sin(angle)/angle``, ``dy = distance * (1 - cos(angle))/angle``, ``dyaw = angle``
    (``dx = distance``, ``dy = 0`` for a straight line), evaluated without cancellation for small angles.
    """
    if abs(angle) < _SMALL_ANGLE:
        a2 = angle * angle
        sinc = 1.0 - a2 / 6.0 + a2 * a2 / 120.0
        cosc = angle * (0.5 - a2 / 24.0 + a2 * a2 / 720.0)
    else:
        sinc = math.sin(angle) / angle
        half = math.sin(0.5 * angle)
        cosc = 2.0 * half * half / angle
    return (distance * sinc, distance * cosc, angle)


def _clamp(value: float, lo: float, hi: float) -> float:
    return lo if value < lo else hi if value > hi else value


def step(state: DiffDriveState, cmd_v: float, cmd_w: float, dt: float, limits: DiffDriveLimits) -> DiffDriveState:
    """Advance the robot by ``dt`` seconds under the velocity command ``(cmd_v, cmd_w)`` (m/s, rad/s).

    The command is first clamped to the speed limits (``|v| <= max_linear_speed``,
    ``|w| <= max_angular_speed``), then the change from the current velocities is clamped to the acceleration
    limits (``|v_new - v| <= max_linear_accel * dt``, same for ``w``). The resulting ``(v_new, w_new)`` is held
    constant for the whole step and the pose is integrated EXACTLY along the resulting circular arc (unicycle
    model; a straight line when ``w_new == 0``):

        yaw' = yaw + w dt
        x'   = x + v/w (sin(yaw') - sin(yaw)),   y' = y - v/w (cos(yaw') - cos(yaw))

    Args:
        state: current pose and velocities.
        cmd_v: commanded forward speed (m/s), finite.
        cmd_w: commanded yaw rate (rad/s), finite.
        dt: step length in seconds, > 0.
        limits: the robot's limits.

    Returns:
        The state after ``dt``: new pose (yaw wrapped to ``(-pi, pi]``) and the velocities ``(v_new, w_new)``
        that were applied during the step.
    """
    dt = positive(dt, "dt", "seconds")
    cmd_v = real_number(cmd_v, "cmd_v")
    cmd_w = real_number(cmd_w, "cmd_w")
    if not (math.isfinite(cmd_v) and math.isfinite(cmd_w)):
        raise ValueError(f"cmd_v and cmd_w must be finite, got {cmd_v!r} and {cmd_w!r}")
    if not isinstance(limits, DiffDriveLimits):
        raise TypeError(f"limits must be a DiffDriveLimits, got {type(limits).__name__}")
    v_target = _clamp(cmd_v, -limits.max_linear_speed, limits.max_linear_speed)
    w_target = _clamp(cmd_w, -limits.max_angular_speed, limits.max_angular_speed)
    dv = limits.max_linear_accel * dt
    dw = limits.max_angular_accel * dt
    v = _clamp(v_target, state.v - dv, state.v + dv)
    w = _clamp(w_target, state.w - dw, state.w + dw)
    fx, fy, dyaw = arc_increment(v * dt, w * dt)
    c, s = math.cos(state.yaw), math.sin(state.yaw)
    return DiffDriveState(
        x=state.x + c * fx - s * fy,
        y=state.y + s * fx + c * fy,
        yaw=wrap_angle(state.yaw + dyaw),
        v=v,
        w=w,
    )
