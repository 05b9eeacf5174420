"""Tests of the localizer's robustness: covariance consistency (NEES), degeneracy in a corridor,
lost detection, the covariance propagation, and their errors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.typing import NDArray

import planicp
from planicp import (
    AcceptanceGate,
    DegeneracyRule,
    FusionRule,
    IcpConfig,
    Localizer,
    LostRule,
    MotionNoise,
    PlanMap,
    PlanRaster,
    RecoveryConfig,
    localize,
    se2,
)
from planicp.plans.default_plan import load_default_plan
from planicp.se2 import between, compose
from planicp.sim.crowd import Crowd, crowded_scans
from planicp.sim.experiment import ExperimentConfig, LidarModel, Recording, run_experiment
from planicp.sim.world import Furnishing
from planicp.tracking.fusion_rule import fuse_with_prediction
from planicp.tracking.lost_rule import LostDetector

CHI2_3_95 = 7.8147


def _corridor(length: float = 100.0, width: float = 2.0, res: float = 0.05) -> PlanMap:
    """A closed corridor with 0.2 m walls: interior x 0..length, y 0..width."""
    cols, rows = int(round((length + 0.4) / res)), int(round((width + 0.4) / res))
    walls = np.zeros((rows, cols), dtype=bool)
    walls[:4, :] = walls[-4:, :] = walls[:, :4] = walls[:, -4:] = True
    return PlanMap.from_raster(PlanRaster(walls, res, (-0.2, -0.2, 0.0)))


def _track(plan: PlanMap, recording: Recording, **options: object) -> tuple[NDArray[np.float64], list[object]]:
    localizer = Localizer(plan, tuple(recording.truth[0]), **options)  # type: ignore[arg-type]
    estimates = [localizer.update(s, tuple(o)) for s, o in zip(recording.scans, recording.odometry_in_odom)]
    return np.array([e.pose for e in estimates]), estimates  # type: ignore[attr-defined]


def _rms(values: NDArray[np.float64]) -> float:
    return float(np.sqrt(np.mean(values**2)))


def _wrap(a: NDArray[np.float64]) -> NDArray[np.float64]:
    wrapped: NDArray[np.float64] = (a + math.pi) % (2 * math.pi) - math.pi
    return wrapped


@pytest.mark.parametrize("seed", [0, 1])
def test_corridor_keeps_odometry_along_the_axis_and_corrects_the_rest(seed: int) -> None:
    """A 100 m corridor seen by a 10 m LIDAR: nothing fixes the position along it except near its
    ends. Good odometry (1 % noise, no drift); the heading and the across-corridor position are
    corrected, the along-corridor error stays that of odometry (without the degeneracy handling
    ICP slides by centimetres to decimetres)."""
    plan = _corridor()
    config = ExperimentConfig(
        duration_s=60.0,
        seed=seed,
        lidar=LidarModel(range_max=10.0),
        furnishing=Furnishing(0, 0, 0, 0),
        error_generator=None,
    )
    recording, _ = run_experiment(plan, config)
    odometry = recording.odometry - recording.truth
    planicp = recording.estimate - recording.truth
    along_odometry, along_planicp = _rms(odometry[:, 0]), _rms(planicp[:, 0])
    assert along_planicp <= 1.5 * along_odometry + 0.001, (along_planicp, along_odometry)
    across_planicp, across_odometry = _rms(planicp[:, 1]), _rms(odometry[:, 1])
    heading_planicp, heading_odometry = _rms(_wrap(planicp[:, 2])), _rms(_wrap(odometry[:, 2]))
    assert across_planicp < 0.002 and across_planicp < across_odometry / 3, (across_planicp, across_odometry)
    assert heading_planicp < math.radians(0.02) and heading_planicp < heading_odometry / 2, (
        heading_planicp,
        heading_odometry,
    )
    poses, estimates = _track(plan, recording)
    flagged = [e for e in estimates if e.degeneracy is not None]  # type: ignore[attr-defined]
    assert len(flagged) > 0.5 * len(estimates)
    for e in flagged:
        assert abs(e.degeneracy.axis[0]) > 0.99  # type: ignore[attr-defined]
    # the fit alone (no fusion with the prediction, no degeneracy handling) slides along the axis
    sliding, _ = _track(
        plan, recording, degeneracy=DegeneracyRule(min_constraint=0.0), fusion=FusionRule(max_innovation=0.0)
    )
    assert _rms(sliding[:, 0] - recording.truth[:, 0]) > 3 * along_planicp


def test_covariance_matches_the_error_spread() -> None:
    """NEES of the accepted estimates on the shipped plan: mean near 3 and most below the
    chi-square 95 % bound; the raw, unscaled covariance is clearly overconfident."""
    plan = load_default_plan()
    calibrated_scale = IcpConfig.for_tracking().covariance_scale
    nees: dict[float, list[float]] = {1.0: [], calibrated_scale: []}
    for seed in (0, 1):
        recording, _ = run_experiment(plan, ExperimentConfig(duration_s=40.0, seed=seed))
        for scale in nees:
            _, estimates = _track(plan, recording, config=IcpConfig.for_tracking(covariance_scale=scale))
            for k, e in enumerate(estimates):
                if e.accepted:  # type: ignore[attr-defined]
                    err = np.array(e.pose) - recording.truth[k]  # type: ignore[attr-defined]
                    err[2] = _wrap(err[2])
                    nees[scale].append(float(err @ np.linalg.solve(e.covariance, err)))  # type: ignore[attr-defined]
    calibrated, raw = np.array(nees[calibrated_scale]), np.array(nees[1.0])
    assert len(calibrated) > 700
    assert 1.5 < calibrated.mean() < 4.5, calibrated.mean()
    assert np.mean(calibrated < CHI2_3_95) > 0.88
    assert raw.mean() > 2 * calibrated.mean() and np.mean(raw < CHI2_3_95) < 0.8


def _kidnap(
    seed: int, config: IcpConfig | None = None, recovery: RecoveryConfig | None = None
) -> tuple[int | None, int | None]:
    """Tracks 10 s of one run, then feeds the scans of another run from the first place that is in
    a room (not the corridor) and more than 5 m away, with odometry that continues smoothly: the
    robot was carried there without telling the localizer. Returns (scans until `lost`, scans until
    the error is back under 10 cm and the localizer is no longer lost), None for never (25 scans)."""
    plan = load_default_plan()
    before, _ = run_experiment(plan, ExperimentConfig(duration_s=10.0, seed=seed))
    after, _ = run_experiment(plan, ExperimentConfig(duration_s=60.0, seed=1000 + seed))
    corridor_y = 10.3
    start = next(
        j
        for j in range(1, len(after.times) - 30)
        if math.dist(after.truth[j, :2], before.truth[-1, :2]) > 5.0 and abs(after.truth[j, 1] - corridor_y) > 1.5
    )
    localizer = Localizer(plan, tuple(before.truth[0]), config, recovery=recovery)
    for scan, odom in zip(before.scans, before.odometry_in_odom):
        localizer.update(scan, tuple(odom))
    last, origin = tuple(before.odometry_in_odom[-1]), tuple(after.odometry_in_odom[start - 1])
    lost_at = back_at = None
    for i in range(25):
        j = start + i
        estimate = localizer.update(after.scans[j], compose(last, between(origin, tuple(after.odometry_in_odom[j]))))
        error = math.dist(estimate.pose[:2], after.truth[j, :2])
        if lost_at is None and estimate.lost:
            lost_at = i
        if lost_at is not None and back_at is None and error < 0.1 and not estimate.lost:
            back_at = i
            assert estimate.relocalized and estimate.accepted
    return lost_at, back_at


# The recovery's searches held to their nodes (no ceiling in time, no spare time): a run is then
# the same on any machine and under any load. With the defaults' spare time the searches end
# sooner on an idle machine, later on a loaded one (seed 1 came back after 21 scans while a study
# ran beside the tests).
SAME_ON_ANY_MACHINE = RecoveryConfig(search_time=None, search_spare_time=None)


def test_kidnapped_robot_is_found_again() -> None:
    """The issue's bar: `lost` within 5 scans and back under 10 cm within 20, in 9 of 10 runs."""
    outcomes = [_kidnap(seed, recovery=SAME_ON_ANY_MACHINE) for seed in range(10)]
    good = [lost is not None and lost < 5 and back is not None and back < 20 for lost, back in outcomes]
    assert sum(good) >= 9, outcomes


