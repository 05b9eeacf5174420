"""Stage 6 of `Localizer.update`: the pose and covariance after an accepted fit (`correct`), the
pose refined to the highest posterior in the plan's likelihood field (`posterior_refinement`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..._validation import Pose
from ..decisions import Correction, Prediction, ScoreDecision, SearchDecision
from ..degeneracy_rule import fuse_along_weak_axis
from ..icp_result import IcpResult
from ..odometry_fault import mixture_modes
from ..posterior_refinement import refine_pose
from .rules import Rules


def correct(
    points: NDArray[np.float64], prediction: Prediction, search: SearchDecision, score: ScoreDecision, rules: Rules
) -> Correction:
    """The pose and covariance after an accepted fit: its fusion with the prediction; after an
    odometry fault (not fused) or a search, the fit alone, except along a degenerate axis, where
    the prediction is corrected only as far as the variances say; but a fit that disagrees with
    the prediction and explains the scan far worse than the track's scans are explained is taken
    for a corrupted scan and refused (`_corrupted_scan`). Without an accepted fit, the
    prediction's. A pose from a fit from the prediction is then refined to the pose of highest
    posterior in the plan's likelihood field (`posterior_refinement`): with the prediction as
    the prior where the two were fused or the fit is degenerate, none where the odometry faulted
    and the scan constrains every direction; a search's place is kept as its alignment left it.
    The covariance is the fusion's, widened by the spread of the posterior's two modes where the
    refinement found two."""
    result = search.result
    if result is None or score.reason != "":
        return Correction(prediction.pose, prediction.covariance, False, None, "prediction")
    degeneracy = rules.degeneracy.check(result)
    fused = None if search.searched else rules.fusion.fuse(result, prediction.pose, prediction.covariance)
    if fused is not None:
        correction = Correction(fused[0], fused[1], True, degeneracy, "fused")
        return _refined(points, correction, ("prediction", prediction.pose, prediction.covariance), rules)
    refused = "" if search.searched else _corrupted_scan(search)
    if refused:
        return Correction(prediction.pose, prediction.covariance, False, None, "prediction", refused=refused)
    if degeneracy is not None:
        pose, covariance = fuse_along_weak_axis(degeneracy, result, prediction.pose, prediction.covariance)
        correction = Correction(pose, covariance, True, degeneracy, "weak_axis")
        # Along the weak axis the scan says nothing, and the prediction is what is known there.
        prior: tuple[str, Pose, NDArray[np.float64]] | None = ("prediction", prediction.pose, prediction.covariance)
    else:
        covariance = finite_or(result.covariance, prediction.covariance)
        correction = Correction(result.pose, covariance, True, None, "fit")
        if not search.searched:
            return _fault_or_prediction(points, correction, prediction, result, score, rules)
        prior = None
    return correction if search.searched else _refined(points, correction, prior, rules)


def _fault_or_prediction(
    points: NDArray[np.float64],
    fit: Correction,
    prediction: Prediction,
    result: IcpResult,
    score: ScoreDecision,
    rules: Rules,
) -> Correction:
    """A fit from the prediction that disagrees with it beyond their covariances (`fit`, not
    degenerate) weighed as the max-mixture motion model weighs it: either the odometry faulted,
    and the prediction is no evidence (the scan's likelihood alone, climbed from the fit, at the
    fault cost `F`), or it did not, and the pose is the mode of the scan's likelihood times the
    prediction's Gaussian, climbed from the prediction. The one of lower cost is taken. On
    freiburg-campus (odometry seed 7) three fits 0.3-0.4 m from a sound prediction were taken alone
    for one scan each, at costs 11 units below the prediction's mode, less than `F` (13.8): single
    scans whose walls the map drew twice. Without the refinement's field and its fault component,
    the fit alone, refined with no prior, when it is sound (it passes the gate's and the lost
    rule's bars as set, as a scan must to teach the bars anything, `keep_records`); a fit that
    passes only the bars relaxed to what this plan's fits explain keeps a track, but is no
    evidence that the odometry faulted, and the prediction is kept (in a crowd of 30 people on
    the shipped plan, 71 % of the returns blocked, a fit 19 cm from a sound prediction that
    explained 29 % of its scan was taken alone for two scans)."""
    refinement = rules.refinement
    if not refinement.weighs_faults:
        if not rules.passes_as_set(result, score.score):
            return Correction(
                prediction.pose,
                prediction.covariance,
                False,
                None,
                "prediction",
                refused="it disagrees with the prediction beyond their covariances and passes only the bars "
                "relaxed to what this plan's fits explain: no evidence of an odometry fault",
            )
        return _refined(points, fit, None, rules)
    modes = mixture_modes(points, fit.pose, prediction.pose, prediction.covariance, rules.plan, refinement)
    if modes.fault_preferred:
        return replace(fit, pose=modes.faulted.pose, refinement=modes.faulted)
    held = modes.held
    return Correction(held.pose, prediction.covariance, True, None, "prediction_mode", refinement=held)


def _corrupted_scan(search: SearchDecision) -> str:
    """Why a fit from the prediction that disagrees with it beyond their covariances is no
    evidence ("" when it is evidence). Either the odometry faulted, and the fit is right, or the
    scan is corrupted (turned, shifted, a reflection) and the fit is wherever part of it happens
    to match. An odometry fault leaves the scan explained as the track's scans are; a fit whose
    cost in the likelihood field exceeds the track's typical cost by the fault cost (the sweep
    for a fault ran, `SearchDecision.fault`, and found no place that explains the scan as usual)
    explains it far worse, which a corrupted scan does and a sound fit does not (on the real
    logs' maps one scan in five turned by 30 or 90 degrees was taken this way, 43-51 cm from the
    prediction). The update then keeps the prediction, as for a fit the gate rejects. (Only an
    accepted fit gets here, so the sweep judged the fit's cost, not the prediction's.)"""
    sweep = search.fault
    if sweep is None or sweep.more_probable:
        return ""
    return (
        f"it disagrees with the prediction beyond their covariances and explains the scan far worse than "
        f"the track's scans (cost {sweep.current_cost:.1f} against a typical {sweep.typical:.1f}): a corrupted "
        "scan more likely than an odometry fault"
    )


def _refined(
    points: NDArray[np.float64],
    correction: Correction,
    prior: tuple[str, Pose, NDArray[np.float64]] | None,
    rules: Rules,
) -> Correction:
    """`correction` with its pose refined (`refine_pose`; `prior`: its name, pose and covariance,
    or None) when the rule is on, and the spread of the posterior's two modes, where it has two,
    added to its covariance."""
    if not rules.refinement.enabled:
        return correction
    refinement = refine_pose(points, correction.pose, rules.plan, prior, rules.refinement)
    covariance = correction.covariance + refinement.spread
    return replace(correction, pose=refinement.pose, covariance=covariance, refinement=refinement)


def finite_or(covariance: NDArray[np.float64], fallback: NDArray[np.float64]) -> NDArray[np.float64]:
    """`covariance` as float64 when it is finite, else `fallback`."""
    cov = np.asarray(covariance, dtype=np.float64)
    return cov.copy() if np.isfinite(cov).all() else fallback
