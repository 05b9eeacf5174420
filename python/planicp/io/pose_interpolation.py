"""Odometry at arbitrary times: linear in position, along the shorter arc in yaw."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def interpolate_poses(
    times: NDArray[np.float64], poses: NDArray[np.float64], query: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Poses of a time-stamped stream at the `query` times.

    x and y are interpolated linearly; yaw along the shorter arc between the two neighbouring
    samples (so 3.1 and -3.1 rad meet at pi, not at 0), then wrapped to (-pi, pi]. A query equal
    to a sample time returns that sample. Queries outside [times[0], times[-1]] get NaN rows.

    Args:
        times: (K,) non-decreasing seconds, K >= 1. Repeated times are allowed (the later sample wins).
        poses: (K, 3) x, y, yaw (metres, radians).
        query: (Q,) seconds.

    Returns:
        ((Q, 3) poses, (Q,) mask of the queries inside the stream's time span).
    """
    t = np.asarray(times, dtype=np.float64)
    p = np.asarray(poses, dtype=np.float64)
    q = np.asarray(query, dtype=np.float64)
    if t.ndim != 1 or p.shape != (t.shape[0], 3):
        raise ValueError(f"need times (K,) and poses (K, 3), got {t.shape} and {p.shape}")
    if q.ndim != 1:
        raise ValueError(f"query must be (Q,), got shape {q.shape}")
    out = np.full((q.shape[0], 3), np.nan)
    if t.shape[0] == 0:
        return out, np.zeros(q.shape[0], dtype=bool)
    if np.any(np.diff(t) < 0.0) or not np.all(np.isfinite(t)):
        raise ValueError("odometry times must be finite and non-decreasing")
    inside = (q >= t[0]) & (q <= t[-1])
    qi = q[inside]
    # Index of the last sample at or before each query, kept one short of the end so hi exists.
    hi = np.clip(np.searchsorted(t, qi, side="right"), 1, max(t.shape[0] - 1, 1))
    lo = hi - 1
    if t.shape[0] == 1:
        out[inside] = p[0]
        return out, inside
    span = t[hi] - t[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(span > 0.0, (qi - t[lo]) / span, 1.0)
    w = np.clip(w, 0.0, 1.0)
    xy = p[lo, :2] + w[:, None] * (p[hi, :2] - p[lo, :2])
    dyaw = np.angle(np.exp(1j * (p[hi, 2] - p[lo, 2])))
    yaw = np.angle(np.exp(1j * (p[lo, 2] + w * dyaw)))
    out[inside, :2] = xy
    out[inside, 2] = yaw
    return out, inside