def test_a_kidnap_is_found_again_with_each_search_within_one_update() -> None:
    """`search_nodes=None, search_time=None`: every search runs to its end in the update that starts it, so the
    place is confirmed on the next scans, sooner than with the default's searches spread over
    updates (docs/benchmarks.md, "Kidnapped robot")."""
    outcomes = [_kidnap(seed, recovery=RecoveryConfig(search_nodes=None, search_time=None)) for seed in range(5)]
    good = [lost is not None and lost < 5 and back is not None and back < 8 for lost, back in outcomes]
    assert sum(good) >= 4, outcomes


def test_no_update_scores_more_search_nodes_than_its_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every search of an update (around the prediction, the recovery's, the searches that find a
    stale search's places again) draws on one budget of `search_nodes`: over a kidnap and its
    recovery no update scores more (but for the three nodes an expansion may add to each search),
    and the search of the whole plan is spread over updates. (Without the update's spare time,
    `search_spare_time`, in which the recovery's searches go on past the nodes.)"""
    from planicp.tracking.recovery import Recovery, SearchBudget

    spent: list[int] = []
    spend = SearchBudget.spend

    def counting(self: SearchBudget, nodes: int) -> None:
        spent[-1] += nodes
        spend(self, nodes)

    new_update = Recovery.new_update

    def per_update(self: Recovery) -> SearchBudget:
        spent.append(0)
        return new_update(self)

    monkeypatch.setattr(SearchBudget, "spend", counting)
    monkeypatch.setattr(Recovery, "new_update", per_update)
    lost, back = _kidnap(3, recovery=RecoveryConfig(search_nodes=10_000, search_time=None, search_spare_time=None))
    assert lost is not None and back is not None, (lost, back)
    searching = [n for n in spent if n > 0]
    # A search may score three nodes past its share (an expansion scores four children), and an
    # update runs up to four: around the prediction, near the last pose, the whole plan, a re-search.
    assert max(spent) <= 10_000 + 4 * 3 and len(searching) >= 5, searching
    assert sum(n >= 10_000 for n in searching) >= 3, searching


def test_a_place_adopted_before_the_whole_plan_was_searched_stays_on_trial() -> None:
    """A place found near the last pose that explains the scans as well as sound tracking did is
    adopted before the spread search of the whole plan has ended (a robot whose odometry broke
    is back at once), and that search goes on: here (kidnap run 0) the place adopted is a
    look-alike 7 m from the robot, and the place the search of the whole plan finds explains the
    next scans better, so it replaces it. (Where the look-alike explains the scans as well as the
    right place, by the recovery's margin, the pose stays provisional with the rival listed.)"""
    plan = load_default_plan()
    before, _ = run_experiment(plan, ExperimentConfig(duration_s=10.0, seed=0))
    after, _ = run_experiment(plan, ExperimentConfig(duration_s=60.0, seed=1000))
    start = next(
        j
        for j in range(1, len(after.times) - 30)
        if math.dist(after.truth[j, :2], before.truth[-1, :2]) > 5.0 and abs(after.truth[j, 1] - 10.3) > 1.5
    )
    # 15,000 nodes an update and no spare time: the whole plan's search ends three updates after the
    # place nearby is adopted (at the default 20,000 the two searches end together and the right
    # place is found).
    recovery = RecoveryConfig(search_nodes=15_000, search_time=None, search_spare_time=None)
    localizer = Localizer(plan, tuple(before.truth[0]), recovery=recovery)
    for scan, odom in zip(before.scans, before.odometry_in_odom):
        localizer.update(scan, tuple(odom))
    last, origin = tuple(before.odometry_in_odom[-1]), tuple(after.odometry_in_odom[start - 1])
    adopted: list[tuple[float, bool]] = []
    for j in range(start, start + 20):
        estimate = localizer.update(after.scans[j], compose(last, between(origin, tuple(after.odometry_in_odom[j]))))
        if estimate.relocalized:
            adopted.append((math.dist(estimate.pose[:2], after.truth[j, :2]), estimate.provisional))
    assert len(adopted) == 2, adopted
    (wrong, on_trial), (right, after_trial) = adopted
    assert wrong > 5.0 and on_trial and right < 0.05 and not after_trial, adopted
    assert math.dist(estimate.pose[:2], after.truth[start + 19, :2]) < 0.05 and not estimate.lost


def test_a_kidnap_is_noticed_when_tracking_with_the_wall_index() -> None:
    """Tracking through the nearest-wall index: its visibility masks see occluders within 0.6 m
    only, so from the wrong room it pairs returns that came through walls. The lost rule counts
    those as unexplained; without that, this run (seed 1) was never found again."""
    lost, back = _kidnap(1, IcpConfig.for_tracking(correspondence_search="wall_index"), SAME_ON_ANY_MACHINE)
    assert lost is not None and lost < 5 and back is not None and back < 20, (lost, back)


def test_relocalize_on_request() -> None:
    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=5.0, seed=4))
    truth = tuple(recording.truth[20])
    localizer = Localizer(plan, (3.0, 15.0, 1.0))  # told nothing useful
    found = localizer.relocalize(recording.scans[20])
    assert found.best is not None and not found.ambiguous
    assert math.dist(localizer.pose[:2], truth[:2]) < 0.05 and not localizer.lost
    estimate = localizer.update(recording.scans[21], tuple(recording.odometry_in_odom[21]))
    assert estimate.accepted and math.dist(estimate.pose[:2], recording.truth[21, :2]) < 0.05


