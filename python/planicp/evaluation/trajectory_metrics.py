"""Errors of a trajectory against a reference trajectory, as evaluation tools report them.

Both are (N, 3) map-frame poses (x, y, yaw: metres, radians) at the same N times; rows where the
reference is NaN (no reference for that scan) are left out. No alignment or scale correction is
applied: both trajectories are already in the plan's frame (as `evo_ape ... -r trans_part` without
`--align` or `-s`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..se2 import wrap_angles

LOST_THRESHOLD_M = 0.3
"""A pose farther than this from the reference counts as lost (metres)."""


def pose_errors(
    poses: NDArray[np.float64], reference: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(position error in metres, signed heading error in radians) per row; NaN where the reference
    (or the pose) is NaN.

    Raises:
        ValueError: the arrays are not both (N, 3).
    """
    p = np.asarray(poses, dtype=np.float64)
    r = np.asarray(reference, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape != r.shape:
        raise ValueError(f"poses and reference must both be (N, 3), got {p.shape} and {r.shape}")
    position = np.hypot(p[:, 0] - r[:, 0], p[:, 1] - r[:, 1])
    heading = wrap_angles(p[:, 2] - r[:, 2])
    return position, heading


def error_summary(
    poses: NDArray[np.float64], reference: NDArray[np.float64], lost_threshold: float = LOST_THRESHOLD_M
) -> dict[str, float]:
    """Translation ATE (RMS), worst and final position error, heading RMS and worst, and the share of
    poses farther than `lost_threshold` metres, over the rows that have a reference.

    Raises:
        ValueError: wrong shapes, or no row with both a pose and a reference.
    """
    position, heading = pose_errors(poses, reference)
    valid = np.isfinite(position) & np.isfinite(heading)
    if not valid.any():
        raise ValueError("no pose has a reference to compare with")
    pos, yaw = position[valid], heading[valid]
    return {
        "ate_rms_m": float(np.sqrt(np.mean(pos**2))),
        "position_max_m": float(pos.max()),
        "position_final_m": float(pos[-1]),
        "heading_rms_deg": math.degrees(float(np.sqrt(np.mean(yaw**2)))),
        "heading_max_deg": math.degrees(float(np.abs(yaw).max())),
        "lost_share": float(np.mean(pos > lost_threshold)),
        "compared_poses": float(valid.sum()),
    }
