"""An odometry fault (the odometry turns far more than its noise allows) is found from the scans
and taken at once, the track's own pose left behind until a scan rules it out; a corrupted scan
that looks like one is taken back at the next scan (`planicp.tracking.odometry_fault`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planicp import Localizer, PlanMap, PosteriorRefinement, se2
from planicp.tracking.decisions import LeftPlaceDecision
from planicp.tracking.odometry_fault import (
    CostHistory,
    fault_cost,
    fault_starts,
    scan_cost,
    sweep_for_fault,
    within_fault,
)

# The synthetic office, its drive and scans: the module fixtures of test_localizer.py.
from test_localizer import DEG, DRIFT, drifting_odometry, error, office, path, plan, scans  # noqa: F401

Pose = tuple[float, float, float]
FAULT_AT = 20


def faulty_odometry(path: list[Pose], turn: float) -> list[Pose]:
    """Odometry drifting by DRIFT per step that, between scans FAULT_AT - 1 and FAULT_AT, turns
    `turn` radians and moves 15 cm more than the robot did."""
    odom = drifting_odometry(path, (3.0, -1.0, 0.7), DRIFT)
    fault = (0.15, 0.0, turn)
    return odom[:FAULT_AT] + [
        se2.compose(se2.compose(odom[FAULT_AT - 1], fault), se2.between(odom[FAULT_AT - 1], o)) for o in odom[FAULT_AT:]
    ]


def drive(plan: PlanMap, path: list[Pose], scans: list[np.ndarray], odom: list[Pose], **refinement: float) -> list:
    loc = Localizer(plan, path[0], refinement=PosteriorRefinement(enabled=True, **refinement))
    return [loc.update(s, o) for s, o in zip(scans, odom)]


def test_a_35_degree_odometry_fault_is_taken_at_once_and_the_track_left_behind_ruled_out(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    odom = faulty_odometry(path, 35 * DEG)
    estimates = drive(plan, path, scans, odom)
    faulted = estimates[FAULT_AT]
    search = faulted.decisions[3]
    assert search.cause == "fault" and search.searched and search.pending is None
    assert faulted.accepted and faulted.relocalized and search.why.startswith("odometry fault: ")
    assert error(path[FAULT_AT], faulted.pose)[0] < 0.03 and error(path[FAULT_AT], faulted.pose)[1] < 1 * DEG
    # The track's own pose (its fit from the prediction, 35 degrees off) is left behind, and the
    # covariance reported is widened towards it until a scan rules it out: the robot is at the
    # place or on the track, as far as one scan can tell.
    assert search.left is not None and error(path[FAULT_AT], search.left)[1] > 10 * DEG
    own = faulted.decisions[5].covariance
    assert faulted.covariance[2, 2] > own[2, 2] + 0.4 * (30 * DEG) ** 2
    assert np.allclose(estimates[FAULT_AT - 1].covariance, estimates[FAULT_AT - 1].decisions[5].covariance)
    for k in range(FAULT_AT, len(path)):
        distance, turn = error(path[k], estimates[k].pose)
        assert distance < 0.03 and turn < 1 * DEG, (k, distance, turn)
    # The place left behind, where the odometry alone puts the robot, is ruled out by the next
    # scan; it is never taken back, and the covariance is the track's own again.
    left = estimates[FAULT_AT + 1].decisions[6]
    assert isinstance(left, LeftPlaceDecision) and left.place is not None
    assert left.kept is None and left.returned is None and error(path[FAULT_AT + 1], left.place)[1] > 10 * DEG
    assert np.allclose(estimates[FAULT_AT + 1].covariance, estimates[FAULT_AT + 1].decisions[5].covariance)
    assert all(e.decisions[6].returned is None for e in estimates)
    assert all(e.decisions[6].place is None and e.decisions[6].kept is None for e in estimates[FAULT_AT + 2 :])
    # Without the fault component the track stays in the wrong basin.
    stuck = drive(plan, path, scans, odom, fault_probability=0.0)
    assert all(e.decisions[3].fault is None for e in stuck)
    assert error(path[FAULT_AT + 1], stuck[FAULT_AT + 1].pose)[1] > 5 * DEG


def test_one_scan_turned_35_degrees_is_taken_back_at_the_next_scan(
    plan: PlanMap, path: list[Pose], scans: list[np.ndarray]
) -> None:
    """A scan turned within the fault window fits a turned place as an odometry fault would: one
    scan cannot tell them apart, and the turned place is taken for that scan (its position is
    the robot's: the scan turned about the scanner). The next scan prefers the track left
    behind by the fault cost, and the estimate is the clean run's again."""
    odom = drifting_odometry(path, (3.0, -1.0, 0.7), DRIFT)
    c, s = math.cos(35 * DEG), math.sin(35 * DEG)
    corrupted = [scan @ np.array([[c, s], [-s, c]]) if k == FAULT_AT else scan for k, scan in enumerate(scans)]
    clean = drive(plan, path, scans, odom)
    junk = drive(plan, path, corrupted, odom)
    turned = junk[FAULT_AT]
    assert turned.decisions[3].cause == "fault" and turned.relocalized
    assert error(clean[FAULT_AT].pose, turned.pose)[0] < 0.05
    assert abs(error(clean[FAULT_AT].pose, turned.pose)[1] - 35 * DEG) < 2 * DEG
    # The next clean scan takes the track back (the stage that weighs the place left behind, or
    # the sweep from the turned prediction), and every estimate after is within 2 cm of the clean
    # run's (the fit the sweep takes at the next scan is not fused with the prediction).
    back = junk[FAULT_AT + 1]
    assert back.decisions[6].returned is not None or back.decisions[3].cause == "fault"
    for k in [*range(FAULT_AT), *range(FAULT_AT + 1, len(path))]:
        distance, turn = error(clean[k].pose, junk[k].pose)
        assert distance < 0.02 and turn < 0.5 * DEG, (k, distance, turn)


def test_the_sweep_finds_no_place_turned_beyond_its_window() -> None:
    """The fault component covers headings within `fault_heading_window` of the prediction: in a
    6 x 4 m room, with the prediction turned 40 degrees from the truth, a window of 44 degrees
    finds the truth; one of 30 degrees finds nothing, though its climbs (from 10 to 70 degrees)
    end at the truth or at the room turned by 180 degrees: places the model gives no weight."""
    segments = [((0, 0), (6, 0)), ((6, 0), (6, 4)), ((6, 4), (0, 4)), ((0, 4), (0, 0))]
    room = PlanMap.from_segments(np.array(segments, dtype=float), spacing=0.05)
    truth = (3.0, 2.0, 0.0)
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    ranges = [
        min(d for d in (3.0 / abs(math.cos(a)) if math.cos(a) else 9.0, 2.0 / abs(math.sin(a)) if math.sin(a) else 9.0))
        for a in angles
    ]
    scan = np.ascontiguousarray(np.column_stack([np.cos(angles), np.sin(angles)]) * np.array(ranges)[:, None])
    predicted = (3.0, 2.0, 40 * DEG)
    still = (0.0, 0.0, 0.0)  # the robot turned in place: no motion, and no bound on the position
    history = CostHistory()
    for _ in range(5):
        history.record(scan_cost(scan, truth, room, PosteriorRefinement()))
    wide = sweep_for_fault(scan, predicted, predicted, room, PosteriorRefinement(), history, still, math.inf)
    assert wide is not None and wide.more_probable
    assert error(truth, wide.pose)[0] < 0.02 and error(truth, wide.pose)[1] < 1 * DEG
    narrow = sweep_for_fault(
        scan, predicted, predicted, room, PosteriorRefinement(fault_heading_window=30 * DEG), history, still, math.inf
    )
    assert narrow is not None and not narrow.more_probable
    assert abs(se2.wrap_angle(narrow.pose[2] - predicted[2])) <= 30 * DEG


def test_the_sweep_finds_a_fault_early_in_a_long_step_metres_from_the_predicted_position() -> None:
    """The odometry's heading went 30 degrees wrong at the start of a 4 m step: the drive it
    reports is turned about the last pose, and the predicted position lies 2.1 m from the robot,
    beyond any climb's reach. The sweep's climbs start along the step as well (`fault_starts`:
    the heading gone wrong at its end, halfway, or at its start), and find the robot; from the
    predicted position alone they do not."""
    segments = [((0, 0), (12, 0)), ((12, 0), (12, 7)), ((12, 7), (0, 7)), ((0, 7), (0, 0)), ((7, 0), (7, 3))]
    segments += [((3, 7), (3, 5)), ((9.5, 7), (9.5, 5.5))]
    room = PlanMap.from_segments(np.array(segments, dtype=float), spacing=0.05)
    last, step = (2.0, 2.0, 0.0), (4.0, 0.0, 0.0)
    truth = se2.compose(last, step)
    predicted = se2.compose(se2.compose(last, (0.0, 0.0, 30 * DEG)), step)
    assert error(truth, predicted)[0] > 2.0
    directions = 720
    ranges = np.asarray(room.view_from(truth, 20.0, directions).ranges)
    angles = -math.pi + 2 * math.pi * np.arange(directions) / directions
    seen = np.isfinite(ranges)
    scan = np.ascontiguousarray(np.column_stack([np.cos(angles), np.sin(angles)])[seen] * ranges[seen][:, None])
    rule, history = PosteriorRefinement(), CostHistory()
    for _ in range(3):
        history.record(scan_cost(scan, truth, room, rule))
    motion = se2.between(last, predicted)
    sweep = sweep_for_fault(scan, predicted, predicted, room, rule, history, motion, 0.5)
    assert sweep is not None and sweep.more_probable
    assert error(truth, sweep.pose)[0] < 0.05 and error(truth, sweep.pose)[1] < 1 * DEG
    starts = fault_starts(predicted, motion, rule.fault_heading_window, 0.5)
    assert min(error(truth, s)[0] for s in starts) < 0.3 and error(truth, predicted)[0] > 2.0
    # At every heading the predicted position is a start; the others only where they lie apart.
    assert sum(error(predicted, s)[0] < 1e-9 for s in starts) == 2 * int(rule.fault_heading_window // (6 * DEG)) + 1
    assert len(fault_starts(predicted, (0.0, 0.0, 0.0), rule.fault_heading_window, 0.5)) == 15


def test_a_fault_leaves_the_robot_where_a_turn_or_a_slip_of_the_step_can() -> None:
    """The fault component covers the odometry turning more than the robot (within the heading
    window) and its wheels slipping (the robot moving less than reported): from the last pose at
    the origin, a 1 m step forward, the places within 0.5 m of the sector it sweeps (1 m, 44
    degrees either way) with a heading within the window; not a place behind the last pose, where
    a corridor's look-alike lies."""
    rule, motion = PosteriorRefinement(), (1.0, 0.0, 0.0)
    predicted = (1.0, 0.0, 0.0)

    def covered(x: float, y: float, yaw: float = 0.0) -> bool:
        return within_fault((x, y, yaw), predicted, motion, rule, 0.5)

    assert covered(0.5, 0.0) and covered(0.0, 0.0)  # slipped half the step, or all of it
    assert covered(math.cos(40 * DEG), math.sin(40 * DEG), 40 * DEG)  # turned 40 degrees more
    assert covered(1.4, 0.0) and not covered(1.6, 0.0)  # 0.4 and 0.6 m beyond the step
    assert covered(-0.45, 0.0) and not covered(-1.3, 0.0)  # behind the last pose
    assert not covered(0.0, 1.2)  # beside it, 0.86 m from the sector's side at 44 degrees
    assert not covered(0.5, 0.0, 50 * DEG)  # turned beyond the window
    # A robot standing still (no motion): only the tolerance around the last pose.
    assert within_fault((0.3, 0.3, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), rule, 0.5)
    assert not within_fault((0.5, 0.3, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), rule, 0.5)


def test_the_cost_history_and_the_fault_cost() -> None:
    history = CostHistory()
    for cost in (1.0, 2.0):
        history.record(cost)
    assert history.typical() is None  # fewer than three costs: one outlier would carry the median
    history.record(100.0)
    assert history.typical() == 2.0
    for _ in range(30):
        history.record(7.0)
    assert history.typical() == 7.0  # only the last twenty count
    # A cost beyond the typical one by the fault cost (a corrupted scan accepted because no place
    # explained it better) is no measure of the track's scans: three of them among twenty raise
    # the median when recorded, and are left out when the fault cost is given.
    threshold = fault_cost(1e-3)
    ruled, plain = CostHistory(), CostHistory()
    for k in range(20):
        for h, limit in ((ruled, threshold), (plain, math.inf)):
            if k in (5, 10, 15):
                h.record(7.0 + threshold + 1.0, (float(k), 0.0, 0.0), limit)
            h.record(7.0 + 0.1 * k, (float(k), 0.0, 0.0), limit)
    assert ruled.typical() == pytest.approx(7.95) and plain.typical() == pytest.approx(8.25)
    # The pose is the last accepted one either way.
    ruled.record(7.0 + threshold + 1.0, (30.0, 0.0, 0.0), threshold)
    assert ruled.typical() == pytest.approx(7.95)
    assert ruled.motion_since((31.0, 0.0, 0.0), (0.5, 0.0, 0.0)) == pytest.approx((1.0, 0.0, 0.0))
    history.clear()
    assert history.typical() is None
    # The steps a fault may lie in: from the last accepted pose's odometry (the updates after it
    # held their predictions), or this update's own motion before any.
    assert history.motion_since((3.0, 1.0, 0.0), (0.5, 0.0, 0.0)) == (0.5, 0.0, 0.0)
    history.record(4.0, (1.0, 1.0, math.pi / 2))
    assert history.motion_since((1.0, 3.0, math.pi / 2), (0.5, 0.0, 0.0)) == pytest.approx((2.0, 0.0, 0.0))
    assert fault_cost(1e-3) == pytest.approx(13.8155, abs=1e-4)
    with pytest.raises(ValueError, match="fault_probability"):
        PosteriorRefinement(fault_probability=1.0)
    with pytest.raises(ValueError, match="fault_heading_window"):
        PosteriorRefinement(fault_heading_window=math.radians(50.0))
