"""Wheel-odometry simulation: per-message Gaussian noise and the thesis' systematic error generator.

Frames (REP-105): the odometry pose is T_odom_base. The odom frame is the robot's base frame at the FIRST
truth pose given to `Odometry`, so odometry starts at the identity ``(0, 0, 0)``. Each message
carries one increment: the motion ``(dx, dy, dyaw)`` between two successive truth poses, expressed in the
base frame at the earlier of them (x forward, y left, yaw counter-clockwise; metres, radians). The measured
increment is composed onto the previous odometry pose:

    odom_k = odom_{k-1} * (dx + n_x + c_t,  dy + n_y,  dyaw + n_yaw + c_r)

with ``n_*`` the Gaussian noise of `OdometryNoise` and ``(c_t, c_r)`` the constants of
`ErrorGenerator`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import Pose, as_pose, positive, real_number
from ..se2 import between, compose

__all__ = ["ErrorGenerator", "Odometry", "OdometryNoise"]


def _non_negative(value: Any, name: str, unit: str) -> float:
    v = real_number(value, name)
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{name} must be a finite number >= 0 ({unit}), got {value!r}")
    return v


@dataclass(frozen=True)
class OdometryNoise:
    """Zero-mean Gaussian noise added to every odometry increment (independent per message and component).

    With the true increment ``(dx, dy, dyaw)`` of a message (base frame at its start):

    * ``dx`` and ``dy`` each get noise of standard deviation ``translation_fraction * hypot(dx, dy)``
      metres (1 % of the step by default);
    * ``dyaw`` gets noise of standard deviation ``rotation_fraction * |dyaw| + rotation_sigma_min`` radians
      (1 % of the step's rotation plus 1e-5 rad by default; the constant term makes a stationary robot's
      heading random-walk).

    Attributes:
        translation_fraction: dimensionless, >= 0.
        rotation_fraction: dimensionless, >= 0.
        rotation_sigma_min: radians per message, >= 0.

    Every field must be finite and >= 0 (``ValueError`` naming the field). Use `none` for noiseless
    odometry.
    """

    translation_fraction: float = 0.01
    rotation_fraction: float = 0.01
    rotation_sigma_min: float = 1e-5

    def __post_init__(self) -> None:
        for name, unit in (("translation_fraction", "fraction of the step"),
                           ("rotation_fraction", "fraction of the rotation"),
                           ("rotation_sigma_min", "radians")):  # fmt: skip
            object.__setattr__(self, name, _non_negative(getattr(self, name), name, unit))

    @classmethod
    def none(cls) -> OdometryNoise:
        """No noise at all."""
        return cls(0.0, 0.0, 0.0)

    @property
    def enabled(self) -> bool:
        """Whether any sigma can be non-zero."""
        return self.translation_fraction > 0.0 or self.rotation_fraction > 0.0 or self.rotation_sigma_min > 0.0

    def sigmas(self, increment: Pose) -> tuple[float, float]:
        """``(translation sigma in metres, rotation sigma in radians)`` for a true ``increment``."""
        dx, dy, dyaw = increment
        sigma_t = self.translation_fraction * math.hypot(dx, dy)
        return sigma_t, self.rotation_fraction * abs(dyaw) + self.rotation_sigma_min


@dataclass(frozen=True)
class ErrorGenerator:
    """The thesis' systematic odometry error: constants added to EVERY odometry message.

    Each message's increment gets ``+translation_per_message`` metres on its x component -- forward along the
    base x axis at the start of the increment -- and ``+rotation_per_message`` radians on its yaw
    (counter-clockwise). They are added to every message regardless of the motion: also when the robot
    stands still (its odometry then creeps forward and turns) and when it reverses (the constant is still
    added along +x). At 100 Hz the defaults add 5 mm/s and 5e-3 rad/s (0.29 deg/s).

    Consequence for a straight drive of ``N`` messages of true step ``d`` (no noise): the odometry heading
    error is exactly ``N * rotation_per_message`` and the odometry position is
    ``(d + c_t) * sum_{j<N} (cos(j c_r), sin(j c_r))`` (an arc of radius ``(d + c_t) / (2 sin(c_r / 2))``);
    for small angles the along-track error is about ``N * c_t`` and the cross-track error about
    ``(d + c_t) * c_r * N (N - 1) / 2`` to the left.

    Attributes:
        translation_per_message: metres per message (5e-5); any finite value (negative drifts backwards).
        rotation_per_message: radians per message (5e-5); any finite value (negative turns clockwise).
    """

    translation_per_message: float = 5e-5
    rotation_per_message: float = 5e-5

    def __post_init__(self) -> None:
        for name in ("translation_per_message", "rotation_per_message"):
            v = real_number(getattr(self, name), name)
            if not math.isfinite(v):
                raise ValueError(f"{name} must be finite, got {v!r}")
            object.__setattr__(self, name, v)

    def apply(self, increment: Pose) -> Pose:
        """``increment`` (base frame at its start) with the constants added."""
        dx, dy, dyaw = increment
        return dx + self.translation_per_message, dy, dyaw + self.rotation_per_message


class Odometry:
    """Simulated wheel odometry that integrates true motion with noise and the error generator.

    Feed it the truth: `update` once per message with the true pose (map frame) at that message, or
    `run` with a whole trajectory, which samples it at ``rate_hz``. The first truth pose defines the odom
    frame (identity, REP-105); every later one is one message whose increment is the true relative motion
    since the previous truth pose, perturbed as described in the module docstring (noise first, computed from
    the true increment, then the generator's constants).
    """

    def __init__(
        self,
        rate_hz: float = 100.0,
        noise: OdometryNoise | None = None,
        error_generator: ErrorGenerator | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        """
        Args:
            rate_hz: message rate in Hz, > 0 (used by `run`).
            noise: per-message noise (None: no noise).
            error_generator: systematic error (None: off).
            rng: seeded generator, required when ``noise`` is enabled (3 normal draws per message).

        Raises:
            ValueError: ``rate_hz`` not positive and finite, or noise enabled without ``rng``.
        """
        self.rate_hz = positive(rate_hz, "rate_hz", "Hz")
        if noise is not None and not isinstance(noise, OdometryNoise):
            raise TypeError(f"noise must be an OdometryNoise, got {type(noise).__name__}")
        if error_generator is not None and not isinstance(error_generator, ErrorGenerator):
            raise TypeError(f"error_generator must be an ErrorGenerator, got {type(error_generator).__name__}")
        if rng is not None and not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        self.noise = noise if noise is not None else OdometryNoise.none()
        self.error_generator = error_generator
        if self.noise.enabled and rng is None:
            raise ValueError("rng is required when noise is enabled (pass a seeded numpy.random.Generator)")
        self._rng = rng
        self._last_truth: Pose | None = None
        self._pose: Pose = (0.0, 0.0, 0.0)
        self._messages = 0

    @property
    def pose(self) -> Pose:
        """Current odometry pose T_odom_base ``(x, y, yaw)``: metres, metres, radians in ``(-pi, pi]``."""
        return self._pose

    @property
    def messages(self) -> int:
        """Messages integrated so far (the initial truth pose is not a message)."""
        return self._messages

    def reset(self) -> None:
        """Forget everything: the next truth pose defines a new odom frame."""
        self._last_truth = None
        self._pose = (0.0, 0.0, 0.0)
        self._messages = 0

    def update(self, true_pose_now: Any) -> Pose:
        """Integrate the message that ends at ``true_pose_now`` (map frame ``(x, y, yaw)``).

        Returns:
            The odometry pose T_odom_base after the message; ``(0, 0, 0)`` for the first call, which only
            anchors the odom frame at the robot's start pose.
        """
        truth = as_pose(true_pose_now, "true_pose_now")
        if self._last_truth is None:
            self._last_truth = truth
            return self._pose
        dx, dy, dyaw = between(self._last_truth, truth)
        self._last_truth = truth
        if self.noise.enabled:
            assert self._rng is not None
            sigma_t, sigma_r = self.noise.sigmas((dx, dy, dyaw))
            nx, ny, nr = self._rng.standard_normal(3)
            dx, dy, dyaw = dx + sigma_t * nx, dy + sigma_t * ny, dyaw + sigma_r * nr
        if self.error_generator is not None:
            dx, dy, dyaw = self.error_generator.apply((dx, dy, dyaw))
        self._pose = compose(self._pose, (dx, dy, dyaw))
        self._messages += 1
        return self._pose

    def run(self, times: ArrayLike, poses: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Odometry messages for a whole truth trajectory, starting from a fresh odom frame.

        The truth (``times`` ``(N,)`` seconds, strictly increasing; ``poses`` ``(N, 3)`` map frame) is sampled
        at ``t_k = times[0] + k / rate_hz`` for ``k = 1 .. floor((times[-1] - times[0]) * rate_hz)`` (1e-9
        tolerance), linearly interpolated in x, y and the unwrapped yaw. ``times[0]`` anchors the odom frame
        (identity there) and is not a message, so a 10 s trajectory at 100 Hz gives 1000 messages.

        Returns:
            ``(message_times (M,), odom_poses (M, 3))``: seconds and T_odom_base ``(x, y, yaw)``.
        """
        t = np.asarray(times, dtype=np.float64)
        p = np.asarray(poses, dtype=np.float64)
        if t.ndim != 1 or t.size < 1 or p.shape != (t.size, 3):
            raise ValueError(f"times must be (N,) and poses (N, 3) with N >= 1, got {t.shape} and {p.shape}")
        if not (np.isfinite(t).all() and np.isfinite(p).all()):
            raise ValueError("times and poses must be finite")
        if (np.diff(t) <= 0.0).any():
            raise ValueError("times must be strictly increasing")
        count = math.floor((t[-1] - t[0]) * self.rate_hz + 1e-9)
        stamps = t[0] + np.arange(1, count + 1, dtype=np.float64) / self.rate_hz
        stamps = np.minimum(stamps, t[-1])
        yaw = np.unwrap(p[:, 2])
        xs = np.interp(stamps, t, p[:, 0])
        ys = np.interp(stamps, t, p[:, 1])
        yaws = np.interp(stamps, t, yaw)
        self.reset()
        self.update((float(p[0, 0]), float(p[0, 1]), float(p[0, 2])))
        out = np.empty((count, 3), dtype=np.float64)
        for k in range(count):
            out[k] = self.update((float(xs[k]), float(ys[k]), float(yaws[k])))
        return stamps, out
