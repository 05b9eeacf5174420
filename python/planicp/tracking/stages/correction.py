"""Stage 6 of `Localizer.update`: the pose and covariance after an accepted fit (`correct`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..decisions import Correction, Prediction, ScoreDecision, SearchDecision
from ..degeneracy_rule import fuse_along_weak_axis
from .rules import Rules


def correct(prediction: Prediction, search: SearchDecision, score: ScoreDecision, rules: Rules) -> Correction:
    """The pose and covariance after an accepted fit: its fusion with the prediction; after an
    odometry fault (not fused) or a search, the fit alone, except along a degenerate axis, where
    the prediction is corrected only as far as the variances say. Without an accepted fit, the
    prediction's."""
    result = search.result
    if result is None or score.reason != "":
        return Correction(prediction.pose, prediction.covariance, False, None, "prediction")
    degeneracy = rules.degeneracy.check(result)
    fused = None if search.searched else rules.fusion.fuse(result, prediction.pose, prediction.covariance)
    if fused is not None:
        return Correction(fused[0], fused[1], True, degeneracy, "fused")
    if degeneracy is not None:
        pose, covariance = fuse_along_weak_axis(degeneracy, result, prediction.pose, prediction.covariance)
        return Correction(pose, covariance, True, degeneracy, "weak_axis")
    return Correction(result.pose, finite_or(result.covariance, prediction.covariance), True, None, "fit")


def finite_or(covariance: NDArray[np.float64], fallback: NDArray[np.float64]) -> NDArray[np.float64]:
    """`covariance` as float64 when it is finite, else `fallback`."""
    cov = np.asarray(covariance, dtype=np.float64)
    return cov.copy() if np.isfinite(cov).all() else fallback