def test_a_symmetric_room_keeps_the_localizer_lost_with_its_hypotheses() -> None:
    """In an empty rectangular room every scan fits the room turned by 180 degrees as well: the
    localizer does not pick one, it stays lost and reports both places."""
    res = 0.05
    walls = np.zeros((int(6.4 / res), int(10.4 / res)), dtype=bool)
    walls[:4, :] = walls[-4:, :] = walls[:, :4] = walls[:, -4:] = True
    plan = PlanMap.from_raster(PlanRaster(walls, res, (-0.2, -0.2, 0.0)))
    config = ExperimentConfig(duration_s=3.0, seed=1, furnishing=Furnishing(0, 0, 0, 0))
    recording, _ = run_experiment(plan, config)
    localizer = Localizer(plan, (5.0, 3.0, 0.0))
    found = localizer.relocalize(recording.scans[0])
    assert found.ambiguous and len(found.candidates) >= 2
    for k in range(1, 6):
        estimate = localizer.update(recording.scans[k], tuple(recording.odometry_in_odom[k]))
        assert estimate.lost and not estimate.relocalized
        assert len(estimate.hypotheses) >= 2
    truth = recording.truth[5]
    assert min(math.dist(h[:2], truth[:2]) for h in estimate.hypotheses) < 0.1


def test_places_followed_while_lost_move_with_the_odometry_over_a_scan_too_small_to_align() -> None:
    """A scan with too few points is not aligned; while lost, the places the recovery follows move
    with the odometry over it, so that they are where the robot is when the next scan comes."""
    res = 0.05
    walls = np.zeros((int(6.4 / res), int(10.4 / res)), dtype=bool)
    walls[:4, :] = walls[-4:, :] = walls[:, :4] = walls[:, -4:] = True
    plan = PlanMap.from_raster(PlanRaster(walls, res, (-0.2, -0.2, 0.0)))
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=8.0, seed=1, furnishing=Furnishing(0, 0, 0, 0)))
    localizer = Localizer(plan, (5.0, 3.0, 0.0))
    localizer.relocalize(recording.scans[40])
    estimate = localizer.update(recording.scans[41], tuple(recording.odometry_in_odom[41]))
    assert estimate.lost and len(estimate.hypotheses) >= 2  # the room and the room turned round
    assert math.dist(recording.truth[41, :2], recording.truth[46, :2]) > 0.2  # the robot drives on
    estimate = localizer.update(np.zeros((0, 2)), tuple(recording.odometry_in_odom[46]))
    assert estimate.lost and estimate.result is None
    assert min(math.dist(h[:2], recording.truth[46, :2]) for h in estimate.hypotheses) < 0.05
    estimate = localizer.update(recording.scans[47], tuple(recording.odometry_in_odom[47]))
    assert min(math.dist(h[:2], recording.truth[47, :2]) for h in estimate.hypotheses) < 0.05


def test_lost_detector_rules() -> None:
    detector = LostDetector(LostRule(window=3, min_score=0.5, max_rejections=2))
    assert not detector.update(0.9, True) and not detector.update(0.1, True)  # window not full yet
    assert detector.update(0.1, True)  # mean 0.37 < 0.5
    assert detector.score == pytest.approx((0.9 + 0.1 + 0.1) / 3)
    detector.reset()
    assert not detector.update(0.9, False)
    assert detector.update(0.9, False)  # two rejections in a row
    assert not detector.update(0.9, True) and math.isfinite(detector.score)
    assert detector.update(float("nan"), True) is False  # NaN counts as 0: mean (0.9 + 0.9 + 0) / 3 = 0.6
    detector.reset()
    detector.declare_lost()
    assert detector.lost
    detector.reset()
    assert not detector.lost


