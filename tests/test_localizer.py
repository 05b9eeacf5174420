"""The Localizer: tracking with drifting odometry, the map -> odom transform, the acceptance gate
and reset."""

from __future__ import annotations

import math
import time
from statistics import NormalDist
from typing import Any

import numpy as np
import pytest

from planicp import AcceptanceGate, FusionRule, IcpConfig, Localizer, PlanMap, localize, relocalize, se2
from planicp import sim as syn
from planicp.tracking.fusion_rule import finite_covariance
from planicp.tracking.recovery import Recovery, RecoveryConfig
from planicp.tracking.student_t import student_t_quantile

DEG = math.pi / 180.0
Pose = tuple[float, float, float]


def clear_path(floor: Any, rng: np.random.Generator, steps: int, step: float, clearance: float) -> list[Pose]:
    """`steps + 1` poses `step` metres apart along a straight line through free space, every one at
    least `clearance` metres (as a square window of cells) from walls and furniture; the heading
    follows the line with a slow +-10 deg weave so that the robot also turns."""
    occ = floor.occupied()
    res = floor.resolution
    ox, oy = floor.origin
    k = int(math.ceil(clearance / res))
    rows, cols = occ.shape
    for _ in range(2000):
        x0, y0, _ = floor.sample_pose(rng, clearance=clearance)
        heading = float(rng.uniform(-math.pi, math.pi))
        poses = []
        for i in range(steps + 1):
            x = x0 + i * step * math.cos(heading)
            y = y0 + i * step * math.sin(heading)
            c, r = int((x - ox) / res), int((y - oy) / res)
            if not (k <= r < rows - k and k <= c < cols - k) or occ[r - k : r + k + 1, c - k : c + k + 1].any():
                break
            poses.append((x, y, se2.wrap_angle(heading + 10 * DEG * math.sin(i / 6.0))))
        else:
            return poses
    raise AssertionError("no straight free path found")


def drifting_odometry(truth: list[Pose], start: Pose, drift: Pose) -> list[Pose]:
    """Odometry readings (T_odom_base) whose every increment is the true one composed with `drift`."""
    odom = [start]
    for a, b in zip(truth[:-1], truth[1:]):
        odom.append(se2.compose(se2.compose(odom[-1], se2.between(a, b)), drift))
    return odom


def error(a: Pose, b: Pose) -> tuple[float, float]:
    dx, dy, dyaw = se2.between(a, b)
    return math.hypot(dx, dy), abs(dyaw)


@pytest.fixture(scope="module")
def office() -> Any:
    return syn.generate_floor(3, "office")


@pytest.fixture(scope="module")
def plan(office: Any) -> PlanMap:
    return PlanMap.from_points(office.wall_points())


@pytest.fixture(scope="module")
def path(office: Any) -> list[Pose]:
    return clear_path(office, np.random.default_rng(42), steps=40, step=0.1, clearance=0.6)


@pytest.fixture(scope="module")
def scans(office: Any, path: list[Pose]) -> list[np.ndarray]:
    rng = np.random.default_rng(7)
    return [syn.simulate_scan(office, p, rng)[0] for p in path]


DRIFT = (0.002, 0.0, 0.1 * DEG)  # added to every 10 cm odometry increment


def track(plan: PlanMap, path: list[Pose], scans: list[np.ndarray], config: IcpConfig | None = None) -> Any:
    """Tracks the path from the true start with odometry drifting by DRIFT per step."""
    odom = drifting_odometry(path, (3.0, -1.0, 0.7), DRIFT)
    loc = Localizer(plan, path[0], config)
    estimates = [loc.update(s, o) for s, o in zip(scans, odom)]
    return odom, estimates, loc


@pytest.fixture(scope="module")
def tracking(plan: PlanMap, path: list[Pose], scans: list[np.ndarray]) -> Any:
    return track(plan, path, scans)


def test_odometry_drift_is_large(path: list[Pose], tracking: Any) -> None:
    odom, _, _ = tracking
    assert len(path) == 41
    # dead reckoning from the true start with the drifting odometry
    dead = [se2.compose(path[0], se2.between(odom[0], o)) for o in odom]
    odom_error = error(path[-1], dead[-1])[0]
    assert odom_error > 0.10, f"odometry drift of only {odom_error:.3f} m: the tests would prove nothing"


def test_every_estimate_accepted_with_default_settings(tracking: Any) -> None:
    """Each scan starts ICP within ~2 mm / 0.1 deg of the truth: nothing should be rejected."""
    _, estimates, _ = tracking
    rejected = [(i, e.reason, repr(e.result)) for i, e in enumerate(estimates) if not e.accepted]
    assert not rejected, rejected


