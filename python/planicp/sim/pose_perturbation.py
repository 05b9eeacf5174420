"""A pose offset by a given distance and angle in random directions: the guess an alignment starts from
in tests and benchmarks."""

from __future__ import annotations

import math

import numpy as np

from ..se2 import wrap_angle
from .argument_checks import finite_float, pose_arg

__all__ = ["perturb_pose"]


def perturb_pose(
    pose: tuple[float, float, float], rng: np.random.Generator, translation: float, rotation: float
) -> tuple[float, float, float]:
    """``pose`` offset by exactly ``translation`` metres in a uniformly random direction and by
    ``+rotation`` or ``-rotation`` radians (random sign). The yaw is wrapped to ``[-pi, pi)``."""
    x, y, yaw = pose_arg(pose)
    translation = finite_float(translation, "translation")
    rotation = finite_float(rotation, "rotation")
    if translation < 0.0 or rotation < 0.0:
        raise ValueError(f"translation and rotation must be >= 0, got {translation} and {rotation}")
    phi = float(rng.uniform(-math.pi, math.pi))
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return (
        x + translation * math.cos(phi),
        y + translation * math.sin(phi),
        wrap_angle(yaw + sign * rotation),
    )