def test_the_lost_rule_scores_recent_scans_only() -> None:
    """A crowd's first scans, poorly explained before any scan was explained well enough for
    later ones to continue, are not still counted after many scans held as clutter (the crowd
    bench's second drive at 40 people was declared lost at update 20 by two scores from updates
    0 and 1); five poorly explained scans in a row still say lost."""
    detector = LostDetector(LostRule(window=5, min_score=0.35, max_rejections=3))
    assert not detector.update(0.14, False) and not detector.update(0.15, False)
    assert not detector.update(0.26, True)
    for _ in range(14):
        assert not detector.hold()
    verdicts = [detector.update(0.37, True), detector.hold(), detector.hold(), detector.update(0.38, True)]
    assert verdicts == [False] * 4 and detector.scores == [0.37, 0.38]
    assert not any([detector.update(0.14, True), detector.update(0.15, True), detector.update(0.26, True)])
    assert detector.update(0.30, True)  # the last 5 all scored: mean 0.25
    assert detector.score == pytest.approx((0.38 + 0.14 + 0.15 + 0.26 + 0.30) / 5)
    detector.reset()
    assert not detector.update(0.9, False) and not detector.hold() and not detector.update(0.9, False)
    assert detector.update(0.9, False) and detector.rejections == 3  # in a row across a held scan
    detector.reset()
    assert not detector.update(0.9, False) and not detector.update(0.9, False)
    assert not detector.hold(accepted=True) and detector.rejections == 0  # a held scan's accepted fit ends the row
    assert not detector.update(0.9, False) and not detector.update(0.9, False)
    for cfg, message in (
        ({"min_inlier_ratio": 0.0}, "min_inlier_ratio must be in"),
        ({"confirmations": 0}, "confirmations must be at least 1"),
        ({"margin": 2.0}, "margin must be in"),
        ({"local_radius": -1.0}, "local_radius"),
        ({"search": "global"}, "search must be a RelocalizationConfig"),
    ):
        with pytest.raises((ValueError, TypeError), match=message):
            RecoveryConfig(**cfg)  # type: ignore[arg-type]
    for bad, message in (
        ({"window": 0}, "window must be at least 1"),
        ({"min_score": 1.5}, "min_score must be in"),
        ({"max_rejections": 0}, "max_rejections must be at least 1"),
    ):
        with pytest.raises(ValueError, match=message):
            LostRule(**bad)  # type: ignore[arg-type]


def test_motion_noise_propagation() -> None:
    still = MotionNoise(0.0, 0.0, 0.0, 0.0, 0.0)
    p0 = np.diag([0.01, 0.02, 0.001])
    np.testing.assert_allclose(still.propagate(p0, (1.0, 2.0, 0.3), (0.0, 0.0, 0.0)), p0)
    # Driving 10 m straight ahead (+x) with an uncertain heading spreads the position sideways (+y):
    # var_y grows by 10^2 * var_yaw, and x and y do not correlate with each other.
    p1 = still.propagate(np.diag([0.0, 0.0, 1e-4]), (0.0, 0.0, 0.0), (10.0, 0.0, 0.0))
    assert p1[1, 1] == pytest.approx(100 * 1e-4) and p1[0, 0] == pytest.approx(0.0, abs=1e-15)
    assert p1[1, 2] == pytest.approx(10 * 1e-4)
    # The motion's own noise, rotated into the map: facing +y, forward noise is y noise.
    noisy = MotionNoise(0.1, 0.0, 0.0, 0.0, 0.0)
    p2 = noisy.propagate(np.zeros((3, 3)), (0.0, 0.0, math.pi / 2), (2.0, 0.0, 0.0))
    assert p2[0, 0] == pytest.approx(0.04) and p2[1, 1] == pytest.approx(0.04) and p2[2, 2] == 0.0
    with pytest.raises(ValueError, match="translation_fraction must be a finite number >= 0"):
        MotionNoise(translation_fraction=-0.1)
    # Malformed arguments are refused by name; a motion beyond any building (where the covariance
    # would overflow) too.
    with pytest.raises(ValueError, match="covariance must be 3x3"):
        noisy.propagate(np.eye(2), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="pose must be"):
        noisy.propagate(np.eye(3), (0.0, 0.0), (1.0, 0.0, 0.0))
    with pytest.raises(TypeError, match="motion must hold real numbers"):
        noisy.propagate(np.eye(3), (0.0, 0.0, 0.0), "abc")
    with pytest.raises(ValueError, match=r"motion has a coordinate of 1\.0+e\+300 m, beyond \+-1e\+09 m"):
        noisy.propagate(np.eye(3), (0.0, 0.0, 0.0), (1e300, 1e300, 0.0))


def test_fusion_with_the_prediction() -> None:
    """The Kalman update of the prediction by a fit: equal covariances meet halfway and halve; a
    fit that does not constrain the corridor's axis keeps the prediction along it; an innovation
    over the rule's bound (odometry faulted) leaves the fit alone in the localizer."""
    corridor = _corridor(length=60.0)
    x = np.linspace(-8.0, 8.0, 400)
    scan = np.concatenate([np.column_stack([x, np.full_like(x, 1.0)]), np.column_stack([x, np.full_like(x, -1.0)])])
    fit = localize(scan, corridor, (30.0, 1.02, 0.01))
    assert not np.isfinite(fit.covariance).all()  # nothing fixes x
    covariance = np.diag([1e-4, 1e-4, 1e-4])
    boxed = dataclasses.replace(fit, covariance=covariance)
    predicted = (fit.pose[0] + 0.02, fit.pose[1] - 0.01, se2.wrap_angle(fit.pose[2] + 0.004))
    pose, fused = fuse_with_prediction(boxed, predicted, covariance)
    np.testing.assert_allclose(pose, np.add(fit.pose, predicted) / 2, atol=1e-12)
    np.testing.assert_allclose(fused, covariance / 2, atol=1e-15)
    assert FusionRule().innovation(boxed, predicted, covariance) == pytest.approx((4 + 1 + 0.16) * 1e-4 / 2e-4)
    # Across the corridor and in heading the fit is far more precise than the prediction, so it
    # decides; along it the fit says nothing and the prediction is kept.
    pose, fused = fuse_with_prediction(fit, predicted, covariance)
    assert pose[0] == pytest.approx(predicted[0], abs=1e-5)
    assert pose[1] == pytest.approx(fit.pose[1], abs=1e-4) and pose[2] == pytest.approx(fit.pose[2], abs=1e-4)
    assert fused[0, 0] == pytest.approx(1e-4, rel=1e-3) and fused[1, 1] < 1e-5
    with pytest.raises(ValueError, match="max_innovation must be a number >= 0"):
        FusionRule(max_innovation=-1.0)
    with pytest.raises(TypeError, match="fusion must be a planicp.FusionRule"):
        Localizer(corridor, (30.0, 1.0, 0.0), fusion=16.0)  # type: ignore[arg-type]


