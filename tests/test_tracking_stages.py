"""The stages of `Localizer.update` one by one (`planicp.tracking.stages`), each with real scans of
a synthetic office, and the decisions an `Estimate` lists."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from planicp import (
    AcceptanceGate,
    IcpConfig,
    Localizer,
    LostRule,
    MotionNoise,
    PlanMap,
    PosteriorRefinement,
    RecoveryConfig,
    localize,
    se2,
)
from planicp.plans.default_plan import load_default_plan
from planicp.sim.crowd import Crowd, crowded_scans
from planicp.sim.experiment import ExperimentConfig, run_experiment
from planicp.sim.world import Furnishing
from planicp.tracking import stages
from planicp.tracking.decisions import (
    Bookkeeping,
    Correction,
    FitDecision,
    LeftPlace,
    LeftPlaceDecision,
    LostDecision,
    PendingDecision,
    PendingPlace,
    Prediction,
    RecoveryDecision,
    ScoreDecision,
    SearchDecision,
)
from planicp.tracking.fusion_rule import CHI2_3_999
from planicp.tracking.lost_rule import LostDetector
from planicp.tracking.occlusion_rule import OcclusionFilter, OcclusionRule
from planicp.tracking.odometry_fault import CostHistory, FaultSweep, fault_cost, scan_cost
from planicp.tracking.posterior_refinement import refine_pose
from planicp.tracking.recovery import Recovery, SearchBudget

# The synthetic office, its drive and scans: the module fixtures of test_localizer.py.
from test_localizer import DEG, error, office, path, plan, scans  # noqa: F401

Pose = tuple[float, float, float]
SMALL = np.diag([0.02**2, 0.02**2, (1 * DEG) ** 2])


def rules(plan: PlanMap, **changes: Any) -> stages.Rules:
    """The rules of a default `Localizer` on `plan`, with `changes`."""
    return Localizer(plan, (0.0, 0.0, 0.0), **changes)._rules()


def prediction_at(pose: Pose, covariance: np.ndarray = SMALL) -> Prediction:
    return Prediction((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), pose, covariance, True)


def search_stage(
    points: np.ndarray, prediction: Prediction, fit: FitDecision, the_rules: stages.Rules, history: Any = None
) -> SearchDecision:
    """The search stage with no place pending, not lost, an unbounded budget and `history`
    (None: an empty `CostHistory`)."""
    return stages.search_near_prediction(
        points,
        prediction,
        fit,
        PendingDecision(None, None),
        the_rules,
        False,
        SearchBudget(None),
        CostHistory() if history is None else history,
    )


def test_the_prediction_composes_the_odometry_motion_and_grows_the_covariance() -> None:
    a, b = 0.01, 0.002
    covariance = np.diag([a, a, b])
    prediction = stages.predict(
        (2.0, 3.0, math.pi / 2), covariance, (5.0, 5.0, 0.0), (6.0, 5.0, math.pi / 2), MotionNoise()
    )
    assert not prediction.first
    np.testing.assert_allclose(prediction.motion, (1.0, 0.0, math.pi / 2), atol=1e-15)
    np.testing.assert_allclose(prediction.pose, (2.0, 4.0, math.pi), atol=1e-12)
    # Heading pi/2 and 1 m forward: the heading's variance b moves x by -1 m per radian; the
    # motion's own noise is 5 % of 1 m + 1 mm in x and y, 5 % of 90 deg + 1 deg + 0.05 deg in yaw.
    sigma_t = 0.05 * 1.0 + 0.001
    sigma_r = 0.05 * math.pi / 2 + math.radians(1.0) + math.radians(0.05)
    expected = np.array([[a + b + sigma_t**2, 0.0, -b], [0.0, a + sigma_t**2, 0.0], [-b, 0.0, b + sigma_r**2]])
    np.testing.assert_allclose(prediction.covariance, expected, rtol=1e-12, atol=1e-15)
    assert np.linalg.det(prediction.covariance) > np.linalg.det(covariance)
    first = stages.predict((2.0, 3.0, 0.5), covariance, None, (6.0, 5.0, 1.0), MotionNoise())
    assert first.first and first.motion == (0.0, 0.0, 0.0) and first.pose == (2.0, 3.0, 0.5)


def test_the_fit_stage_gives_the_gates_reason_for_a_prediction_beyond_the_jump_limit(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    off = se2.compose(path[1], (0.25, 0.0, 0.0))
    strict = rules(plan, gate=AcceptanceGate(max_translation_jump=0.1))
    fit = stages.fit_from_prediction(scans[1], prediction_at(off), strict, False)
    assert fit.usable and fit.result is not None and not fit.passed
    assert error(path[1], fit.result.pose)[0] < 0.05  # ICP found the truth...
    assert fit.reason.startswith("correction of 0.2") and fit.reason.endswith(" m exceeds 0.100 m"), fit.reason
    same = stages.fit_from_prediction(scans[1], prediction_at(off), rules(plan), False)
    assert same.passed and same.reason == ""  # ...which the default 0.5 m limit accepts
    tiny = stages.fit_from_prediction(scans[1][:2], prediction_at(path[1]), rules(plan), False)
    assert tiny.result is None and not tiny.usable and tiny.reason == "scan has 2 usable points (need 3)"


def test_the_occlusion_rule_is_tried_from_an_uncertain_prediction_when_the_fit_of_every_return_is_rejected(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A crowd round the robot from its first scan (the `Localizer`'s first prediction is 10 cm
    uncertain, too much for the rule at once): four in five beams blocked at 30-60 % of their
    range. The fit of every return is rejected; the rule, tried with its margin widened to 3 sigma,
    keeps the rest and the fit of those passes. After an odometry fault nothing is kept."""
    truth = path[1]
    scan = scans[1]
    rng = np.random.default_rng(5)
    blocked = rng.random(len(scan)) < 0.8
    crowded = scan.copy()
    crowded[blocked] *= rng.uniform(0.3, 0.6, size=(int(blocked.sum()), 1))
    uncertain = np.diag([0.1**2, 0.1**2, (5 * DEG) ** 2])
    the_rules = rules(plan)
    plain = stages.fit_from_prediction(crowded, prediction_at(truth, uncertain), rules(plan, occlusion=False), False)
    assert plain.result is not None and not plain.passed and "inlier ratio" in plain.reason
    fit = stages.fit_from_prediction(crowded, prediction_at(truth, uncertain), the_rules, False)
    assert fit.passed and fit.kept is not None and fit.result is not None
    assert np.count_nonzero(fit.kept & blocked) < 0.05 * blocked.sum()  # the crowd is left out...
    certain = stages.fit_from_prediction(crowded, prediction_at(truth), the_rules, False)
    assert certain.kept is not None  # ...the walls kept, as from a certain prediction (not the furniture)
    assert np.count_nonzero(fit.kept & ~blocked) >= np.count_nonzero(certain.kept & ~blocked) > 100
    assert error(truth, fit.result.pose)[0] < 0.02
    # Not while lost, and not where the fit of every return passes: one alignment.
    assert stages.fit_from_prediction(crowded, prediction_at(truth, uncertain), the_rules, True).kept is None
    clean = stages.fit_from_prediction(scan, prediction_at(truth, uncertain), the_rules, False)
    assert clean.passed and clean.kept is None
    # The odometry turned 30 degrees more than the robot: the returns on the walls look short of
    # them from the prediction, and the rest do not fit it soundly.
    turned = se2.compose(truth, (0.0, 0.0, 30 * DEG))
    faulted = stages.fit_from_prediction(scan, prediction_at(turned, uncertain), the_rules, False)
    assert not faulted.passed and faulted.kept is None


