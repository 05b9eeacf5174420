"""Brute-force geometry used by several test files as an independent reference."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def nearest_distance(
    queries: NDArray[np.float64], points: NDArray[np.float64], chunk: int = 1024
) -> NDArray[np.float64]:
    """Distance from each query to its nearest point (brute force, in chunks)."""
    out = np.empty(len(queries))
    for i in range(0, len(queries), chunk):
        q = queries[i : i + chunk]
        d2 = ((q[:, None, :] - points[None, :, :]) ** 2).sum(axis=2)
        out[i : i + chunk] = np.sqrt(d2.min(axis=1))
    return out