def test_an_odometry_fault_is_not_fused() -> None:
    """An 8-degree odometry step (within the gate's 10 degrees, so no search is involved): the fit and
    the prediction disagree far beyond their covariances, so the accepted pose is the fit's; a
    plausible prediction is fused (the pose moves off the fit)."""
    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=3.0, seed=4, furnishing=Furnishing(0, 0, 0, 0)))
    localizer = Localizer(plan, tuple(recording.truth[0]))
    for scan, odom in zip(recording.scans[:-1], recording.odometry_in_odom[:-1]):
        estimate = localizer.update(scan, tuple(odom))
    assert estimate.accepted and estimate.pose != estimate.result.pose  # type: ignore[union-attr]
    step = compose(tuple(recording.odometry_in_odom[-1]), (0.0, 0.0, math.radians(8.0)))
    faulted = localizer.update(recording.scans[-1], step)
    assert faulted.accepted and faulted.result is not None
    assert localizer.fusion.innovation(faulted.result, faulted.predicted_pose, np.diag([1e-4, 1e-4, 1e-5])) > 100
    assert faulted.pose == faulted.result.pose
    assert math.dist(faulted.pose[:2], recording.truth[-1, :2]) < 0.02


def test_translation_constraint_and_degeneracy_rule() -> None:
    corridor = _corridor(length=60.0)
    x = np.linspace(-8.0, 8.0, 400)
    scan = np.concatenate([np.column_stack([x, np.full_like(x, 1.0)]), np.column_stack([x, np.full_like(x, -1.0)])])
    result = localize(scan, corridor, (30.0, 1.0, 0.0))
    axis, weak, strong = result.translation_constraint()
    assert abs(axis[0]) > 0.999 and weak < 1.0 and strong > 100
    degeneracy = DegeneracyRule().check(result)
    assert degeneracy is not None and degeneracy.weak == weak
    assert DegeneracyRule(min_constraint=0.0).check(result) is None
    # Near the corridor's end its end wall constrains the axis too.
    t = np.linspace(-0.9, 0.9, 100)
    along = np.linspace(-1.0, 7.0, 300)
    end = np.concatenate(
        [
            np.column_stack([along, np.full_like(along, 1.0)]),
            np.column_stack([along, np.full_like(along, -1.0)]),
            np.column_stack([np.full_like(t, -1.0), t]),
        ]
    )
    near_end = localize(end, corridor, (1.0, 1.0, 0.0))
    assert near_end.translation_constraint()[1] > 50
    assert DegeneracyRule().check(near_end) is None
    with pytest.raises(ValueError, match="min_constraint"):
        DegeneracyRule(min_constraint=-1.0)


def test_localizer_covariance_and_reset_validation() -> None:
    plan = _corridor(length=10.0)
    localizer = Localizer(plan, (5.0, 1.0, 0.0))
    np.testing.assert_allclose(np.sqrt(np.diag(localizer.covariance)), [0.1, 0.1, math.radians(5.0)])
    localizer.reset((4.0, 1.0, 0.0), np.diag([0.04, 0.04, 0.01]))
    np.testing.assert_allclose(localizer.covariance, np.diag([0.04, 0.04, 0.01]))
    bad_inputs: list[tuple[object, type[Exception], str]] = [
        (np.eye(2), ValueError, "must be 3x3"),
        (np.diag([1.0, -1.0, 1.0]), ValueError, "positive semi-definite"),
        (np.full((3, 3), np.nan), ValueError, "must be finite"),
        (np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), ValueError, "symmetric"),
        ([["a"] * 3] * 3, TypeError, "real numbers"),
    ]
    for bad, error, message in bad_inputs:
        with pytest.raises(error, match=message):
            localizer.reset((4.0, 1.0, 0.0), bad)
        with pytest.raises(error, match=message):
            Localizer(plan, (5.0, 1.0, 0.0), initial_covariance=bad)
    np.testing.assert_allclose(localizer.covariance, np.diag([0.04, 0.04, 0.01]))  # unchanged by the failures


def test_a_crowd_taking_half_of_the_returns() -> None:
    """People standing 0.7-3 m around the robot block about half of the beams. The Localizer's
    defaults (automatic trimming, the occlusion rule, fusion with the prediction) keep the error
    near twice the empty floor's, without ever declaring themselves lost; plain ICP without them is
    dragged by the crowd near the walls."""
    plan = load_default_plan()
    config = ExperimentConfig(duration_s=30.0, seed=2, furnishing=Furnishing(0, 0, 0, 0))
    recording, world = run_experiment(plan, config)
    empty_scans, _ = crowded_scans(recording, world.floor, config.lidar, Crowd(0), seed=2)
    crowd_scans, blocked = crowded_scans(recording, world.floor, config.lidar, Crowd(25), seed=2)
    assert 0.45 < np.mean(blocked) < 0.6

    def track(scans: list[NDArray[np.float64]], **options: object) -> tuple[float, int]:
        localizer = Localizer(plan, tuple(recording.truth[0]), **options)  # type: ignore[arg-type]
        estimates = [localizer.update(s, tuple(o)) for s, o in zip(scans, recording.odometry_in_odom)]
        poses = np.array([e.pose for e in estimates])
        return _rms(np.hypot(*(poses[:, :2] - recording.truth[:, :2]).T)), sum(e.lost for e in estimates)

    empty, _ = track(empty_scans)
    crowded, lost = track(crowd_scans)
    plain, _ = track(crowd_scans, config=IcpConfig(), occlusion=False, fusion=FusionRule(max_innovation=0.0))
    assert empty < 0.003 and crowded < 2.2 * empty and lost == 0, (empty, crowded, lost)
    assert plain > 10 * crowded, (plain, crowded)
    with pytest.raises(ValueError, match="people"):
        Crowd(-1)
    with pytest.raises(ValueError, match="need min_distance <= max_distance"):
        Crowd(3, min_distance=2.0, max_distance=1.0)
    with pytest.raises(ValueError, match="need min_radius <= max_radius"):
        Crowd(3, min_radius=0.3, max_radius=0.2)
    # Nowhere free around a place far outside the floor: refused, not an endless search.
    with pytest.raises(ValueError, match="found free places for only 0 of 3 people"):
        Crowd(3).place(np.random.default_rng(0), (1000.0, 1000.0), world.floor)