def test_every_estimate_accepted_with_a_larger_iteration_budget(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    _, estimates, _ = track(plan, path, scans, IcpConfig(max_iterations=100))
    rejected = [(i, e.reason) for i, e in enumerate(estimates) if not e.accepted]
    assert not rejected, rejected
    assert error(path[-1], estimates[-1].pose)[0] < 0.05


def test_tracking_beats_drifting_odometry(path: list[Pose], tracking: Any) -> None:
    odom, estimates, loc = tracking
    assert sum(e.accepted for e in estimates) >= 0.9 * len(estimates)
    final_t, final_r = error(path[-1], estimates[-1].pose)
    assert final_t < 0.05 and final_r < 0.5 * DEG, (final_t, math.degrees(final_r))
    worst = max(error(t, e.pose)[0] for t, e in zip(path, estimates))
    assert worst < 0.05, worst
    assert loc.pose == estimates[-1].pose


def test_estimates_are_consistent(path: list[Pose], tracking: Any) -> None:
    odom, estimates, _ = tracking
    previous = path[0]
    for i, (o, est) in enumerate(zip(odom, estimates)):
        assert est.odom_pose == o
        assert est.result is not None
        if est.accepted:
            # fused with the prediction, the pose stays within the fit's covariance: the fused
            # offset from the fit has a Mahalanobis distance at most the innovation's, which the
            # fusion rule bounds (otherwise the fit is taken alone)
            offset = np.array(est.pose) - np.array(est.result.pose)
            offset[2] = se2.wrap_angle(offset[2])
            assert offset @ np.linalg.solve(finite_covariance(est.result), offset) <= FusionRule().max_innovation + 1e-9
            assert est.reason == ""
        else:
            assert est.pose == est.predicted_pose
            assert est.reason != ""
        # the prediction is the previous pose plus the odometry motion
        motion = (0.0, 0.0, 0.0) if i == 0 else se2.between(odom[i - 1], o)
        np.testing.assert_allclose(est.predicted_pose, se2.compose(previous, motion), rtol=0, atol=1e-12)
        previous = est.pose


def test_map_to_odom_transform(tracking: Any) -> None:
    odom, estimates, _ = tracking
    for o, est in zip(odom, estimates):
        lhs = est.T_map_odom @ se2.pose_to_matrix(o)
        np.testing.assert_allclose(lhs, est.T_map_base, rtol=0, atol=1e-9)
        np.testing.assert_allclose(est.T_map_base, se2.pose_to_matrix(est.pose), rtol=0, atol=0)
        # a proper rigid transform
        r = est.T_map_odom[:2, :2]
        np.testing.assert_allclose(r @ r.T, np.eye(2), atol=1e-12)
        np.testing.assert_array_equal(est.T_map_odom[2], [0.0, 0.0, 1.0])
    # the correction grows with the drift: the last map->odom differs from the first
    first, last = se2.matrix_to_pose(estimates[0].T_map_odom), se2.matrix_to_pose(estimates[-1].T_map_odom)
    assert abs(se2.wrap_angle(last[2] - first[2])) > 2 * DEG


def test_gate_rejects_a_wild_odometry_jump(plan: PlanMap, path: list[Pose], scans: list[np.ndarray]) -> None:
    """Odometry claims a 2 m step the robot did not make: whatever ICP makes of it, the estimate is
    rejected and the pose follows the prediction."""
    loc = Localizer(plan, path[0])
    assert loc.update(scans[0], (0.0, 0.0, 0.0)).accepted
    est = loc.update(scans[1], (2.1, 0.0, 0.0))
    assert not est.accepted
    assert est.reason
    np.testing.assert_allclose(est.pose, est.predicted_pose, atol=0)
    assert loc.pose == est.predicted_pose


GATE_ONLY = RecoveryConfig(local_radius=0.0)
"""No search around the prediction: the gate's verdict alone (what the gate tests pin down)."""


def test_gate_rejects_a_correction_beyond_max_translation_jump(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    gate = AcceptanceGate(max_translation_jump=0.1)
    loc = Localizer(plan, path[0], gate=gate, recovery=GATE_ONLY)
    first = loc.update(scans[0], (0.0, 0.0, 0.0))
    assert first.accepted
    # odometry says 35 cm; the robot moved 10 cm: ICP pulls back by ~0.25 m > 0.1 m
    true_motion = se2.between(path[0], path[1])
    claimed = se2.compose(true_motion, (0.25, 0.0, 0.0))
    est = loc.update(scans[1], claimed)
    assert est.result is not None
    assert error(path[1], est.result.pose)[0] < 0.05, est.result  # ICP found the truth...
    assert not est.accepted  # ...but the correction is too large to trust
    assert "correction of" in est.reason and "exceeds 0.100 m" in est.reason, est.reason
    jump = float(est.reason.split("correction of ")[1].split(" m")[0])
    assert 0.2 < jump < 0.3
    expected = se2.compose(first.pose, claimed)
    np.testing.assert_allclose(est.pose, expected, atol=1e-12)
    np.testing.assert_allclose(est.predicted_pose, expected, atol=1e-12)
    assert loc.pose == est.pose


def test_gate_rejects_a_correction_beyond_max_rotation_jump(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    gate = AcceptanceGate(max_rotation_jump=1 * DEG)
    loc = Localizer(plan, path[0], gate=gate, recovery=GATE_ONLY)
    first = loc.update(scans[0], (0.0, 0.0, 0.0))
    assert first.accepted
    claimed = se2.compose(se2.between(path[0], path[1]), (0.0, 0.0, 3 * DEG))
    est = loc.update(scans[1], claimed)
    assert est.result is not None and error(path[1], est.result.pose)[1] < 0.5 * DEG
    assert not est.accepted
    assert "deg exceeds 1.00 deg" in est.reason, est.reason
    np.testing.assert_allclose(est.pose, se2.compose(first.pose, claimed), atol=1e-12)


def test_gate_rejects_poor_inlier_ratio(plan: PlanMap, path: list[Pose], scans: list[np.ndarray]) -> None:
    # The furniture's returns aligned too (the occlusion rule, tried on a rejected fit, would
    # leave them out, and the plan explains every return it keeps).
    loc = Localizer(plan, path[0], gate=AcceptanceGate(min_inlier_ratio=1.0), occlusion=False)
    est = loc.update(scans[0], (0.0, 0.0, 0.0))
    assert est.result is not None and est.result.inlier_ratio < 1.0
    assert not est.accepted and "inlier ratio" in est.reason
    loc = Localizer(plan, path[0], gate=AcceptanceGate(min_inliers=100_000))
    est = loc.update(scans[0], (0.0, 0.0, 0.0))
    assert not est.accepted and "inliers (need 100000)" in est.reason


def test_gate_rejects_non_convergence_only_when_required(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    cfg = IcpConfig(max_iterations=1)
    off = se2.compose(path[0], (0.15, -0.1, 2 * DEG))
    # A start certain enough that the gate vouches for it (no search around it: 3 sigma within
    # 0.5 m and 10 degrees), so that the one-iteration fit is what is judged.
    start = np.diag([0.1**2, 0.1**2, (3 * DEG) ** 2])
    strict = AcceptanceGate(require_convergence=True)
    est = Localizer(plan, off, cfg, gate=strict, initial_covariance=start).update(scans[0], (0.0, 0.0, 0.0))
    assert est.result is not None and not est.result.converged
    assert not est.accepted and "did not converge in 1 iterations" in est.reason
    # The default gate does not require it.
    est = Localizer(plan, off, cfg, initial_covariance=start).update(scans[0], (0.0, 0.0, 0.0))
    # The start prior pulls the fit by millimetres: a fit cut short after one iteration leaves
    # residuals that share its error along each wall, and its covariance says so.
    assert est.accepted and math.dist(est.pose[:2], est.result.pose[:2]) < 0.01  # type: ignore[union-attr]
    # without fusion it is the fit
    est = Localizer(plan, off, cfg, fusion=FusionRule(max_innovation=0.0), initial_covariance=start).update(
        scans[0], (0.0, 0.0, 0.0)
    )
    assert est.accepted and est.pose == est.result.pose  # type: ignore[union-attr]


def test_rejection_then_recovery(plan: PlanMap, path: list[Pose], scans: list[np.ndarray]) -> None:
    """After a rejected step the localizer keeps tracking from the prediction with the next scan."""
    loc = Localizer(plan, path[0], gate=AcceptanceGate(max_translation_jump=0.1), recovery=GATE_ONLY)
    assert loc.update(scans[0], (0.0, 0.0, 0.0)).accepted
    odom1 = se2.compose(se2.between(path[0], path[1]), (0.15, 0.0, 0.0))  # 15 cm slip, rejected
    assert not loc.update(scans[1], odom1).accepted
    # odometry continues from its (slipped) reading; the next correction is 0.15 m: still rejected
    odom2 = se2.compose(odom1, se2.between(path[1], path[2]))
    assert not loc.update(scans[2], odom2).accepted
    # a lenient gate would have accepted it: tracking recovers once the gate allows the correction
    loc.gate = AcceptanceGate()
    est = loc.update(scans[3], se2.compose(odom2, se2.between(path[2], path[3])))
    assert est.accepted and error(path[3], est.pose)[0] < 0.05


def test_reset_pairs_the_new_pose_with_the_next_odometry(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    loc = Localizer(plan, (0.0, 0.0, 0.0))
    loc.update(scans[0], (5.0, 5.0, 1.0))  # somewhere wrong, and an odometry history
    loc.reset(path[10])
    assert loc.pose == path[10]
    # far-away odometry reading: after reset, it only anchors the odometry, it moves nothing
    est = loc.update(scans[10], (-40.0, 12.0, -2.0))
    assert est.predicted_pose == path[10]
    assert est.accepted and error(path[10], est.pose)[0] < 0.05
    # the next reading moves the robot by the odometry difference since the reset
    motion = se2.between(path[10], path[11])
    odom_next = se2.compose((-40.0, 12.0, -2.0), motion)
    est2 = loc.update(scans[11], odom_next)
    np.testing.assert_allclose(est2.predicted_pose, se2.compose(est.pose, motion), atol=1e-12)
    assert est2.accepted and error(path[11], est2.pose)[0] < 0.05


def test_first_update_uses_no_motion(plan: PlanMap, path: list[Pose], scans: list[np.ndarray]) -> None:
    loc = Localizer(plan, path[5])
    est = loc.update(scans[5], (100.0, -100.0, 3.0))
    assert est.predicted_pose == path[5]
    assert est.accepted


def test_a_good_fit_beyond_the_gate_is_checked_by_a_search_and_taken(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A bad odometry step (15 deg, beyond the default 10 deg gate): ICP finds the truth, the gate
    alone would reject it, the search around the prediction finds it, and the pose takes it when the
    next scan's search finds the same place again (not on one scan's word)."""
    loc = Localizer(plan, path[0])
    assert loc.update(scans[0], (0.0, 0.0, 0.0)).accepted
    claimed = se2.compose(se2.between(path[0], path[1]), (0.0, 0.0, 15 * DEG))
    est = loc.update(scans[1], claimed)
    assert not est.accepted and not est.relocalized and "taken if the next scan confirms it" in est.reason
    claimed_next = se2.compose(claimed, se2.between(path[1], path[2]))  # the odometry keeps its fault
    est = loc.update(scans[2], claimed_next)
    assert est.accepted and est.relocalized and est.reason == "", est.reason
    assert error(path[2], est.pose)[0] < 0.05 and error(path[2], est.pose)[1] < 1 * DEG
    gate_only = Localizer(plan, path[0], recovery=GATE_ONLY)
    gate_only.update(scans[0], (0.0, 0.0, 0.0))
    est = gate_only.update(scans[1], claimed)
    assert not est.accepted and "deg exceeds 10.00 deg" in est.reason, est.reason


def test_a_scan_turned_by_a_right_angle_does_not_move_the_pose() -> None:
    """One scan in five corrupted (its points turned by 90 degrees) in the demo's furnished office:
    such a scan fits some place beyond the gate, which the search after the rejected jump finds
    too. Taken at once, the pose jumped there (at scan 130 of this drive) and tracked it; now the
    next, sound scan does not confirm the place and the pose stays with the clean run's."""
    import dataclasses

    from planicp.plans.default_plan import load_default_plan
    from planicp.sim.experiment import ExperimentConfig, replay, run_experiment

    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=16.0, seed=1))
    turn = np.array([[0.0, 1.0], [-1.0, 0.0]])  # row vectors times this: +90 degrees
    corrupted = [s @ turn if k % 5 == 0 and k > 0 else s for k, s in enumerate(recording.scans)]
    clean = replay(plan, recording, IcpConfig.for_tracking())
    junk = replay(plan, dataclasses.replace(recording, scans=corrupted), IcpConfig.for_tracking())
    apart = np.hypot(*(junk.estimate[:, :2] - clean.estimate[:, :2]).T)
    assert apart.max() < 0.05, (int(np.argmax(apart)), apart.max())


def test_an_uncertain_prediction_is_searched_around(plan: PlanMap, path: list[Pose], scans: list[np.ndarray]) -> None:
    """A prediction 1 m off whose covariance says so (3 sigma = 1.2 m, as after odometry over a long
    gap in the scans): the plan is searched around it instead of trusting ICP's nearest fit."""
    off = se2.compose(path[0], (0.7, -0.7, 8 * DEG))
    wide = np.diag([0.4**2, 0.4**2, (5 * DEG) ** 2])
    est = Localizer(plan, off, initial_covariance=wide).update(scans[0], (0.0, 0.0, 0.0))
    assert est.accepted and est.relocalized, est.reason
    assert error(path[0], est.pose)[0] < 0.05 and error(path[0], est.pose)[1] < 1 * DEG


def test_a_prediction_whose_heading_is_uncertain_beyond_the_gate_is_searched_around(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A prediction whose 3-sigma heading uncertainty exceeds the gate's rotation limit (10
    degrees; a long turn of the odometry) is searched around, as one whose position uncertainty
    exceeds its translation limit is: the true correction may lie beyond what the gate accepts.
    Within the limit, no search."""
    from planicp.tracking.decisions import SearchDecision

    def cause(heading_std: float) -> Any:
        off = se2.compose(path[0], (0.05, 0.0, 2 * DEG))
        covariance = np.diag([0.05**2, 0.05**2, heading_std**2])
        est = Localizer(plan, off, initial_covariance=covariance).update(scans[0], (0.0, 0.0, 0.0))
        assert est.accepted and error(path[0], est.pose)[0] < 0.05, est.reason
        (search,) = [d for d in est.decisions if isinstance(d, SearchDecision)]
        return search.cause

    assert cause(4 * DEG) == "uncertain"  # 3 sigma = 12 degrees
    assert cause(3 * DEG) is None  # 9 degrees


def test_a_search_for_an_uncertain_prediction_covers_only_what_it_allows(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The search around an uncertain prediction covers the places that can pass the fusion's
    99.9 % bound (sqrt(16.266) = 4.03 sigma, widened by the refinement's reach), not every
    heading within the recovery's radius; a search after a rejected jump (odometry may have
    faulted) still covers the whole neighbourhood."""
    from planicp.tracking.recovery import SearchBudget

    regions: list[Any] = []
    search = SearchBudget.search

    def recording(self: SearchBudget, scan: Any, plan: PlanMap, region: Any, *args: Any) -> Any:
        regions.append(region)
        return search(self, scan, plan, region, *args)

    monkeypatch.setattr(SearchBudget, "search", recording)
    off = se2.compose(path[0], (0.7, -0.7, 8 * DEG))
    wide = np.diag([0.4**2, 0.4**2, (5 * DEG) ** 2])
    est = Localizer(plan, off, initial_covariance=wide).update(scans[0], (0.0, 0.0, 0.0))
    assert est.accepted and est.relocalized and error(path[0], est.pose)[0] < 0.05, est.reason
    (region,) = regions
    k = math.sqrt(16.266)
    assert region.radius == pytest.approx(k * 0.4 + 0.25, rel=1e-3)  # + the ICP's correspondence distance
    assert region.yaw_tolerance == pytest.approx(k * 5 * DEG + 2 * 2 * DEG, rel=1e-3)  # + two heading steps
    regions.clear()
    loc = Localizer(plan, path[0])
    # The default start's 5-degree heading deviation (3 sigma 15 degrees, beyond the gate's 10) is
    # searched around on the first update, within what it allows.
    loc.update(scans[0], (0.0, 0.0, 0.0))
    (start,) = regions
    assert start.yaw_tolerance == pytest.approx(k * 5 * DEG + 2 * 2 * DEG, rel=1e-3)
    regions.clear()
    loc.update(scans[1], se2.compose(se2.between(path[0], path[1]), (0.0, 0.0, 15 * DEG)))
    assert [(r.radius, r.yaw_tolerance) for r in regions] == [(3.0, math.pi)]


def test_a_search_for_an_uncertain_start_keeps_to_the_stated_uncertainty() -> None:
    """A start pose given with 0.35-0.5 m and 2 degrees of uncertainty (as from RViz) makes the first
    update search around it (3 sigma above the gate's 0.5 m). With a 6 m, 180-degree scanner, a place
    2.4 m away and turned by 136 degrees explained more of this scan (0.66 of it, against 0.54 at
    the truth) and was adopted; the search now refuses places outside the prediction's covariance
    (the fusion's 99.9 % chi-square bound). The scan is scan 346 of the sample sweep's run
    ea5715a8fb28ab6c (docs/sweep.md, "Studies at scale")."""
    from planicp.plans.default_plan import load_default_plan
    from planicp.sim.experiment import run_experiment
    from planicp.sweep.runs import expand_runs
    from planicp.sweep.study import Study

    study = Study.from_dict(
        {
            "name": "one run",
            "duration_s": 60,
            "plans": ["default"],
            "seeds": [3],
            "furniture": [0],
            "people": [2],
            "sensors": {
                "budget": {"fov_deg": 180, "beams": 181, "range_max": 6.0, "range_sigma": 0.03, "dropout": 0.1}
            },
            "odometry": {"thesis": {}},
        }
    )
    (spec,) = expand_runs(study)
    assert spec.run_id == "ea5715a8fb28ab6c"
    config = spec.experiment_config()
    plan = load_default_plan()
    recording, _ = run_experiment(plan, config)
    truth, scan = tuple(recording.truth[346]), recording.scans[346]
    for sd in (0.35, 0.5):
        localizer = Localizer(
            plan, truth, config.icp, initial_covariance=np.diag([sd**2, sd**2, math.radians(2.0) ** 2])
        )
        estimate = localizer.update(scan, (0.0, 0.0, 0.0))
        error = math.hypot(estimate.pose[0] - truth[0], estimate.pose[1] - truth[1])
        assert estimate.accepted and not estimate.relocalized, (sd, estimate.reason)
        assert error < 0.05 and abs(se2.wrap_angle(estimate.pose[2] - truth[2])) < math.radians(1.0), (sd, error)


def test_returns_through_walls_are_judged_against_what_sound_tracking_showed(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray], tracking: Any
) -> None:
    """A place through whose walls more of a scan's returns pass than the recovery allows is not
    taken: `max_beyond`, or the share the soundly tracked scans showed at their own poses when that
    is more (a SLAM map's sparse cells let beams through at the right place too)."""
    _, estimates, loc = tracking
    recovery = loc._recovery
    assert len(recovery.beyond_shares) >= 0.8 * len(estimates)  # every sound fit was recorded
    assert recovery.beyond_limit == recovery.config.max_beyond  # this plan's walls stop the beams
    scan = scans[20]
    ranges = np.hypot(scan[:, 0], scan[:, 1])[:, None]

    def through(share: float) -> np.ndarray:
        """`scan` with the first `share` of its returns 2 m farther along their beams."""
        moved = scan.copy()
        n = int(share * len(scan))
        moved[:n] *= (ranges[:n] + 2.0) / ranges[:n]
        return moved

    assert not recovery._contradicted(scan, path[20])
    assert recovery._contradicted(through(0.3), path[20])
    for _ in range(60):
        recovery.observe_beyond(0.35)  # tracking in a map whose walls the beams pass
    assert recovery.beyond_limit == pytest.approx(0.35)
    assert not recovery._contradicted(through(0.3), path[20])
    assert recovery._contradicted(through(0.6), path[20])
    recovery.beyond_shares.clear()


def test_returns_through_walls_are_weighed_over_the_scans_that_confirm_a_place(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A followed place is dropped when the scans it has explained show, on average, more returns
    beyond its walls than the limit: one scan through whose walls many returns pass does not drop a
    place that the scans before showed none through (in a SLAM map beams pass sparse cells at the
    true place by an amount that varies from scan to scan), a second one in a row does."""
    from planicp.tracking.occlusion_rule import OcclusionFilter, OcclusionRule
    from planicp.tracking.recovery import Hypothesis

    recovery = Recovery(
        plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate(), OcclusionFilter(plan, OcclusionRule())
    )
    assert recovery.beyond_limit == pytest.approx(0.15)
    scan = scans[21]
    ranges = np.hypot(scan[:, 0], scan[:, 1])[:, None]
    through = scan.copy()
    n = int(0.35 * len(scan))
    through[:n] *= (ranges[:n] + 2.0) / ranges[:n]
    motion = se2.between(path[20], path[21])
    assert recovery._beyond_share(scan, path[21]) < 0.02
    spike = recovery._beyond_share(through, path[21])
    assert 0.18 < spike < 0.4
    fit = localize(scans[20], plan, path[20], recovery.icp)
    # Two scans with no return through its walls, then one with a fifth or more of them: kept.
    clean = Hypothesis(path[20], fit, 2, 2 * fit.inlier_ratio, True, 0.0)
    followed = recovery._follow(clean, through, motion)
    assert followed is not None and followed.streak == 3
    assert followed.mean_beyond == pytest.approx(spike / 3, abs=0.01)
    # A place found with as many of its scan's returns through its walls, and the same again: dropped.
    contradicted = Hypothesis(path[20], fit, 1, fit.inlier_ratio, True, spike)
    assert recovery._follow(contradicted, through, motion) is None


def test_a_place_followed_over_a_turned_step_is_found_within_the_odometry_spread(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A place that followed the odometry over a scan no place explained, on a step whose
    odometry turned 15 degrees more than the robot, lies beyond what the gate lets ICP correct:
    the next sound scan's fit from there is refused, and the place is found again by a search
    within the odometry's spread since it was last fitted, not dropped. The same place fitted on
    the scan before (no spread) is held to the gate, and a place 1.5 m from the robot, beyond the
    spread, is dropped."""
    from dataclasses import replace

    from planicp.tracking.recovery import Hypothesis

    recovery = Recovery(plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate())
    fit = localize(scans[20], plan, path[20], recovery.icp)
    junk = np.random.default_rng(4).uniform(-8.0, 8.0, size=scans[30].shape)
    x, y, yaw = se2.between(path[20], path[30])
    recovery.hypotheses = [Hypothesis(path[20], fit, 2, 2 * fit.inlier_ratio, True)]
    assert not recovery._follow_all(junk, (x, y, yaw + math.radians(15.0)))
    [coasted] = recovery.hypotheses
    assert coasted.missed and coasted.spread[2, 2] > 0.0
    motion = se2.between(path[30], path[40])
    here = se2.compose(coasted.pose, motion)
    assert recovery.gate.rejection(localize(scans[40], plan, here, recovery.icp), here) != ""
    recovery.new_update()
    followed = recovery._follow(coasted, scans[40], motion)
    assert followed is not None and followed.streak == 3
    assert error(followed.pose, path[40])[0] < 0.02 and error(followed.pose, path[40])[1] < math.radians(1.0)
    assert not followed.missed and not followed.spread.any()
    # Fitted on the scan before, the same place is held to the gate's one step.
    assert recovery._follow(replace(coasted, spread=np.zeros((3, 3))), scans[40], motion) is None
    far = replace(coasted, pose=se2.compose(coasted.pose, (1.5, 0.0, 0.0)))
    assert recovery._follow(far, scans[40], motion) is None


def test_a_search_that_ends_on_a_scan_no_place_explains_keeps_its_places(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A search that ends an update after its scan finds its places again with the scan of that
    update. A corrupted one, which none of them explains and no followed place does, tells them
    not apart: they join the hypotheses moved by the odometry since the search's scan, having
    missed it, and the next sound scan weighs them. When a followed place explained the scan,
    the places it does not explain are dropped, as before."""
    from planicp.tracking.relocalize import SearchRegion

    junk = np.random.default_rng(4).uniform(-8.0, 8.0, size=scans[21].shape)
    for explained in (False, True):
        recovery = Recovery(plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate())
        run = recovery._start(scans[20], SearchRegion(path[20], 0.5, math.radians(10.0)))
        run.log.append((junk, se2.between(path[20], path[21])))
        recovery._follow_all(junk, se2.between(path[20], path[21]))  # no place followed yet
        recovery._explained = explained
        recovery.new_update()
        assert recovery._advance(run, junk, None, whole_plan=False)
        if explained:
            assert recovery.hypotheses == []
            continue
        [kept] = recovery.hypotheses
        assert kept.missed and kept.streak == 1 and kept.near and kept.spread[0, 0] > 0.0
        assert error(kept.pose, path[21])[0] < 0.03
        assert recovery._follow_all(scans[22], se2.between(path[21], path[22]))
        [followed] = recovery.hypotheses
        assert not followed.missed and followed.streak == 2 and error(followed.pose, path[22])[0] < 0.03


def test_a_followed_place_whose_odometry_step_faulted_is_found_by_the_fault_sweep(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A place the recovery follows, moved by an odometry step that turned 30 degrees too far at
    its start (1 m of driving), is found where the fault left the robot when the localizer's
    refinement weighs faults (`Recovery._faulted`, the tracking's sweep within the fault model,
    whose place the scan prefers to the fit from the odometry's by more than the fault costs),
    and dropped without it, as is one whose step turned 60 degrees too far (beyond the model's
    44-degree window) either way."""
    from planicp import PosteriorRefinement
    from planicp.tracking.recovery import Hypothesis

    def followed(turn: float, refinement: PosteriorRefinement | None) -> Hypothesis | None:
        icp = IcpConfig.for_tracking(correspondence_search="wall_index")
        recovery = Recovery(plan, RecoveryConfig(), icp, AcceptanceGate(), refinement=refinement)
        place = Hypothesis(path[10], localize(scans[10], plan, path[10], icp), 1, 0.9, False)
        motion = se2.compose((0.0, 0.0, turn), se2.between(path[10], path[20]))
        return recovery._follow(place, scans[20], motion)

    faults = PosteriorRefinement(enabled=True)
    for turn in (30 * DEG, -30 * DEG):
        place = followed(turn, faults)
        assert place is not None and place.streak == 2
        assert error(place.pose, path[20])[0] < 0.01 and error(place.pose, path[20])[1] < 0.5 * DEG
        assert followed(turn, None) is None
        assert followed(turn, PosteriorRefinement(enabled=True, fault_probability=0.0)) is None
        # A fault so improbable that no scan can pay for it: the held place is kept to (dropped).
        assert followed(turn, PosteriorRefinement(enabled=True, fault_probability=1e-300)) is None
    assert followed(60 * DEG, faults) is None and followed(-60 * DEG, faults) is None


def test_a_search_that_ends_updates_after_its_scan_follows_its_places_through_the_scans_since(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A search that ends 25 updates after its scan, with odometry that turned 3 degrees too far
    on every step, follows its place through the 25 scans since, as a hypothesis is followed: the
    place is within 3 cm of the robot with a streak of 26 scans, where the place moved by the
    odometry alone would be more than 0.4 m off. Within a budget of one alignment an update the
    places catch up over several calls, each counted as `ALIGNMENT_NODES` nodes."""
    from planicp.tracking.recovery import ALIGNMENT_NODES
    from planicp.tracking.relocalize import SearchRegion

    recovery = Recovery(plan, RecoveryConfig(search_time=None), IcpConfig.for_tracking(), AcceptanceGate())
    run = recovery._start(scans[10], SearchRegion(path[10], 0.3, math.radians(10.0)))
    coasted = path[10]
    for a, b, scan in zip(path[10:35], path[11:36], scans[11:36]):
        x, y, yaw = se2.between(a, b)
        run.log.append((scan, (x, y, yaw + math.radians(3.0))))
        coasted = se2.compose(coasted, run.log[-1][1])
    assert error(coasted, path[35])[0] > 0.4
    recovery.new_update()
    calls = 1
    while not recovery._advance(run, scans[35], ALIGNMENT_NODES, whole_plan=False):
        calls += 1
        assert calls < 100
    assert calls > 20
    [place] = recovery.hypotheses
    assert place.streak == 26 and not place.missed and error(place.pose, path[35])[0] < 0.03
    assert run.log == [] and run.places == []


def test_a_running_search_keeps_its_own_copy_of_each_scan(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A caller that fills one buffer with every scan (a ROS callback's array, reused) does not
    change the scans a running search's places are to be followed through."""
    recovery = Recovery(plan, RecoveryConfig(search_nodes=100), IcpConfig.for_tracking(), AcceptanceGate())
    buffer = scans[10].copy()
    recovery.new_update()
    recovery.step(buffer, (0.0, 0.0, 0.0), path[10])
    buffer[:] = scans[11]
    recovery.new_update()
    recovery.step(buffer, se2.between(path[10], path[11]), path[10])
    assert recovery._whole is not None and recovery._whole.places is None
    buffer[:] = 0.0
    [(kept, _)] = recovery._whole.log
    assert np.array_equal(kept, scans[11])


def test_a_search_that_starts_while_lost_begins_on_a_sound_scan(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A search that starts while the robot is lost begins on the latest of the last lost scans
    that overlaps a scan before it (`SOUND_OVERLAP`), not on a corrupted one: after a random
    cloud the search near the pose begins on the scan before the cloud, over the region of that
    update's drive, and follows its place over the cloud to the robot, and so does a search of
    the whole plan; a sound scan after a cloud overlaps the one before the cloud and is begun
    on; with every scan sound, the latest is."""
    from planicp.tracking.recovery import START_CHOICES

    assert START_CHOICES == 2
    cloud = np.random.default_rng(4).uniform(-8.0, 8.0, size=scans[12].shape)

    def lost_through(updates: list[np.ndarray]) -> Recovery:
        config = RecoveryConfig(search_nodes=1, search_time=None, search_spare_time=None)
        recovery = Recovery(plan, config, IcpConfig.for_tracking(), AcceptanceGate())
        for i, scan in enumerate(updates, start=10):
            recovery.new_update()
            recovery.step(scan, se2.between(path[i - 1], path[i]), path[i - 1])
        return recovery

    # The latest scan is a cloud: the search begins on the one before it.
    recovery = lost_through([scans[10], scans[11], cloud])
    assert recovery._lost_at is not None
    run = recovery._start_sound(cloud, recovery._lost_at)
    assert np.array_equal(run.steps.scan, scans[11])
    assert run.steps.region == recovery._near_region(recovery._lost_at, recovery._recent[1].drive)
    assert run.steps.region != recovery._near_region(recovery._lost_at, recovery._drive)
    [(logged, motion)] = run.log
    assert np.array_equal(logged, cloud) and motion == se2.between(path[11], path[12])
    recovery.hypotheses = []
    recovery.new_update()
    assert recovery._advance(run, cloud, None, whole_plan=False)
    [place] = recovery.hypotheses
    assert place.near and place.missed and error(place.pose, path[12])[0] < 0.03
    whole = recovery._start_sound(cloud, None)
    assert np.array_equal(whole.steps.scan, scans[11]) and whole.steps.region is None
    assert [(np.array_equal(s, cloud), m) for s, m in whole.log] == [(True, se2.between(path[11], path[12]))]
    # A cloud between two sound scans: the latest continues the one before the cloud.
    recovery = lost_through([scans[10], cloud, scans[12]])
    assert recovery._lost_at is not None
    run = recovery._start_sound(scans[12], recovery._lost_at)
    assert np.array_equal(run.steps.scan, scans[12]) and run.log == []
    # Every scan sound: the latest.
    recovery = lost_through([scans[10], scans[11], scans[12]])
    assert recovery._lost_at is not None
    run = recovery._start_sound(scans[12], recovery._lost_at)
    assert np.array_equal(run.steps.scan, scans[12]) and run.log == []
    # A scan too small to align between (followed by the odometry alone): the latest scan
    # overlaps the one before it across the motions of both updates.
    recovery = lost_through([scans[10], scans[11]])
    recovery.coast(se2.between(path[11], path[12]))
    recovery.new_update()
    recovery.step(scans[13], se2.between(path[12], path[13]), path[12])
    assert recovery._lost_at is not None and [e.scan is None for e in recovery._recent] == [False, True, False]
    run = recovery._start_sound(scans[13], recovery._lost_at)
    assert np.array_equal(run.steps.scan, scans[13]) and run.log == []


def test_the_search_near_a_robot_lost_by_a_heading_fault_covers_the_ring_it_drove_to(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """Lost at a pose whose heading was 40 degrees off, then driven 4 m by sound odometry, the
    robot is where the drive turned by that error puts it, 2.7 m from where the odometry does.
    The search near it covers every heading, at each the drive turned by the heading's error
    within `local_radius` plus the drive's spread: it finds the robot there, scoring fewer nodes
    than the disk of the path's length around the lost pose (the search before)."""
    from planicp.tracking.relocalize import SearchRegion

    recovery = Recovery(plan, RecoveryConfig(local_radius=0.5), IcpConfig.for_tracking(), AcceptanceGate())
    lost_at = (path[0][0], path[0][1], path[0][2] + math.radians(40.0))
    recovery._lost_at = lost_at
    for a, b in zip(path[:-1], path[1:]):
        recovery._drive.add(se2.between(a, b), recovery.motion_noise)
    coasted = se2.compose(lost_at, recovery._drive.motion)
    assert error(coasted, path[40])[0] > 2.0
    region = recovery._near_region(lost_at, recovery._drive)
    assert region.lever != (0.0, 0.0) and region.radius < 0.5 + recovery._drive.path - 2.0
    ring = relocalize(scans[40], plan, region=region, config=recovery.config.search)
    assert ring.best is not None and error(ring.best.pose, path[40])[0] < 0.05, ring.best
    disk = relocalize(
        scans[40], plan, region=SearchRegion(lost_at, 0.5 + recovery._drive.path), config=recovery.config.search
    )
    assert ring.nodes < disk.nodes / 2
    # Turned in place, the path is shorter than the spread's reach: the disk of its length.
    recovery.clear()
    recovery._lost_at = lost_at
    recovery._drive.add((0.0, 0.0, 1.0), recovery.motion_noise)
    near = recovery._near_region(lost_at, recovery._drive)
    assert near.lever == (0.0, 0.0) and near.radius == 0.5 and near.center == lost_at


def test_the_limit_on_returns_through_walls_is_wide_while_few_scans_were_tracked(plan: PlanMap) -> None:
    """`Recovery.beyond_seen` is the upper bound of a prediction interval for the next sound scan's
    share, not mean + 3 deviations: six shares say little about the spread (on fhw, whose odometry
    broke on its seventh scan, mean + 3 deviations refused the true place)."""
    recovery = Recovery(plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate())
    shares = [0.10, 0.14, 0.18, 0.12, 0.16, 0.20]
    recovery.observe_beyond(shares[0])
    assert recovery.beyond_seen == 0.0 and recovery.beyond_limit == recovery.config.max_beyond
    for share in shares[1:]:
        recovery.observe_beyond(share)
    s = float(np.std(shares, ddof=1))
    # Student's t at 5 degrees of freedom, one-sided 1 in 741 (the normal's 3 sigma): 5.49.
    assert recovery.beyond_seen == pytest.approx(0.15 + 5.493 * s * math.sqrt(1 + 1 / 6), abs=1e-3)
    assert recovery.beyond_seen > 0.15 + 3 * float(np.std(shares)) + 0.1
    for share in shares * 8 + shares[:2]:  # 50 scans of the same spread
        recovery.observe_beyond(share)
    many = np.array(recovery.beyond_shares)
    assert len(many) == 50
    assert recovery.beyond_seen == pytest.approx(many.mean() + 3.161 * many.std(ddof=1) * math.sqrt(1.02), abs=1e-3)


def test_a_scan_no_place_explains_is_passed_over_once(plan: PlanMap, path: list[Pose], scans: list[np.ndarray]) -> None:
    """A corrupted scan, which no followed place explains, tells none of them from another: they
    follow the odometry over it, their streaks unchanged; a second such scan in a row drops them.
    A scan the tracked place explains (a place on trial) does weigh them: those it fails are
    dropped at once."""
    from planicp.tracking.recovery import Hypothesis

    recovery = Recovery(plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate())
    fit = localize(scans[20], plan, path[20], recovery.icp)
    place = Hypothesis(path[20], fit, 2, 2 * fit.inlier_ratio, True)
    junk = np.random.default_rng(4).uniform(-8.0, 8.0, size=scans[21].shape)
    motion = se2.between(path[20], path[21])
    recovery.hypotheses = [place]
    assert not recovery._follow_all(junk, motion)
    [coasted] = recovery.hypotheses
    assert coasted.missed and coasted.streak == 2 and coasted.total == place.total
    assert error(coasted.pose, path[21])[0] < 1e-9
    # The next scan, sound, is explained there: the streak goes on.
    assert recovery._follow_all(scans[22], se2.between(path[21], path[22]))
    [followed] = recovery.hypotheses
    assert not followed.missed and followed.streak == 3 and error(followed.pose, path[22])[0] < 0.03
    # Two corrupted scans in a row: dropped at the second.
    assert not recovery._follow_all(junk, se2.between(path[22], path[23]))
    assert not recovery._follow_all(junk, se2.between(path[23], path[24]))
    assert recovery.hypotheses == []
    # Explained elsewhere: the scan weighs the places, and drops those it fails.
    recovery.hypotheses = [place]
    assert recovery._follow_all(junk, motion, explained_elsewhere=True)
    assert recovery.hypotheses == []


def test_the_recovery_searches_on_in_the_update_s_spare_time(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """`search_spare_time`: past its `search_nodes`, the recovery's search goes on until that long
    after the update began; with none it stops at the nodes and goes on in the next update. The
    spare time never outlasts `search_time`."""
    from planicp.tracking.recovery import SearchBudget

    def first_update(config: RecoveryConfig) -> Recovery:
        recovery = Recovery(plan, config, IcpConfig.for_tracking(), AcceptanceGate())
        recovery.new_update()
        recovery.step(scans[20], (0.0, 0.0, 0.0), path[20])
        return recovery

    spread = first_update(RecoveryConfig(search_nodes=1_000, search_time=None, search_spare_time=None))
    assert spread.searching and not spread.hypotheses
    spared = first_update(RecoveryConfig(search_nodes=1_000, search_time=None, search_spare_time=30.0))
    assert not spared.searching  # the whole plan's search ended in the update that began it
    assert min(error(h.pose, path[20])[0] for h in spared.hypotheses) < 0.05
    now = time.perf_counter()
    assert SearchBudget(1_000, until=now + 0.001, spare_until=now + 10.0).spare_seconds() <= 0.001
    assert SearchBudget(1_000).spare_seconds() == 0.0


def test_an_update_s_searches_stop_at_its_time_ceiling_whatever_nodes_are_left(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """`search_time` (15 ms by default): the searches of an update stop that long after it began,
    with nodes left, and go on in the next update. An update whose ceiling has passed before its
    searches begin scores none of its 5,000 nodes, where without a ceiling it scores them all."""
    assert RecoveryConfig().search_time == 0.015

    def scored(config: RecoveryConfig) -> tuple[Recovery, int]:
        recovery = Recovery(plan, config, IcpConfig.for_tracking(), AcceptanceGate())
        budget = recovery.new_update()
        recovery.step(scans[20], (0.0, 0.0, 0.0), path[20])
        assert budget.left is not None
        return recovery, 5_000 - budget.left

    recovery, nodes = scored(RecoveryConfig(search_nodes=5_000, search_time=None, search_spare_time=None))
    assert recovery.searching and nodes >= 5_000
    recovery, nodes = scored(RecoveryConfig(search_nodes=5_000, search_time=1e-9, search_spare_time=None))
    assert recovery.searching and nodes == 0


def test_a_place_nearby_must_explain_scans_as_sound_tracking_does(plan: PlanMap) -> None:
    """`Recovery.explained_seen` is the lower bound of a prediction interval for the share of
    its returns the next sound scan's fit explains (as `beyond_seen` is an upper one): scans
    explained alike keep it high, scans explained unevenly (the parts of a building differ)
    lower it."""
    recovery = Recovery(plan, RecoveryConfig(), IcpConfig.for_tracking(), AcceptanceGate())
    assert recovery.explained_seen == 0.0
    alike = [0.95, 0.96, 0.94, 0.95, 0.97, 0.93] * 8
    for share in alike:
        recovery.observe_explained(share)
    a = np.array(alike)
    bound = a.mean() - student_t_quantile(NormalDist().cdf(3.0), len(a) - 1) * a.std(ddof=1) * math.sqrt(1 + 1 / len(a))
    assert recovery.explained_seen == pytest.approx(bound, abs=1e-9)
    assert 0.88 < recovery.explained_seen < 0.92
    uneven = [0.98, 0.92, 0.96, 0.91, 0.64, 0.96, 0.94, 0.97, 0.80, 0.91, 0.96, 0.99, 0.84, 0.76, 0.89]
    for share in uneven:
        recovery.observe_explained(share)
    assert 0.6 < recovery.explained_seen < 0.8


def test_student_t_quantiles() -> None:
    """Exact for 1 and 2 degrees of freedom, the Cornish-Fisher expansion beyond (table values)."""
    assert student_t_quantile(0.975, 1) == pytest.approx(12.706, abs=1e-3)
    assert student_t_quantile(0.995, 2) == pytest.approx(9.925, abs=1e-3)
    assert student_t_quantile(0.975, 5) == pytest.approx(2.571, abs=2e-3)
    assert student_t_quantile(0.995, 10) == pytest.approx(3.169, abs=2e-3)
    assert student_t_quantile(0.975, 1000) == pytest.approx(1.962, abs=2e-3)


def test_a_plan_whose_index_cannot_be_built_is_still_tracked(
    office: Any, path: list[Pose], scans: list[np.ndarray], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Making a `Localizer` builds the plan's nearest-wall index; a plan it cannot be built for
    gets a `Localizer` all the same, whose alignments go through the KD-tree instead."""
    from planicp import _core

    def refuse(self: PlanMap) -> None:
        raise _core.PlanicpError("the nearest-wall index would be too large")

    monkeypatch.setattr(PlanMap, "prepare_index", refuse)
    _, estimates, _ = track(PlanMap.from_points(office.wall_points()), path, scans)
    assert all(e.accepted for e in estimates)
    assert max(error(e.pose, p)[0] for e, p in zip(estimates, path)) < 0.05