def test_the_score_counts_the_returns_the_occlusion_rule_left_out_as_unexplained(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    truth = path[0]
    clutter = np.column_stack([np.full(100, 0.4), np.linspace(-0.2, 0.2, 100)])  # a person 40 cm ahead
    points = np.vstack([scans[0], clutter])
    the_rules = rules(plan)
    fit = stages.fit_from_prediction(points, prediction_at(truth), the_rules, False)
    assert fit.passed and fit.kept is not None and fit.beyond is not None and fit.result is not None
    assert not fit.kept[-100:].any()  # the person is left out
    search = search_stage(points, prediction_at(truth), fit, the_rules)
    assert search.cause is None and search.result is fit.result and not search.searched
    score = stages.judge_score(points, prediction_at(truth), fit, search, the_rules, False, None)
    inliers = np.zeros(len(points), dtype=bool)
    inliers[fit.kept] = fit.result.inlier_mask
    assert score.score == np.count_nonzero(inliers & ~fit.beyond) / len(points)
    assert score.score <= np.count_nonzero(fit.kept) / len(points) <= (len(points) - 100) / len(points)
    assert score.score < fit.result.inlier_ratio - 0.1  # the ratio over the kept points alone is higher
    assert not score.poor and score.continues is None and score.reason == ""


def test_a_scan_that_hides_nearly_every_wall_says_nothing_even_where_its_fit_slides() -> None:
    """The crowd bench's fifth drive with 50 people, scan 180, from the true pose: 98 % of the
    beams blocked, the occlusion rule keeps fewer returns than it needs, every return is aligned,
    and that fit slides 5.5 cm onto the people, more than a quarter of the rule's margin.
    Aligning every return again would be the same fit; the scan is still one that hides the
    walls, and is held as a crowd's (taken as a rejection, it made the track lost there with its
    pose right, and lost, a fit on the people later took it 67 cm off)."""
    plan = load_default_plan()
    config = ExperimentConfig(duration_s=30.0, seed=5, furnishing=Furnishing(0, 0, 0, 0))
    recording, world = run_experiment(plan, config)
    scans, blocked = crowded_scans(recording, world.floor, config.lidar, Crowd(50), seed=5)
    truth = tuple(float(v) for v in recording.truth[180])
    assert blocked[180] > 0.97
    the_rules = rules(plan)
    fit = stages.fit_from_prediction(scans[180], prediction_at(truth), the_rules, False)
    assert fit.result is not None and fit.kept is None and fit.beyond is not None
    assert math.dist(fit.result.pose[:2], truth[:2]) > the_rules.occlusion.rule.margin / 4.0  # slid
    assert fit.occluded and not fit.realigned and not fit.passed
    search = SearchDecision(None, None, fit.result, fit.reason, False)
    score = stages.judge_score(scans[180], prediction_at(truth), fit, search, the_rules, False, None)
    assert score.poor and score.continues is True


def test_a_crowd_scan_between_the_learned_and_the_set_bar_is_held_not_counted(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """Seven in ten beams blocked by people: the plan explains under the lost rule's 0.35 as set
    but above the bar learned on a patchy plan, so the scan is not poor; the plan explains the
    returns the occlusion rule kept, and the scan is held as a crowd rather than counted with its
    score (which would put the track in doubt, the whole plan searched beside it)."""
    truth = path[1]
    rng = np.random.default_rng(3)
    blocked = rng.random(len(scans[1])) < 0.7
    crowded = scans[1].copy()
    crowded[blocked] *= rng.uniform(0.3, 0.6, size=(int(blocked.sum()), 1))
    relaxed = on_a_patchy_map(plan, path[0])._rules()
    fit = stages.fit_from_prediction(crowded, prediction_at(truth), relaxed, False)
    assert fit.passed and fit.kept is not None and fit.result is not None and fit.result.inlier_ratio > 0.9
    search = SearchDecision(None, None, fit.result, "", False)
    score = stages.judge_score(crowded, prediction_at(truth), fit, search, relaxed, False, None)
    assert relaxed.lost.min_score < score.score < relaxed.lost_as_set.min_score
    assert not score.poor and score.continues is True and score.reason == ""
    assert stages.judge_score(crowded, prediction_at(truth), fit, search, relaxed, True, None).continues is None
    clean = stages.fit_from_prediction(scans[1], prediction_at(truth), relaxed, False)
    clean_search = SearchDecision(None, None, clean.result, "", False)
    clean_score = stages.judge_score(scans[1], prediction_at(truth), clean, clean_search, relaxed, False, None)
    assert clean_score.score > relaxed.lost_as_set.min_score and clean_score.continues is None


def test_on_a_slam_map_the_score_does_not_count_returns_beyond_a_cell_the_beams_passed(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray], tmp_path: Any
) -> None:
    # A post the map's scans saw, 0.45 m ahead of the robot, that this scan's beams pass (it was
    # seen from elsewhere, or has gone): a SLAM map marks it as the walls, cells where returns ended.
    truth = path[0]
    clear = stages.fit_from_prediction(scans[0], prediction_at(truth), rules(plan), False)
    assert clear.beyond is not None and np.count_nonzero(clear.beyond) < 5  # without the post
    offsets = np.stack(np.meshgrid(np.arange(3) * 0.05, np.arange(3) * 0.05), axis=-1).reshape(-1, 2)
    local = offsets + np.array([0.4, -0.05])
    c, s_ = math.cos(truth[2]), math.sin(truth[2])
    post = local @ np.array([[c, s_], [-s_, c]]) + np.array(truth[:2])
    points = np.vstack([plan.points, post])
    drawn = PlanMap.from_points(points)
    slam = PlanMap.from_ros_map(drawn.to_ros_map(tmp_path / "slam.yaml", resolution=0.05), cache=False)
    assert slam.cells_mark_returns and not drawn.cells_mark_returns
    scores = {}
    for name, map_ in (("drawn", drawn), ("slam", slam)):
        the_rules = rules(map_)
        fit = stages.fit_from_prediction(scans[0], prediction_at(truth), the_rules, False)
        assert fit.passed and fit.beyond is not None and fit.result is not None
        assert error(truth, fit.result.pose)[0] < 0.05  # the SLAM map is the plan in 5 cm cells
        # The cast stops at the post (21 degrees of the scan) and hides the wall behind it.
        assert 40 <= np.count_nonzero(fit.beyond) < 200
        search = search_stage(scans[0], prediction_at(truth), fit, the_rules)
        score = stages.judge_score(scans[0], prediction_at(truth), fit, search, the_rules, False, None)
        inliers = np.zeros(len(scans[0]), dtype=bool)
        if fit.kept is None:
            inliers[:] = fit.result.inlier_mask
        else:
            inliers[fit.kept] = fit.result.inlier_mask
        beyond = fit.beyond if name == "drawn" else np.zeros(len(scans[0]), dtype=bool)
        assert score.score == np.count_nonzero(inliers & ~beyond) / len(scans[0])
        scores[name] = score.score
    # A drawn post stops every beam: returns behind it are evidence against the pose. The SLAM
    # map's cell is not: the score is the fit's own.
    assert scores["drawn"] < scores["slam"] - 0.01


def test_the_correction_fuses_the_fit_and_shrinks_the_covariance(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    the_rules = rules(plan)
    wide = np.diag([0.05**2, 0.05**2, (2 * DEG) ** 2])
    prediction = prediction_at(se2.compose(path[2], (0.04, -0.03, 1 * DEG)), wide)
    fit = stages.fit_from_prediction(scans[2], prediction, the_rules, False)
    search = search_stage(scans[2], prediction, fit, the_rules)
    score = stages.judge_score(scans[2], prediction, fit, search, the_rules, False, None)
    correction = stages.correct(scans[2], prediction, search, score, the_rules)
    assert correction.accepted and correction.kind == "fused" and correction.degeneracy is None
    assert error(path[2], correction.pose)[0] < 0.01
    assert np.trace(correction.covariance) < np.trace(prediction.covariance) / 10
    assert np.linalg.det(correction.covariance) < np.linalg.det(prediction.covariance)
    rejected = ScoreDecision(score.score, False, None, "some reason")
    kept = stages.correct(scans[2], prediction, search, rejected, the_rules)
    assert not kept.accepted and kept.kind == "prediction" and kept.pose == prediction.pose
    assert kept.covariance is prediction.covariance


def test_a_fit_beyond_the_prediction_is_used_alone_unless_the_scan_is_far_worse_explained_than_usual(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # The odometry strayed 15 cm beyond a 2 cm deviation; ICP still finds the true pose: the two
    # disagree beyond their covariances, and the fit is taken alone (an odometry fault).
    the_rules = rules(plan)
    truth = path[20]
    prediction = prediction_at(se2.compose(truth, (0.15, 0.0, 0.0)))
    fit = stages.fit_from_prediction(scans[20], prediction, the_rules, False)
    assert fit.result is not None and fit.reason == "" and error(truth, fit.result.pose)[0] < 0.01
    search = SearchDecision(None, None, fit.result, "", False)
    score = stages.judge_score(scans[20], prediction, fit, search, the_rules, False, None)
    assert score.reason == ""
    alone = stages.correct(scans[20], prediction, search, score, the_rules)
    assert alone.accepted and alone.kind == "fit" and alone.refused == ""
    assert error(truth, alone.pose)[0] < 0.01
    # On a plan whose fits explain little (the bars relaxed below 0.2), the same fit with a scan
    # the plan explains 20 % of passes the relaxed bars only: it keeps a track, but is no
    # evidence that the odometry faulted, and the prediction stays.
    relaxed = on_a_patchy_map(plan, path[0])._rules()
    assert relaxed.lost.min_score < 0.2 < relaxed.lost_as_set.min_score
    little = ScoreDecision(0.2, False, None, "")
    kept = stages.correct(scans[20], prediction, search, little, relaxed)
    assert not kept.accepted and kept.kind == "prediction" and kept.pose == prediction.pose
    assert kept.refused.endswith(
        "passes only the bars relaxed to what this plan's fits explain: no evidence of an odometry fault"
    )
    assert stages.correct(scans[20], prediction, search, score, relaxed).kind == "fit"  # a sound scan: the fault
    # The same fit when the scan's cost there exceeds the track's typical cost by the fault cost
    # and the sweep found no place that explains it as usual: a corrupted scan is the likelier
    # cause, and the update keeps the prediction.
    sweep = FaultSweep(truth, cost=30.0, current_cost=40.0, typical=3.0, threshold=13.8)
    assert not sweep.more_probable
    corrupted = stages.correct(scans[20], prediction, replace(search, fault=sweep), score, the_rules)
    assert not corrupted.accepted and corrupted.kind == "prediction" and corrupted.pose == prediction.pose
    assert corrupted.refused.startswith("it disagrees with the prediction beyond their covariances")
    assert "(cost 40.0 against a typical 3.0): a corrupted scan" in corrupted.why
    # A fit fused with the prediction (the two agree) is never refused this way.
    wide = prediction_at(prediction.pose, np.diag([0.2**2, 0.2**2, (2 * DEG) ** 2]))
    fused = stages.correct(scans[20], wide, replace(search, fault=sweep), score, the_rules)
    assert fused.accepted and fused.kind == "fused" and fused.refused == ""


def test_a_fit_beyond_the_prediction_is_weighed_against_the_predictions_mode_by_the_fault_cost(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """With the likelihood field and its fault component (a SLAM map's default), a fit that
    disagrees with the prediction beyond their covariances is taken alone only where the scan
    prefers it to the prediction's surroundings by the fault cost (the max-mixture motion model);
    otherwise the pose is the mode of the scan's likelihood times the prediction's Gaussian."""
    the_rules = rules(plan, refinement=PosteriorRefinement(enabled=True))
    threshold = fault_cost(the_rules.refinement.fault_probability)
    truth = path[20]
    # The odometry strayed 15 cm beyond a 2 cm deviation, and ICP finds the true pose: the scan
    # explains it far better than anything near the prediction, and the fit is taken alone.
    strayed = prediction_at(se2.compose(truth, (0.15, 0.0, 0.0)))
    fit = stages.fit_from_prediction(scans[20], strayed, the_rules, False)
    assert fit.result is not None and fit.reason == ""
    search = SearchDecision(None, None, fit.result, "", False)
    score = stages.judge_score(scans[20], strayed, fit, search, the_rules, False, None)
    alone = stages.correct(scans[20], strayed, search, score, the_rules)
    assert alone.accepted and alone.kind == "fit" and error(truth, alone.pose)[0] < 0.01
    assert alone.refinement is not None and alone.refinement.prior == "none"
    # A sound prediction and a fit 25 cm from it, as ICP leaves where a SLAM map drew a wall
    # twice: the scan prefers the prediction's surroundings, and the pose stays there.
    sound = prediction_at(truth)
    off = replace(fit.result, pose=se2.compose(truth, (0.0, 0.25, 0.0)))
    search = SearchDecision(None, None, off, "", False)
    assert the_rules.fusion.fuse(off, sound.pose, sound.covariance) is None  # beyond their covariances
    held = stages.correct(scans[20], sound, search, score, the_rules)
    assert held.accepted and held.kind == "prediction_mode" and error(truth, held.pose)[0] < 0.01
    assert held.refinement is not None and held.refinement.prior == "prediction"
    assert held.covariance is sound.covariance
    assert held.why.startswith("the fit disagrees with the prediction, but the scan does not prefer it")
    climbed = scan_cost(scans[20], off.pose, plan, the_rules.refinement)
    assert held.refinement.cost < climbed + threshold
    # Without the fault component the fit is taken alone, as on a drawn plan.
    plain = rules(plan, refinement=PosteriorRefinement(enabled=True, fault_probability=0.0))
    assert stages.correct(scans[20], sound, search, score, plain).kind == "fit"


def test_the_lost_stage_turns_lost_after_max_rejections_rejections(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    the_rules = rules(plan, gate=AcceptanceGate(max_translation_jump=0.1), lost_rule=LostRule(max_rejections=3))
    detector = LostDetector(the_rules.lost)
    prediction = prediction_at(se2.compose(path[1], (0.25, 0.0, 0.0)))
    fit = stages.fit_from_prediction(scans[1], prediction, the_rules, False)
    search = search_stage(scans[1], prediction, fit, the_rules)
    score = stages.judge_score(scans[1], prediction, fit, search, the_rules, False, None)
    correction = stages.correct(scans[1], prediction, search, score, the_rules)
    assert not correction.accepted and search.cause == "jump" and search.pending is not None
    verdicts = [stages.judge_lost(detector, score, correction, search, False, the_rules) for _ in range(3)]
    assert [(v.lost, v.rejections, v.held, v.counted_accepted) for v in verdicts] == [
        (False, 1, False, False),
        (False, 2, False, False),
        (True, 3, False, False),
    ]
    # Lost for the rejections alone: the score is above the rule's 0.35.
    assert verdicts[-1].window_score == pytest.approx(score.score) and score.score > 0.5
    clutter = ScoreDecision(0.1, True, True, "")
    held = stages.judge_lost(detector, clutter, correction, search, True, the_rules)
    assert held.held and held.lost and held.rejections == 3 and len(detector.scores) == 3


def test_a_lost_track_is_regained_by_a_fit_that_explains_as_much_as_the_recovery_asks_of_a_place(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # While lost, an accepted fit from the prediction ends the lost state only when it explains
    # as much of its scan as the recovery asks of a place (60 %): then the track is regained.
    the_rules = rules(plan)
    assert the_rules.recovery.min_inlier_ratio == 0.6
    detector = LostDetector(the_rules.lost)
    detector.declare_lost()
    search = SearchDecision(None, None, None, "", False)
    sound = Correction(path[0], SMALL, True, None, "fused")
    rejected = Correction(path[0], SMALL, False, None, "prediction")
    good, poor = ScoreDecision(0.8, False, None, ""), ScoreDecision(0.5, False, None, "")
    verdicts = [
        stages.judge_lost(detector, score, correction, search, True, the_rules)
        for score, correction in ((poor, sound), (good, rejected), (poor, sound))
    ]
    assert all(v.lost and not v.regained and not v.counted_accepted for v in verdicts)
    assert [v.rejections for v in verdicts] == [4, 5, 6]
    regained = stages.judge_lost(detector, good, sound, search, True, the_rules)
    assert not regained.lost and regained.regained and regained.counted_accepted and regained.rejections == 0
    assert "regained" in regained.why
    # Tracking, a scan counts as accepted as its fit was, and nothing is regained.
    verdict = stages.judge_lost(detector, poor, sound, search, False, the_rules)
    assert not verdict.lost and verdict.counted_accepted and not verdict.regained


def test_a_regained_track_is_on_trial_while_the_search_of_the_whole_plan_goes_on(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # Lost at a place 5 m and 115 degrees off: the recovery's searches begin. The track's own
    # fits then regain it there (a wrong place that explains the scans as well as the right one
    # cannot be told from it on its fits): it is on trial, the search of the whole plan goes on
    # beside it, and the place the scans fit replaces it.
    config = RecoveryConfig(confirmations=2, search_nodes=40_000, search_time=None, search_spare_time=None)
    icp = IcpConfig.for_tracking().replace(correspondence_search="kd_tree")
    recovery = Recovery(plan, config, icp, AcceptanceGate(), OcclusionFilter(plan, OcclusionRule()), MotionNoise())
    fit = FitDecision(None, None, None, False, "", usable=True)
    wrong = (path[0][0] + 4.0, path[0][1] - 3.0, path[0][2] + 2.0)
    lost = LostDecision(True, False, False, 0.2, 3)
    regained = LostDecision(False, False, True, 0.8, 0, regained=True)
    tracking = LostDecision(False, False, True, 0.8, 0)
    recovery.new_update()
    first = stages.recover(
        recovery, LostDetector(), scans[0], prediction_at(wrong), fit, idle_pose(prediction_at(wrong)), lost
    )
    assert first.action == "step" and recovery.searching
    wrong = se2.compose(wrong, se2.between(path[0], path[1]))
    decisions = tracked_at(recovery, path, scans, wrong, 1, [regained] + [tracking] * 10)
    assert all(d.action == "verify" for d in decisions) and decisions[0].on_trial
    adopted = decisions[-1].adopted
    assert adopted is not None, [d.why for d in decisions]
    assert error(path[len(decisions)], adopted.pose)[0] < 0.05
    # Regained when the whole plan's search has ended: nothing is left to weigh the track against.
    recovery.clear()
    sound = Correction(path[0], SMALL, True, None, "fused")
    ended = stages.recover(recovery, LostDetector(), scans[0], prediction_at(path[0]), fit, sound, regained)
    assert ended.action == "clear"
    assert not recovery.on_trial


def tracked_at(
    recovery: Recovery,
    path: list[Pose],
    scans: list[np.ndarray],
    wrong: Pose,
    first: int,
    verdicts: list[LostDecision],
) -> list[RecoveryDecision]:
    """The recovery stage's decisions while the localizer tracks `wrong` (T_map_base at scan
    `first`, moved by the path's steps after it) with the lost stage's verdict `verdicts[k]` at
    its k-th update, until the recovery adopts a place."""
    fit = FitDecision(None, None, None, False, "", usable=True)
    decisions: list[RecoveryDecision] = []
    for k, verdict in enumerate(verdicts):
        i = first + k
        if k > 0:
            wrong = se2.compose(wrong, se2.between(path[i - 1], path[i]))
        correction = Correction(wrong, SMALL, True, None, "fused")
        recovery.new_update()
        decisions.append(
            stages.recover(recovery, LostDetector(), scans[i], prediction_at(wrong), fit, correction, verdict)
        )
        if decisions[-1].adopted is not None:
            break
    return decisions


def idle_pose(prediction: Prediction) -> Correction:
    """The correction of an update without an accepted fit: the prediction's pose."""
    return Correction(prediction.pose, prediction.covariance, False, None, "prediction")


def test_the_recovery_stage_reports_the_place_it_adopts(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    config = RecoveryConfig(confirmations=2, search_nodes=None, search_time=None)  # each search within its update
    icp = IcpConfig.for_tracking().replace(correspondence_search="kd_tree")
    recovery = Recovery(plan, config, icp, AcceptanceGate(), OcclusionFilter(plan, OcclusionRule()), MotionNoise())
    detector = LostDetector(LostRule())
    detector.declare_lost()
    lost = LostDecision(True, False, False, math.nan, detector.rejections)
    fit = FitDecision(None, None, None, False, "", usable=True)
    wrong = (path[0][0] + 4.0, path[0][1] - 3.0, path[0][2] + 2.0)
    decisions = []
    for i in range(3):
        motion = (0.0, 0.0, 0.0) if i == 0 else se2.between(path[i - 1], path[i])
        prediction = Prediction((0.0, 0.0, 0.0), motion, wrong, SMALL, i == 0)
        decisions.append(stages.recover(recovery, detector, scans[i], prediction, fit, idle_pose(prediction), lost))
        if decisions[-1].adopted is not None:
            break
    assert [d.action for d in decisions] == ["step", "step"]
    assert decisions[0].adopted is None and len(decisions[0].hypotheses) >= 1
    adopted = decisions[-1].adopted
    assert adopted is not None and adopted.streak == 2
    assert error(path[1], adopted.pose)[0] < 0.05 and error(path[1], adopted.pose)[1] < 1 * DEG
    assert decisions[-1].covariance is not None and np.isfinite(decisions[-1].covariance).all()
    assert decisions[-1].hypotheses == () and detector.rejections == 0 and not detector.lost
    coasting = stages.recover(
        recovery,
        detector,
        scans[2],
        prediction,
        FitDecision(None, None, None, False, "x", usable=False),
        idle_pose(prediction),
        lost,
    )
    assert coasting.action == "coast" and coasting.adopted is None
    idle = stages.recover(
        recovery, detector, scans[2], prediction, fit, idle_pose(prediction), LostDecision(False, False, True, 1.0, 0)
    )
    assert idle.action == "clear" and idle.hypotheses == ()


def test_a_track_lost_where_the_scans_preferred_the_place_left_behind_is_searched_for_around_that_place(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # The track is 5 m off (a turned scan taken as a fault, then scans that fit nothing soundly);
    # the place it left behind is where the robot is. The search near the last pose (3 m) is
    # centred on that place, and finds the robot there.
    config = RecoveryConfig(search_nodes=None, search_time=None)
    icp = IcpConfig.for_tracking().replace(correspondence_search="kd_tree")
    lost = LostDecision(True, False, False, math.nan, 3)
    fit = FitDecision(None, None, None, False, "", usable=True)
    wrong = (path[0][0] + 4.0, path[0][1] - 3.0, path[0][2] + 2.0)
    prediction = Prediction((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), wrong, SMALL, True)

    def near_places(lost_at: Pose | None) -> tuple[Any, list[Pose]]:
        recovery = Recovery(plan, config, icp, AcceptanceGate(), OcclusionFilter(plan, OcclusionRule()), MotionNoise())
        decision = stages.recover(
            recovery, LostDetector(LostRule()), scans[0], prediction, fit, idle_pose(prediction), lost, lost_at
        )
        return decision, [h.pose for h in recovery.hypotheses if h.near]

    decision, near = near_places(path[0])
    assert decision.lost_at == path[0] and decision.why.startswith("lost where the scans preferred the place left")
    assert any(error(path[0], p)[0] < 0.05 for p in near)
    decision, near = near_places(None)
    assert decision.lost_at is None and decision.why.startswith("lost: the recovery follows")
    assert not any(error(path[0], p)[0] < 0.5 for p in near)


def test_the_search_near_a_lost_robot_covers_the_path_the_odometry_drove_from_where_track_was_lost(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # Lost at path[0] on a scan no place explains (a random cloud): the searches find nothing.
    # The robot then drives 4 m to path[40] while the pose coasting on a faulted odometry runs 9 m
    # off. The search near the robot, started again, covers 3 m plus the path driven around where
    # track was lost, and finds it; around the coasting pose it would not.
    config = RecoveryConfig(search_nodes=None, search_time=None)  # each search within its update
    icp = IcpConfig.for_tracking().replace(correspondence_search="kd_tree")
    recovery = Recovery(plan, config, icp, AcceptanceGate(), OcclusionFilter(plan, OcclusionRule()), MotionNoise())
    cloud = np.random.default_rng(3).uniform(-10.0, 10.0, size=(360, 2))
    assert recovery.step(cloud, (0.0, 0.0, 0.0), path[0]) is None and recovery.hypotheses == []
    motion = se2.between(path[0], path[40])
    driven = math.hypot(motion[0], motion[1])
    assert 3.9 < driven < 4.1 and math.dist(path[0][:2], path[40][:2]) > 3.9
    coasting = se2.compose(path[40], (9.0, 0.0, 1.2))
    recovery.step(scans[40], motion, coasting)
    near = [h.pose for h in recovery.hypotheses if h.near]
    assert any(error(path[40], p)[0] < 0.05 for p in near), near
    reach = config.local_radius + driven + 0.5  # the search's square, and ICP's last step from it
    assert all(abs(p[0] - path[0][0]) <= reach and abs(p[1] - path[0][1]) <= reach for p in near)


def test_a_track_lost_after_scans_that_vouched_for_nothing_is_searched_for_from_the_last_vouched_pose(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # The scan at path[0] vouched for the pose; the next 20 updates were tracked on fits that
    # explained too little to vouch (a broken odometry step followed), and the track ended 5 m
    # off. Lost at the 21st, the search near the robot pivots on path[0] with the odometry's drive
    # since, and finds it; from the pose the track reached (a fresh recovery), it does not.
    config = RecoveryConfig(search_nodes=None, search_time=None)  # each search within its update
    icp = IcpConfig.for_tracking().replace(correspondence_search="kd_tree")
    lost = LostDecision(True, False, False, math.nan, 3)
    fit = FitDecision(None, None, None, False, "", usable=True)
    wrong = (path[21][0] + 4.0, path[21][1] - 3.0, path[21][2] + 0.5)
    prediction = Prediction((0.0, 0.0, 0.0), se2.between(path[20], path[21]), wrong, SMALL, False)

    def near_places(vouched: bool) -> list[Pose]:
        recovery = Recovery(plan, config, icp, AcceptanceGate(), OcclusionFilter(plan, OcclusionRule()), MotionNoise())
        if vouched:
            recovery.note_tracked((0.0, 0.0, 0.0), path[0], vouched=True)
            for a, b in zip(path[:20], path[1:21]):
                recovery.note_tracked(se2.between(a, b), wrong, vouched=False)
        stages.recover(recovery, LostDetector(LostRule()), scans[21], prediction, fit, idle_pose(prediction), lost)
        assert recovery._lost_at == (path[0] if vouched else wrong)
        return [h.pose for h in recovery.hypotheses if h.near]

    assert any(error(path[21], p)[0] < 0.05 for p in near_places(vouched=True))
    assert not any(error(path[21], p)[0] < 0.5 for p in near_places(vouched=False))


def test_a_scan_vouches_for_the_pose_when_its_fit_explains_as_much_as_the_tracks_sound_fits_do(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # Sound fits explained 88-96 % of their scans: one that explains 40 % is still sound (the plan
    # explains it above the lost rule's bar) and recorded, but vouches for nothing.
    recovery = Recovery(plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate())
    for share in (0.90, 0.94, 0.88, 0.96, 0.92, 0.91):
        recovery.observe_explained(share)
    result = localize(scans[0], plan, path[0], IcpConfig.for_tracking())
    fit = FitDecision(result, None, None, False, "", usable=True)
    score = ScoreDecision(0.9, False, None, "")
    n = result.num_inliers
    well = stages.keep_records(recovery, fit, score, result, int(n / 0.93), True, False, False, rules(plan))
    assert well.vouched and well.explained_share == pytest.approx(0.93, abs=0.01)
    assert "vouched" in well.why
    poorly = stages.keep_records(recovery, fit, score, result, int(n / 0.40), True, False, False, rules(plan))
    assert not poorly.vouched and poorly.explained_share == pytest.approx(0.40, abs=0.01)
    relocalized = stages.keep_records(recovery, fit, score, result, int(n / 0.93), True, True, False, rules(plan))
    assert not relocalized.vouched and relocalized.explained_share is None


def test_a_sound_scan_whose_prediction_was_too_uncertain_to_classify_records_its_beyond_share_at_its_fit(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # A scan a step of metres away: the occlusion rule classified nothing (`fit.beyond` None). Its
    # returns, and as many again pushed half as far again along their beams (beyond the walls they
    # hit), seen from the fit's pose: about half of them beyond the walls.
    the_rules = rules(plan)
    recovery = Recovery(plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate())
    result = localize(scans[0], plan, path[0], IcpConfig.for_tracking())
    points = np.vstack([scans[0], 1.5 * scans[0]])
    fit = FitDecision(result, None, None, False, "", usable=True)
    score = ScoreDecision(0.9, False, None, "")
    n = len(points)
    records = stages.keep_records(recovery, fit, score, result, n, True, False, False, the_rules, points=points)
    assert records.beyond_share is not None and 0.4 < records.beyond_share < 0.55
    assert list(recovery.beyond_shares) == [records.beyond_share]
    assert the_rules.occlusion is not None
    expected = float(np.mean(the_rules.occlusion.classify(points, result.pose)[1]))
    assert records.beyond_share == pytest.approx(expected)
    # Without the points (or for a scan not soundly tracked) nothing is recorded.
    assert stages.keep_records(recovery, fit, score, result, n, True, False, False, the_rules).beyond_share is None
    lost = stages.keep_records(recovery, fit, score, result, n, True, False, True, the_rules, points=points)
    assert lost.beyond_share is None and len(recovery.beyond_shares) == 1


PATCHY = (0.79, 0.71, 0.81, 0.98, 0.93, 0.64, 0.57, 0.73, 0.71, 0.83, 0.64, 0.48, 0.44)
"""Shares of their scans the sound fits of orebro's first 13 scans explained on its map drawn with
three end points per cell: a patchy map, whose sound fits spread widely."""


def on_a_patchy_map(plan: PlanMap, pose: Pose) -> Localizer:
    """A default `Localizer` at `pose` that has recorded the sound fits' shares `PATCHY`: the gate's
    and the lost rule's bars are relaxed below 0.2."""
    loc = Localizer(plan, pose)
    for share in PATCHY:
        loc._recovery.observe_explained(share)
    return loc


def test_the_gate_and_the_lost_rule_relax_their_bars_on_what_a_fit_explains_to_what_sound_fits_teach(
    plan: PlanMap,
) -> None:
    gate, rule = AcceptanceGate(), LostRule()
    assert gate.relaxed_to(None) is gate and rule.relaxed_to(None) is rule
    assert gate.relaxed_to(0.5) is gate and rule.relaxed_to(0.5) is rule  # never raised
    assert gate.relaxed_to(0.1).min_inlier_ratio == 0.1 and rule.relaxed_to(0.1).min_score == 0.1
    assert gate.relaxed_to(0.1).min_inliers == gate.min_inliers  # the count a fit needs stays
    fixed_gate, fixed_rule = AcceptanceGate(relaxes=False), LostRule(relaxes=False)
    assert fixed_gate.relaxed_to(0.1) is fixed_gate and fixed_rule.relaxed_to(0.1) is fixed_rule
    loc = Localizer(plan, (0.0, 0.0, 0.0))
    assert loc._rules().gate == gate and loc._rules().lost == rule  # nothing learned yet
    # Sound fits that explained 88-96 % of their scans: the bars stay as set.
    for share in (0.90, 0.94, 0.88, 0.96, 0.92, 0.91):
        loc._recovery.observe_explained(share)
    assert loc._rules().gate == gate and loc._rules().lost == rule
    # A map that lacks many walls: sound fits explained 44-99 %, and a right fit may explain less
    # than the bars as set.
    loc = on_a_patchy_map(plan, (0.0, 0.0, 0.0))
    bar = loc._recovery.explained_seen
    assert 0.0 < bar < 0.15
    rules_now = loc._rules()
    assert rules_now.gate.min_inlier_ratio == bar and rules_now.lost.min_score == bar
    assert rules_now.gate_as_set == gate and rules_now.lost_as_set == rule
    detector = LostDetector(rule)
    for _ in range(rule.window):
        detector.update(0.2, True, rules_now.lost)
    assert not detector.lost  # 20 % is above the relaxed bar
    detector.update(0.2, True)
    assert detector.lost  # and below the rule as set


def test_a_fit_only_the_relaxed_bars_pass_keeps_the_track_but_teaches_and_vouches_for_nothing(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    loc = on_a_patchy_map(plan, path[0])
    the_rules = loc._rules()
    recovery = loc._recovery
    result = localize(scans[0], plan, path[0], IcpConfig.for_tracking())
    fit = FitDecision(result, None, None, False, "", usable=True)
    n = result.num_inliers
    recorded = len(recovery.explained_shares)
    # The plan explains 20 % of the scan: above the relaxed bars, below the lost rule's as set.
    score = ScoreDecision(0.2, False, None, "")
    relaxed = stages.keep_records(recovery, fit, score, result, int(n / 0.2), True, False, False, the_rules)
    assert relaxed.anchored and not relaxed.vouched and relaxed.explained_share is None
    assert len(recovery.explained_shares) == recorded
    sound = stages.keep_records(
        recovery, fit, ScoreDecision(0.5, False, None, ""), result, int(n / 0.5), True, False, False, the_rules
    )
    assert sound.vouched and sound.explained_share == pytest.approx(0.5, abs=0.01)
    assert len(recovery.explained_shares) == recorded + 1


def test_a_track_kept_only_by_the_relaxed_lost_bar_is_doubted_and_a_better_place_replaces_it(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # Sound fits that spread widely (a patchy map): the lost rule's bar is relaxed below 0.2.
    relaxed = on_a_patchy_map(plan, path[0])._rules()
    assert relaxed.lost.min_score < 0.2 < relaxed.lost_as_set.min_score
    score = ScoreDecision(0.2, False, None, "")
    prediction = prediction_at(path[0])
    sound = Correction(path[0], SMALL, True, None, "fused")
    search = SearchDecision(None, None, None, "", False)
    detector = LostDetector(relaxed.lost_as_set)
    verdicts = [stages.judge_lost(detector, score, sound, search, False, relaxed) for _ in range(5)]
    assert not any(v.lost for v in verdicts) and verdicts[-1].doubted and not verdicts[0].doubted
    assert "searched beside the track" in verdicts[-1].why
    detector = LostDetector(relaxed.lost_as_set)
    as_set = replace(relaxed, lost=relaxed.lost_as_set)
    verdicts = [stages.judge_lost(detector, score, sound, search, False, as_set) for _ in range(5)]
    assert verdicts[-1].lost and not verdicts[-1].doubted
    # In doubt, the whole plan is searched beside the track (here a place 5 m and 115 degrees
    # off, which the scans do not fit): the place the scans fit replaces it.
    config = RecoveryConfig(confirmations=2, search_nodes=None, search_time=None)  # each search within its update
    icp = IcpConfig.for_tracking().replace(correspondence_search="kd_tree")
    recovery = Recovery(plan, config, icp, AcceptanceGate(), OcclusionFilter(plan, OcclusionRule()), MotionNoise())
    doubted = LostDecision(False, False, True, 0.2, 0, doubted=True)
    fit = FitDecision(None, None, None, False, "", usable=True)
    wrong = (path[0][0] + 4.0, path[0][1] - 3.0, path[0][2] + 2.0)
    decisions = tracked_at(recovery, path, scans, wrong, 0, [doubted] * 4)
    assert all(d.action == "verify" for d in decisions) and decisions[0].on_trial
    adopted = decisions[-1].adopted
    assert adopted is not None, [d.why for d in decisions]
    assert error(path[len(decisions) - 1], adopted.pose)[0] < 0.05
    # Not in doubt, nor on trial: the recovery is idle.
    idle = stages.recover(
        recovery, LostDetector(), scans[0], prediction, fit, sound, LostDecision(False, False, True, 0.9, 0)
    )
    assert idle.action == "clear" and not idle.on_trial


def test_an_estimate_lists_the_decisions_of_its_stages_in_order(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    loc = Localizer(plan, path[0])
    loc.update(scans[0], (0.0, 0.0, 0.0))
    est = loc.update(scans[1], se2.between(path[0], path[1]))
    assert [type(d) for d in est.decisions] == [
        Prediction,
        FitDecision,
        PendingDecision,
        SearchDecision,
        ScoreDecision,
        Correction,
        LeftPlaceDecision,
        LostDecision,
        RecoveryDecision,
        Bookkeeping,
    ]
    prediction, fit, pending, search, score, correction, left, lost, recovery, records = est.decisions
    assert isinstance(prediction, Prediction) and prediction.pose == est.predicted_pose and not prediction.first
    assert isinstance(fit, FitDecision) and fit.passed and fit.result is est.result
    assert isinstance(pending, PendingDecision) and pending.place is None
    assert isinstance(search, SearchDecision) and search.cause is None and not search.searched
    assert isinstance(score, ScoreDecision) and 0.7 < score.score < 1.0 and not score.poor
    assert isinstance(correction, Correction) and correction.kind == "fused" and correction.pose == est.pose
    np.testing.assert_array_equal(correction.covariance, est.covariance)
    assert left == LeftPlaceDecision(None)  # no jump was taken
    assert isinstance(lost, LostDecision) and not lost.lost and lost.rejections == 0 and lost.counted_accepted
    assert lost.window_score == est.score  # the mean over both scans
    assert isinstance(recovery, RecoveryDecision) and recovery.action == "clear" and recovery.adopted is None
    assert isinstance(records, Bookkeeping) and records.anchored and records.beyond_share is not None
    assert all(isinstance(d.why, str) and d.why for d in est.decisions)


def test_the_decisions_say_why_a_jump_was_taken_a_scan_later(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """The 15-degree odometry fault of
    `test_localizer.py::test_a_good_fit_beyond_the_gate_is_checked_by_a_search_and_taken`, read
    from the decisions."""
    loc = Localizer(plan, path[0])
    loc.update(scans[0], (0.0, 0.0, 0.0))
    claimed = se2.compose(se2.between(path[0], path[1]), (0.0, 0.0, 15 * DEG))
    est = loc.update(scans[1], claimed)
    search = est.decisions[3]
    assert isinstance(search, SearchDecision) and search.cause == "jump" and search.pending is not None
    assert search.pending[1] == claimed and search.reason == est.reason
    est = loc.update(scans[2], se2.compose(claimed, se2.between(path[1], path[2])))
    pending, search, correction = est.decisions[2], est.decisions[3], est.decisions[5]
    assert isinstance(pending, PendingDecision) and pending.confirmed is not None and pending.place is not None
    assert isinstance(search, SearchDecision) and search.cause is None and search.searched
    assert search.result is pending.confirmed is est.result
    assert isinstance(correction, Correction) and correction.kind == "fit" and est.relocalized


def test_a_scan_that_says_nothing_keeps_the_jump_pending_for_the_next(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """After the 15-degree odometry fault above, a scan too small to align neither confirms nor
    refutes the place the fault's scan fitted: it stays pending, followed with the odometry, and
    the next full scan confirms it."""
    loc = Localizer(plan, path[0])
    loc.update(scans[0], (0.0, 0.0, 0.0))
    claimed = se2.compose(se2.between(path[0], path[1]), (0.0, 0.0, 15 * DEG))
    assert loc.update(scans[1], claimed).decisions[3].pending is not None
    odom2 = se2.compose(claimed, se2.between(path[1], path[2]))
    est = loc.update(scans[2][:2], odom2)  # two returns: nothing to align
    pending = est.decisions[2]
    assert isinstance(pending, PendingDecision) and pending.confirmed is None and len(pending.kept) == 1
    assert pending.kept[0].odom == odom2 and error(path[2], pending.kept[0].pose)[0] < 0.05
    assert pending.kept[0].silent == 1
    assert pending.why == "this scan says nothing of the pending place: still pending"
    assert not est.accepted and error(path[2], est.pose)[1] > 10 * DEG  # the faulted prediction meanwhile
    est = loc.update(scans[3], se2.compose(odom2, se2.between(path[2], path[3])))
    assert est.decisions[2].confirmed is not None and est.relocalized
    assert error(path[3], est.pose)[0] < 0.05


def test_a_scan_the_pending_place_does_not_explain_better_forgets_it(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A place pending after a jump that the next scan refutes (the fit from the prediction is
    sound and the place explains the scan no better) is forgotten, not kept."""
    loc = Localizer(plan, path[0])
    loc.update(scans[0], (0.0, 0.0, 0.0))
    truth1 = se2.between(path[0], path[1])
    pending = (PendingPlace(se2.compose(path[1], (0.0, 0.0, 15 * DEG)), truth1),)  # a corrupted scan's place
    odom2 = se2.compose(truth1, se2.between(path[1], path[2]))
    prediction = stages.predict(path[1], SMALL, truth1, odom2, MotionNoise())
    fit = stages.fit_from_prediction(scans[2], prediction, loc._rules(), False)
    assert fit.passed
    decision = stages.confirm_pending(scans[2], prediction, pending, fit, loc._rules())
    assert decision.place is not None and decision.confirmed is None and decision.kept == ()
    assert decision.why == "this scan does not confirm the pending place: forgotten"


def _history(cost: float) -> CostHistory:
    """A track whose recent accepted scans all cost `cost` in the plan's likelihood field."""
    history = CostHistory()
    for _ in range(20):
        history.record(cost)
    return history


def test_a_scan_the_plan_explains_nowhere_keeps_the_pending_place(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """Half of the scan's returns replaced by junk: the fits at the pending place and from the
    prediction both pass the gate, and the one at the place explains no more; but the scan costs
    far more than the track's scans at both, so it says nothing of the place, which stays pending
    (the same scan from a track whose scans cost as much refutes it). The likelihood field is the
    refinement's, on by default on a SLAM map's cells, turned on here."""
    loc = Localizer(plan, path[0], refinement=PosteriorRefinement())
    rules = loc._rules()
    truth1 = se2.between(path[0], path[1])
    pending = (PendingPlace(se2.compose(path[1], (0.0, 0.0, 15 * DEG)), truth1),)
    odom2 = se2.compose(truth1, se2.between(path[1], path[2]))
    prediction = stages.predict(path[1], SMALL, truth1, odom2, MotionNoise())
    scan = scans[2].copy()
    scan[::2] = np.random.default_rng(5).uniform(-8.0, 8.0, size=scan[::2].shape)
    fit = stages.fit_from_prediction(scan, prediction, rules, False)
    assert fit.passed and fit.result is not None
    clean_cost = scan_cost(scans[2], path[2], plan, rules.refinement)
    junk_cost = scan_cost(scan, fit.result.pose, plan, rules.refinement)
    assert junk_cost > clean_cost + 2 * fault_cost(rules.refinement.fault_probability)
    kept = stages.confirm_pending(scan, prediction, pending, fit, rules, _history(clean_cost))
    assert kept.confirmed is None and len(kept.kept) == 1 and kept.kept[0].silent == 1
    assert kept.kept[0].odom == odom2
    assert kept.why == "this scan says nothing of the pending place: still pending"
    refuted = stages.confirm_pending(scan, prediction, pending, fit, rules, _history(junk_cost))
    assert refuted.confirmed is None and refuted.kept == ()


def test_a_pending_place_is_confirmed_only_where_it_explains_the_scan_as_the_tracks_scans_are(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """The fit from the prediction rejected for its jump confirms a pending place the gate passes
    only where the scan's cost in the likelihood field there is within the fault cost of the
    track's typical cost: a place merely less bad than the rejected fit is no evidence (on
    freiburg-campus a search's place 2.6 m off was so confirmed at a cost of 49.3 against a
    typical 23.7). The true place, from a track whose scans cost what this one does there, is
    confirmed; from a track whose scans cost far less, it says nothing of the place, which stays
    pending."""
    loc = Localizer(plan, path[0], refinement=PosteriorRefinement())
    rules = loc._rules()
    truth1 = se2.between(path[0], path[1])
    pending = (PendingPlace(path[1], truth1),)
    odom2 = se2.compose(truth1, se2.between(path[1], path[2]))
    prediction = stages.predict(path[1], SMALL, truth1, odom2, MotionNoise())
    fit = stages.fit_from_prediction(scans[2], prediction, rules, False)
    assert fit.passed
    jumped = replace(fit, reason="correction of 0.711 m exceeds 0.500 m")
    cost = scan_cost(scans[2], path[2], plan, rules.refinement)
    confirmed = stages.confirm_pending(scans[2], prediction, pending, jumped, rules, _history(cost))
    assert confirmed.confirmed is not None and error(path[2], confirmed.confirmed.pose)[0] < 0.03
    usual = cost - 2 * fault_cost(rules.refinement.fault_probability)
    held = stages.confirm_pending(scans[2], prediction, pending, jumped, rules, _history(usual))
    assert held.confirmed is None and len(held.kept) == 1 and held.kept[0].silent == 1
    assert held.why == "this scan says nothing of the pending place: still pending"


def test_a_place_says_nothing_of_is_kept_over_as_many_scans_as_the_lost_rule_allows(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A scan too small to align keeps every pending place, one more silent scan each, but not
    past the lost rule's `max_rejections`."""
    loc = Localizer(plan, path[0])
    rules = loc._rules()
    truth1 = se2.between(path[0], path[1])
    odom2 = se2.compose(truth1, se2.between(path[1], path[2]))
    prediction = stages.predict(path[1], SMALL, truth1, odom2, MotionNoise())
    fit = stages.fit_from_prediction(scans[2][:2], prediction, rules, False)
    assert fit.result is None
    limit = rules.lost.max_rejections
    pending = (PendingPlace(path[1], truth1, limit - 1), PendingPlace(path[1], truth1, limit))
    decision = stages.confirm_pending(scans[2][:2], prediction, pending, fit, rules)
    assert [p.silent for p in decision.kept] == [limit] and decision.checked == 2
    assert decision.why == "this scan refutes 1 of 2 pending places and says nothing of the rest"


def test_of_two_pending_places_the_scan_confirms_the_one_it_fits(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """After the 15-degree odometry fault, two places are pending: a corrupted scan's, 1.5 m
    off, and the fault's true one. The next scan confirms the true one and forgets the other."""
    loc = Localizer(plan, path[0])
    rules = loc._rules()
    claimed = se2.compose(se2.between(path[0], path[1]), (0.0, 0.0, 15 * DEG))
    wrong = PendingPlace(se2.compose(path[1], (1.5, 0.0, 0.0)), claimed)
    pending = (wrong, PendingPlace(path[1], claimed))
    odom2 = se2.compose(claimed, se2.between(path[1], path[2]))
    predicted_from = se2.compose(path[1], (0.0, 0.0, -15 * DEG))  # the track followed the faulted odometry
    prediction = stages.predict(predicted_from, SMALL, claimed, odom2, MotionNoise())
    fit = stages.fit_from_prediction(scans[2], prediction, rules, False)
    decision = stages.confirm_pending(scans[2], prediction, pending, fit, rules)
    assert decision.confirmed is not None and decision.place is not None and decision.kept == ()
    assert error(path[2], decision.confirmed.pose)[0] < 0.03 and error(path[2], decision.place)[0] < 0.01
    assert decision.checked == 2 and decision.why == "this scan confirms one of 2 pending places: taken"


def test_a_searched_place_must_be_more_probable_than_the_fit_it_would_replace(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """The search's place replaces an acceptable fit from an uncertain prediction only with a
    higher posterior: the scan's likelihood in the plan's field with the prediction as the prior
    (an inlier ratio a few points higher is not enough: along a corridor a place a metre off can
    count more returns near some wall than the true one)."""
    from planicp.tracking.stages.search import _more_probable

    the_rules = rules(plan)
    truth, points = path[3], scans[3]
    uncertain = np.diag([0.25**2, 0.25**2, (5 * DEG) ** 2])
    predicted = se2.compose(truth, (0.1, -0.08, 2 * DEG))
    along = se2.compose(truth, (0.9, 0.0, 0.0))
    assert not _more_probable(points, along, truth, predicted, uncertain, the_rules)
    assert _more_probable(points, truth, along, predicted, uncertain, the_rules)
    # A prediction 0.9 m along and certain of it outweighs the scan's preference for the truth.
    certain = np.diag([0.05**2, 0.05**2, (1 * DEG) ** 2])
    assert _more_probable(points, along, truth, along, certain, the_rules)


def test_the_place_left_behind_is_taken_back_kept_or_forgotten_by_the_fault_cost(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    the_rules = rules(plan, refinement=PosteriorRefinement(enabled=True))
    k = 20
    truth, points = path[k], scans[k]
    before = (1.0, 2.0, 0.3)  # the odometry pose the place was left at, one scan earlier
    odom = se2.compose(before, se2.between(path[k - 1], path[k]))
    elsewhere = se2.compose(truth, (1.5, 0.5, 90 * DEG))  # a place the scan rules out

    def corrected(pose: Pose) -> Correction:
        return Correction(pose, SMALL, True, None, "fused")

    threshold = fault_cost(the_rules.refinement.fault_probability)
    left = LeftPlace(path[k - 1], before)
    # The track took the wrong place; the place it left, followed with the odometry, is the truth.
    back = stages.weigh_left_place(points, left, odom, corrected(elsewhere), the_rules, False)
    assert back.place is not None and back.returned is not None and back.kept is None
    assert error(truth, back.place)[0] < 0.03 and error(truth, back.returned.pose)[0] < 0.03
    assert back.evidence == pytest.approx(back.current_cost - back.cost) and back.evidence > threshold
    assert back.why.startswith("this scan prefers the place left behind")
    # The track is right and the place left behind is not: forgotten.
    gone = stages.weigh_left_place(points, LeftPlace(elsewhere, odom), odom, corrected(truth), the_rules, False)
    assert gone.place is not None and gone.returned is None and gone.kept is None
    assert gone.evidence < -threshold and gone.why.startswith("this scan rules out the place left behind")
    # A place whose mode is the track's (within the corrected pose's covariance) is one
    # hypothesis with it again: forgotten.
    merged = stages.weigh_left_place(points, LeftPlace(truth, odom, 5.0), odom, corrected(truth), the_rules, False)
    assert merged.merged and merged.kept is None and merged.returned is None
    assert merged.why == "the place left behind has the track's own mode again: forgotten"
    # Within the fault cost of each other (the track 1 cm off and sure of it, the place at the
    # scan's mode): still followed, from its mode, with what this scan says added to what the
    # earlier ones said; scans that each prefer it by less than the fault cost take it back together.
    sure = Correction(se2.compose(truth, (0.01, 0.0, 0.0)), np.diag([1e-6, 1e-6, 1e-8]), True, None, "fused")
    kept = stages.weigh_left_place(points, LeftPlace(truth, odom, 5.0), odom, sure, the_rules, False)
    assert not kept.merged and kept.returned is None and kept.kept is not None and kept.kept.odom == odom
    assert error(truth, kept.kept.pose)[0] < 0.01 and 0.0 < kept.current_cost - kept.cost < threshold - 5.0
    assert kept.kept.evidence == pytest.approx(5.0 + kept.current_cost - kept.cost)
    assert kept.why.startswith("the place left behind is still followed")
    many = LeftPlace(truth, odom, threshold - 0.5 * (kept.current_cost - kept.cost))
    assert stages.weigh_left_place(points, many, odom, sure, the_rules, False).returned is not None
    # Where the update took a place the fault sweep found, that place needs a fault and the place
    # left behind does not: a scan that explains the two alike takes the place back.
    same = stages.weigh_left_place(points, LeftPlace(truth, odom), odom, sure, the_rules, False, True, SMALL)
    assert same.returned is not None and same.evidence > threshold
    # Not where the place's own mode lies beyond the motion's reach of where the odometry takes
    # it (it needs a fault too: here ICP turns it 12 degrees, onto the track's place).
    turned = LeftPlace(se2.compose(truth, (0.0, 0.0, 12 * DEG)), odom)
    both = stages.weigh_left_place(points, turned, odom, sure, the_rules, False, True, SMALL)
    assert both.place is not None and error(truth, both.place)[1] < 0.5 * DEG
    assert both.returned is None and not both.merged and abs(both.evidence) < threshold
    # (And with the place the sweep took there, it is that place: merged.)
    assert stages.weigh_left_place(points, turned, odom, corrected(truth), the_rules, False, True, SMALL).merged
    # An update without an accepted fit weighs the place against the prediction: taken back
    # where ICP from it passes the gate, never ruled out (followed from where the odometry puts it).
    refused = Correction(elsewhere, SMALL, False, None, "prediction")
    found = stages.weigh_left_place(points, left, odom, refused, the_rules, False)
    assert found.returned is not None and error(truth, found.returned.pose)[0] < 0.03
    # Weighed against the places the scan offered the track (a fit the gate refused only for
    # the size of its correction, a place left pending), not the prediction alone: where one of
    # them explains the scan as well as the place left behind does, the scan prefers neither.
    offered = (elsewhere, se2.compose(truth, (0.005, 0.0, 0.0)))
    held = stages.weigh_left_place(points, left, odom, refused, the_rules, False, offered=offered)
    assert held.returned is None and held.kept is not None and abs(held.evidence) < 0.5 * threshold
    assert held.current_cost == pytest.approx(scan_cost(points, offered[1], plan, the_rules.refinement))
    assert held.current_cost < scan_cost(points, elsewhere, plan, the_rules.refinement) - threshold
    unsure = Correction(truth, SMALL, False, None, "prediction")
    waiting = stages.weigh_left_place(points, LeftPlace(elsewhere, odom), odom, unsure, the_rules, False)
    assert waiting.evidence < -threshold and waiting.kept is not None and waiting.kept.pose == elsewhere
    assert waiting.why.startswith("the place left behind is still followed")
    lost = stages.weigh_left_place(points, left, odom, corrected(elsewhere), the_rules, True)
    assert lost.place is None and lost.kept is None and lost.returned is None
    # Without the fault component (or the field: a drawn plan's default) nothing is followed.
    for off in (rules(plan), rules(plan, refinement=PosteriorRefinement(enabled=True, fault_probability=0.0))):
        decision = stages.weigh_left_place(points, left, odom, corrected(elsewhere), off, False)
        assert decision == LeftPlaceDecision(None) and decision.why == "no place left behind is followed"


def test_a_scan_far_worse_explained_than_the_tracks_is_swept_for_an_odometry_fault(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # The odometry turned 20 degrees and moved 15 cm more than the robot did; its covariance
    # (2 cm, 1 degree) rules the true pose out, so neither the gate nor the search for an
    # uncertain prediction looks there.
    the_rules = rules(plan, refinement=PosteriorRefinement(enabled=True))
    truth = path[20]
    prediction = prediction_at(se2.compose(truth, (0.15, 0.0, 20 * DEG)))
    history = CostHistory()
    for k in range(10, 20):
        history.record(scan_cost(scans[k], path[k], plan, the_rules.refinement))
    typical = history.typical()
    assert typical is not None
    fit = stages.fit_from_prediction(scans[20], prediction, the_rules, False)
    assert fit.result is not None and error(truth, fit.result.pose)[1] > 5 * DEG  # ICP: the wrong basin
    search = search_stage(scans[20], prediction, fit, the_rules, history)
    assert search.cause == "fault" and search.fault is not None and search.pending is None
    assert search.fault.current_cost > typical + search.fault.threshold
    assert search.fault.cost + search.fault.threshold < search.fault.current_cost
    assert search.found is not None and search.result is search.found
    distance, turn = error(truth, search.result.pose)
    assert distance < 0.03 and turn < 0.5 * DEG, (distance, turn)
    # The place, within the fault model, is the posterior's mode: taken at once (not fused with
    # the prediction, which says nothing after a fault); the fit from the prediction is left
    # behind for the next scans to weigh.
    assert search.searched and search.reason == "" and search.left == prediction.pose
    score = stages.judge_score(scans[20], prediction, fit, search, the_rules, False, None)
    assert score.reason == ""
    correction = stages.correct(scans[20], prediction, search, score, the_rules)
    assert correction.accepted and correction.kind == "fit" and correction.pose == search.result.pose
    assert search.why.startswith("odometry fault: ")
    # A place beyond the fault model (the sweep's heading window) is not taken.
    narrow = rules(plan, refinement=PosteriorRefinement(enabled=True, fault_heading_window=10 * DEG))
    outside = search_stage(scans[20], prediction, fit, narrow, history)
    assert outside.cause is None and outside.fault is not None and not outside.fault.more_probable
    assert outside.why.startswith(f"the scan's cost {outside.fault.current_cost:.1f} exceeds the track's typical")
    # After a search for an uncertain prediction that found nothing, the decision says what the
    # sweep found too (fhw's 66-degree fault, beyond the window, read "found no place" alone).
    uncertain = replace(outside, cause="uncertain")
    assert uncertain.why == (
        "uncertain prediction: the search found no place that passes; the scan's cost "
        f"{outside.fault.current_cost:.1f} exceeds the track's typical {outside.fault.typical:.1f} by over "
        f"{outside.fault.threshold:.1f}: the sweep for an odometry fault found no place better by that "
        f"(best {outside.fault.cost:.1f})"
    )
    assert replace(uncertain, fault=None).why == "uncertain prediction: the search found no place that passes"
    # No sweep before the track has a typical cost, nor without the fault component.
    unknown = search_stage(scans[20], prediction, fit, the_rules)
    assert unknown.cause is None and unknown.fault is None and unknown.pending is None
    off = rules(plan, refinement=PosteriorRefinement(enabled=True, fault_probability=0.0))
    never = search_stage(scans[20], prediction, fit, off, history)
    assert never.cause is None and never.fault is None
    # A scan the prediction explains as well as the track's: no sweep.
    good = prediction_at(truth)
    fit = stages.fit_from_prediction(scans[20], good, the_rules, False)
    calm = search_stage(scans[20], good, fit, the_rules, history)
    assert calm.cause is None and calm.fault is None and calm.why == "no search"


def test_a_jump_an_odometry_fault_explains_is_taken_at_once_and_a_jump_beyond_it_waits(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # The odometry reported 1 m ahead and 10 degrees of turn, the robot moved 0.4 m straight:
    # ICP from the prediction finds the true pose, 0.6 m away, beyond the gate.
    the_rules = rules(plan, refinement=PosteriorRefinement(enabled=True))
    truth = path[20]
    predicted = se2.compose(truth, (0.6, 0.0, 10 * DEG))
    history = _history(scan_cost(scans[20], truth, plan, the_rules.refinement))
    slipped = Prediction((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), predicted, SMALL, False)
    fit = stages.fit_from_prediction(scans[20], slipped, the_rules, False)
    assert fit.result is not None and fit.reason.startswith("correction of 0.60")
    search = search_stage(scans[20], slipped, fit, the_rules, history)
    # The place lies where the odometry's step can have left the robot (it slipped), explains the
    # scan as the track's scans are, and far better than the prediction's surroundings: the
    # posterior's mode, taken at once, the prediction left behind for the next scans to weigh.
    assert search.cause == "jump" and search.searched and search.pending is None
    assert search.left == predicted and search.result is not None
    assert error(truth, search.result.pose)[0] < 0.01
    assert search.why.startswith("jump beyond the gate to a place an odometry fault explains: taken")
    score = stages.judge_score(scans[20], slipped, fit, search, the_rules, False, None)
    correction = stages.correct(scans[20], slipped, search, score, the_rules)
    assert correction.accepted and correction.pose == search.result.pose
    # The same place after no reported motion lies beyond what the step can have done (0.6 m from
    # where the robot stood, more than the gate's 0.5 m): the jump waits for the next scan.
    still = Prediction((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), predicted, SMALL, False)
    waits = search_stage(scans[20], still, fit, the_rules, history)
    assert waits.cause == "jump" and not waits.searched and waits.left is None and waits.pending is not None
    assert error(truth, waits.pending.pose)[0] < 0.01
    # A track whose scans are as poorly explained as the prediction's surroundings explain this
    # one gives no evidence of a fault (as on a map that drew a wall twice): it waits too.
    held = refine_pose(scans[20], predicted, plan, ("prediction", predicted, SMALL), the_rules.refinement)
    poor = _history(held.cost - 0.5 * fault_cost(the_rules.refinement.fault_probability))
    assert search_stage(scans[20], slipped, fit, the_rules, poor).pending is not None
    # So it does without the fault component, and before the track has a typical cost.
    off = rules(plan, refinement=PosteriorRefinement(enabled=True, fault_probability=0.0))
    assert search_stage(scans[20], slipped, fit, off, history).pending is not None
    assert search_stage(scans[20], slipped, fit, the_rules).pending is not None


def test_a_correction_beyond_the_gate_that_an_uncertain_prediction_allows_is_no_jump(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    # A step of 5 m turning 50 degrees: the motion noise's deviations are 0.26 m and 7.6 degrees.
    # The odometry's heading is 12 degrees off; ICP from the prediction finds the truth, beyond
    # the gate's 10 degrees but within the prediction's own 99.9 % bound: the search within that
    # bound confirms the place, taken at once.
    the_rules = rules(plan)
    truth = path[20]
    predicted = se2.compose(truth, (0.1, 0.0, 12 * DEG))
    wide = np.diag([0.26**2, 0.26**2, (7.6 * DEG) ** 2])
    uncertain = Prediction((0.0, 0.0, 0.0), (5.0, 0.0, 50 * DEG), predicted, wide, False)
    fit = stages.fit_from_prediction(scans[20], uncertain, the_rules, False)
    assert fit.result is not None and error(truth, fit.result.pose)[0] < 0.02
    assert fit.reason.startswith("correction of 1") and fit.reason.endswith("exceeds 10.00 deg"), fit.reason
    allowed = search_stage(scans[20], uncertain, fit, the_rules)
    assert allowed.cause == "uncertain" and allowed.searched and allowed.pending is None
    assert allowed.result is not None and error(truth, allowed.result.pose)[0] < 0.02
    # The same correction after a step the odometry is sure of is a jump: it waits for the next scan.
    sure = Prediction((0.0, 0.0, 0.0), (0.5, 0.0, 0.0), predicted, SMALL, False)
    waits = search_stage(scans[20], sure, stages.fit_from_prediction(scans[20], sure, the_rules, False), the_rules)
    assert waits.cause == "jump" and not waits.searched and waits.pending is not None
    # And after one uncertain in position only (0.2 m; 2.6 degrees): 12 degrees lies beyond its bound.
    along = np.diag([0.2**2, 0.2**2, (2.6 * DEG) ** 2])
    narrow = Prediction((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), predicted, along, False)
    beyond = search_stage(scans[20], narrow, stages.fit_from_prediction(scans[20], narrow, the_rules, False), the_rules)
    assert beyond.cause == "jump" and beyond.pending is not None
    # A fit that slid to a place beyond the uncertain prediction's bound (1.1 m away; on seattle,
    # every third scan tracked, after a 5.2 m step, ICP from a heading 9 degrees off went to a
    # place that explained 47 % of the scan): the bound is searched first, and the truth, 0.3 m
    # and 6 degrees from the prediction, is found there and taken at once.
    near = se2.compose(truth, (0.3, 0.0, 6 * DEG))
    wider = Prediction((0.0, 0.0, 0.0), (5.0, 0.0, 50 * DEG), near, wide, False)
    sound = stages.fit_from_prediction(scans[20], wider, the_rules, False)
    assert sound.result is not None and error(truth, sound.result.pose)[0] < 0.02
    slid = replace(sound.result, pose=se2.compose(near, (1.1, 0.0, 0.0)))
    reason = the_rules.gate.rejection(slid, near)
    assert reason.startswith("correction of 1.1") and the_rules.gate.fit_rejection(slid) == ""
    assert the_rules.fusion.innovation(slid, near, wide) > CHI2_3_999
    bounded = search_stage(scans[20], wider, replace(sound, result=slid, reason=reason), the_rules)
    assert bounded.cause == "uncertain" and bounded.searched and bounded.pending is None
    assert bounded.result is not None and error(truth, bounded.result.pose)[0] < 0.02
    # A fit refused for what it explains, not for its jump, is no jump either way: nothing waits.
    few = scans[20][::8][:25]
    poor = stages.fit_from_prediction(few, uncertain, the_rules, False)
    assert poor.reason.startswith("only ") and search_stage(few, uncertain, poor, the_rules).pending is None


def test_a_pending_place_the_scan_prefers_as_a_fault_would_is_confirmed(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    from planicp.tracking.stages.pending import _fault_confirmed

    the_rules = rules(plan, refinement=PosteriorRefinement(enabled=True))
    truth, turned = path[20], se2.compose(path[20], (0.1, 0.0, 15 * DEG))
    assert _fault_confirmed(scans[20], truth, turned, the_rules)
    assert not _fault_confirmed(scans[20], turned, truth, the_rules)
    # Within the fault cost of each other: not on the likelihood's word.
    near = se2.compose(truth, (0.01, 0.0, 0.2 * DEG))
    assert not _fault_confirmed(scans[20], truth, near, the_rules)
    for off in (PosteriorRefinement(enabled=False), PosteriorRefinement(enabled=True, fault_probability=0.0)):
        assert not _fault_confirmed(scans[20], truth, turned, rules(plan, refinement=off))