def test_the_recovery_refuses_places_the_scan_sees_through() -> None:
    """A place whose walls the scan's returns pass through is contradicted (`max_beyond`): the
    true place of a scan is not, a place 2 m off in the corridor is."""
    from planicp.tracking.occlusion_rule import OcclusionFilter, OcclusionRule
    from planicp.tracking.recovery import Recovery

    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=2.0, seed=3, furnishing=Furnishing(0, 0, 0, 0)))
    scan, truth = recording.scans[-1], tuple(recording.truth[-1])
    recovery = Recovery(
        plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate(), OcclusionFilter(plan, OcclusionRule())
    )
    assert not recovery._contradicted(scan, truth)
    shifted = (truth[0] + 2.0, truth[1] + 1.0, truth[2] + 0.5)
    assert recovery._contradicted(scan, shifted)
    assert not Recovery(
        plan,
        RecoveryConfig(max_beyond=1.0),
        IcpConfig.for_tracking(),
        AcceptanceGate(),
        OcclusionFilter(plan, OcclusionRule()),
    )._contradicted(scan, shifted)
    for bad in (0.0, 1.5, math.nan):
        with pytest.raises(ValueError, match="max_beyond must be in"):
            RecoveryConfig(max_beyond=bad)


def test_clutter_is_not_mistaken_for_a_kidnap() -> None:
    """On a generated floor with diagonal walls the robot crosses places where the plan explains
    less than half of the scans. Before the continuity check the localizer declared itself lost
    there and adopted a wrong place 2-6 m away that explained more of the clutter.

    (This floor's paper around the building is larger than the building, so until the simulation
    kept the robot inside the building (`planicp.sim.building_outline`, issue 22) the robot drove
    outside it, where the plan explained a fifth of some scans. Inside, twelve times the demo's
    furniture makes the clutter.)"""
    from planicp import sim as synthetic
    from planicp.sim.world import Furnishing

    floor = synthetic.generate_floor(11, "diagonal")
    plan = PlanMap.from_raster(PlanRaster(floor.walls[::-1], floor.resolution, (floor.origin[0], floor.origin[1], 0.0)))
    crowded = Furnishing(cabinets=36.0, blocks=9.6, tables=24.0, people=12.0)
    for seed in (0, 3):
        recording, _ = run_experiment(plan, ExperimentConfig(duration_s=60.0, seed=seed, furnishing=crowded))
        error = np.hypot(*(recording.estimate[:, :2] - recording.truth[:, :2]).T)
        assert error.max() < 0.05, (seed, error.max())
        assert recording.lost is not None and not recording.lost.any()
        # The clutter is there: at the true pose the plan explains less than half of some scans.
        explained = [
            localize(s, plan, tuple(t), IcpConfig.for_tracking()).inlier_ratio
            for s, t in zip(recording.scans[::10], recording.truth[::10])
        ]
        assert min(explained) < 0.5, min(explained)  # people now give way to the robot: 0.46 on seed 0


def test_continuity_rule() -> None:
    from planicp import ContinuityRule

    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=6.0, seed=6))
    rule = ContinuityRule()
    motion = between(tuple(recording.odometry_in_odom[10]), tuple(recording.odometry_in_odom[12]))
    assert rule.continues(recording.scans[12], recording.scans[10], motion)
    far = np.argmax(np.hypot(*(recording.truth[:, :2] - recording.truth[10, :2]).T))
    assert math.dist(recording.truth[far, :2], recording.truth[10, :2]) > 1.0
    moved = between(tuple(recording.odometry_in_odom[far]), tuple(recording.odometry_in_odom[far]))
    assert not rule.continues(recording.scans[far], recording.scans[10], moved)  # as if nothing moved
    assert not rule.continues(np.zeros((2, 2)), recording.scans[10], motion)
    # The share itself (`overlap`, what a lost robot's search is begun by): most of a
    # continuation, none of a scan too small to align, and none of one whose alignment had to
    # correct the odometry's motion by more than `max_correction`, however well it overlaps then.
    assert rule.overlap(recording.scans[12], recording.scans[10], motion) >= rule.min_overlap
    assert rule.overlap(np.zeros((2, 2)), recording.scans[10], motion) == 0.0
    wide = ContinuityRule(max_distance=0.2)
    scan = recording.scans[10]
    assert wide.overlap(scan, scan, (0.3, 0.0, 0.0)) == 0.0
    assert ContinuityRule(max_distance=0.2, max_correction=0.5).overlap(scan, scan, (0.3, 0.0, 0.0)) > 0.9
    with pytest.raises(ValueError, match="min_overlap"):
        ContinuityRule(min_overlap=0.0)
    with pytest.raises(ValueError, match="max_correction"):
        ContinuityRule(max_correction=-1.0)


def test_a_views_ranges_classify_returns_almost_as_an_exact_cast_does() -> None:
    """A `WallView`'s ranges come from the visibility cast (the plan's wall points rastered at
    7.5 cm), not from an exact cast through the plan image (5 cm) as the occlusion rule's. Over
    random poses and scans that face any way, wrap past +-pi or hold a single return, the two
    classify all but a few returns alike. The rest are returns whose direction passes within a
    visibility cell (0.11 m) of a wall's end, where the coarser raster lengthens the wall: the
    view's answer is then one the exact cast gives for a direction within that distance."""
    from planicp import _core
    from planicp.tracking.occlusion_rule import OcclusionFilter, OcclusionRule

    plan = load_default_plan()
    rule = OcclusionRule()
    occlusion = OcclusionFilter(plan, rule)
    raster = plan.raster
    assert raster is not None
    exact_grid = _core.OccupancyGrid(
        np.ascontiguousarray(raster.walls[::-1]), raster.resolution, (raster.origin[0], raster.origin[1])
    )
    step = 2 * math.pi / rule.beams
    cell, slack = 0.075 * math.sqrt(2), 0.08
    rng = np.random.default_rng(5)
    disagreements, total, inside_a_wall = 0, 0, 0
    for trial in range(30):
        pose = (rng.uniform(2.0, 28.0), rng.uniform(2.0, 18.0), rng.uniform(-math.pi, math.pi))
        centre, width = rng.uniform(-math.pi, math.pi), rng.choice([0.0, 0.3, math.radians(270), 2 * math.pi])
        bearings = centre + rng.uniform(-width / 2, width / 2, size=1 if width == 0.0 else 500)
        r = rng.uniform(0.3, 12.0, size=len(bearings))
        points = np.column_stack([r * np.cos(bearings), r * np.sin(bearings)])
        # The occlusion rule's native classification is the exact one, bit for bit.
        exact = occlusion.classify(points, pose)
        view = plan.view_from(pose, float(r.max()) + 1.0, rule.beams)
        short, beyond = view.classify(points, rule.margin)
        expected = exact_grid.cast(pose, -math.pi, step, rule.beams, 0.0, 1e6)
        expected = np.where(np.isfinite(expected), expected, np.inf)
        if not np.any(expected > 0.0):
            # Inside a wall, where no robot stands: the exact cast reads 0, the view (wall faces
            # only) sees the wall's inside.
            inside_a_wall += 1
            continue
        k = np.round((np.arctan2(points[:, 1], points[:, 0]) + math.pi) / step).astype(np.int64) % rule.beams
        around = [expected[(k - 1) % rule.beams], expected[k], expected[(k + 1) % rule.beams]]
        exact_short = r < np.maximum.reduce(around) - rule.margin
        exact_beyond = r > np.minimum.reduce(around) + rule.margin
        np.testing.assert_array_equal(exact[0], exact_short, err_msg=str(trial))
        np.testing.assert_array_equal(exact[1], exact_beyond, err_msg=str(trial))
        differ = np.flatnonzero((short != exact_short) | (beyond != exact_beyond))
        for i in differ:
            # The exact ranges of the directions within a cell of the return's line of sight, at
            # the nearest wall either cast sees there.
            view_ranges = view.ranges[(k[i] + np.arange(-1, 2)) % rule.beams]
            distance = max(min(r[i], expected[k[i]], *view_ranges), 0.3)
            half = int(math.ceil(cell / distance / step)) + 2
            window = expected[(k[i] + np.arange(-half, half + 1)) % rule.beams]
            lo, hi = float(window.min()), float(window.max())
            assert short[i] in {r[i] < lo - rule.margin - slack, r[i] < hi - rule.margin + slack}, (trial, i)
            assert beyond[i] in {r[i] > lo + rule.margin - slack, r[i] > hi + rule.margin + slack}, (trial, i)
        disagreements += len(differ)
        total += len(r)
    assert disagreements < 0.03 * total and inside_a_wall < 5, (disagreements, total, inside_a_wall)
    assert occlusion.classify(np.zeros((0, 2)), (5.0, 5.0, 0.0))[0].shape == (0,)


def test_the_native_occlusion_classification_refuses_bad_arguments() -> None:
    """`OccupancyGrid.classify_returns` and `visibility_range` name what is wrong."""
    from planicp import _core

    grid = _core.OccupancyGrid(np.eye(40, dtype=bool), 0.1, (0.0, 0.0))
    points = np.array([[1.0, 0.0], [0.0, 1.0]])
    in_front, beyond = grid.classify_returns((2.0, 1.0, 0.0), points, 0.2, 720)
    assert in_front.shape == beyond.shape == (2,)
    with pytest.raises(planicp.PlanicpError, match="margin must be a finite number"):
        grid.classify_returns((2.0, 1.0, 0.0), points, -0.1, 720)
    with pytest.raises(planicp.PlanicpError, match="directions = 4: must be between 8"):
        grid.classify_returns((2.0, 1.0, 0.0), points, 0.2, 4)
    with pytest.raises(planicp.PlanicpError, match="directions must be a non-negative integer"):
        grid.classify_returns((2.0, 1.0, 0.0), points, 0.2, -1)
    with pytest.raises(planicp.PlanicpError, match="sensor pose"):
        grid.classify_returns((math.nan, 1.0, 0.0), points, 0.2, 720)
    settings = IcpConfig()._native
    assert _core.visibility_range(points, settings) == pytest.approx(1.0 + 0.25)
    with pytest.raises(planicp.PlanicpError, match=r"shape \(N, 2\)"):
        _core.visibility_range(np.zeros((3, 3)), settings)


def test_a_view_gives_the_alignment_its_visible_points() -> None:
    """`PlanMap.view_from` gives the visible points and the wall ranges; `localize(view=...)`
    aligns against exactly those points, and refuses a view from elsewhere or of another type."""
    plan = _corridor(length=10.0)  # interior x 0..10, y 0..2
    pose = (5.0, 1.0, 0.0)
    view = plan.view_from(pose, max_range=8.0, directions=720)
    assert view.pose == pose and view.ranges.shape == (720,)
    # Base angle 0 (direction 360) looks down the corridor at the x = 10 wall, 5 m away; base
    # angle pi/2 (direction 540) at the y = 2 wall, 1 m away.
    assert view.ranges[360] == pytest.approx(5.0, abs=0.08)
    assert view.ranges[540] == pytest.approx(1.0, abs=0.08)
    np.testing.assert_array_equal(view.visible_indices, plan.visible_indices(pose, 8.0))
    scan = plan.points[view.visible_indices][::3] - np.array([5.02, 0.99])
    config = IcpConfig.for_tracking()
    shared = localize(scan, plan, pose, config, view=view)
    assert shared.num_target_points == len(view.visible_indices)
    assert shared.pose == localize(scan, plan, pose, config).pose
    # Over the arc a scan spans (returns ahead only): the other directions read NaN, and the
    # scan's returns are judged as over the full circle.
    ahead = scan[scan[:, 0] > 0.5]
    arc = plan.view_from(pose, 8.0, 720, scan=ahead)
    assert 0.3 < np.mean(np.isnan(arc.ranges)) < 0.75
    for got, want in zip(arc.classify(ahead, 0.2), view.classify(ahead, 0.2)):
        np.testing.assert_array_equal(got, want)
    # Without ranges: the same visible points, nothing to classify with.
    bare = plan.view_from(pose, 8.0, 720, scan=ahead, ranges=False)
    np.testing.assert_array_equal(bare.visible_indices, arc.visible_indices)
    assert bare.ranges.shape == (0,)
    with pytest.raises(ValueError, match="without ranges"):
        bare.classify(ahead, 0.2)
    # Only as far as the returns can pair (returns within 2 m ahead, pairing up to 0.5 m): the
    # corridor's end wall, 5 m ahead, is not among the visible points; every visible point
    # within 0.5 m of a return is.
    from planicp import _core

    near = ahead[np.hypot(*ahead.T) < 2.0]
    pair = _core.largest_pair_distance(config._native)
    assert pair == pytest.approx(config.max_correspondence_distance * max(config.correspondence_schedule))
    reached = plan.view_from(pose, 8.0, 720, scan=near, ranges=False, pair_distance=0.5)
    seen = plan.points[reached.visible_indices]
    assert len(seen) and seen[:, 0].max() < 5.0 + 2.0 + 0.5 + 0.1
    assert (plan.points[bare.visible_indices][:, 0] > 9.9).any() and not (seen[:, 0] > 9.9).any()
    returns = near + np.array(pose[:2])
    for i in bare.visible_indices:
        if np.hypot(*(returns - plan.points[i]).T).min() <= 0.5:
            assert i in set(reached.visible_indices.tolist())
    with pytest.raises(ValueError, match="pass scan= and ranges=False"):
        plan.view_from(pose, 8.0, 720, scan=near, pair_distance=0.5)
    with pytest.raises(ValueError, match="pass scan= and ranges=False"):
        plan.view_from(pose, 8.0, 720, ranges=False, pair_distance=0.5)
    with pytest.raises(ValueError, match="pair_distance must be a positive"):
        plan.view_from(pose, 8.0, 720, scan=near, ranges=False, pair_distance=0.0)
    with pytest.raises(planicp.PlanicpError, match="pass the scan too"):
        plan._native.view_from(pose, 8.0, 720, None, False, 0.5)
    with pytest.raises(planicp.PlanicpError, match="pair_distance"):
        plan._native.view_from(pose, 8.0, 720, near, True, 0.5)  # ranges stop at the walls, however far
    with pytest.raises(ValueError, match="was cast from"):
        localize(scan, plan, (5.5, 1.0, 0.0), config, view=view)
    with pytest.raises(TypeError, match="view must be a planicp.WallView"):
        localize(scan, plan, pose, config, view=view.visible_indices)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="directions must be at least 8"):
        plan.view_from(pose, 8.0, directions=4)
    with pytest.raises(ValueError, match="max_range"):
        plan.view_from(pose, 0.0)
    with pytest.raises(ValueError, match="margin"):
        view.classify(scan, -0.1)


def test_occlusion_rule_leaves_out_returns_in_front_of_walls() -> None:
    from planicp import OcclusionRule
    from planicp.tracking.occlusion_rule import OcclusionFilter

    plan = _corridor(length=10.0)  # interior x 0..10, y 0..2
    filt = OcclusionFilter(plan, OcclusionRule())
    pose = (5.0, 1.0, 0.0)
    # Two returns on the walls (y = 2 and x = 10) and one on a person 1 m ahead (the wall is 5 m away).
    points = np.array([[0.0, 1.0], [5.0, 0.0], [1.0, 0.0], [4.9, 0.1]])
    np.testing.assert_array_equal(filt.in_front(points, pose), [False, False, True, False])
    # Beyond the walls: a return 1.5 m past the y = 2 wall could not come from this pose.
    beyond_wall = np.vstack([points, [[0.0, 2.5]]])
    in_front, beyond = filt.classify(beyond_wall, pose)
    np.testing.assert_array_equal(in_front, [False, False, True, False, False])
    np.testing.assert_array_equal(beyond, [False, False, False, False, True])
    # In the Localizer: the estimate says which points were aligned; False switches the rule off.
    recording, _ = run_experiment(load_default_plan(), ExperimentConfig(duration_s=3.0, seed=2))
    localizer = Localizer(load_default_plan(), tuple(recording.truth[0]))
    estimate = localizer.update(recording.scans[0], tuple(recording.odometry_in_odom[0]))
    if estimate.kept is not None:
        assert estimate.kept.shape == (len(recording.scans[0]),)
        assert estimate.result is not None and len(estimate.result.inlier_mask) == int(estimate.kept.sum())
    off = Localizer(load_default_plan(), tuple(recording.truth[0]), occlusion=False)
    assert off.update(recording.scans[0], tuple(recording.odometry_in_odom[0])).kept is None
    with pytest.raises(TypeError, match="occlusion must be an OcclusionRule"):
        Localizer(plan, pose, occlusion=0.2)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="margin must be a positive"):
        OcclusionRule(margin=0.0)
