"""Behaviour of `planicp.localize` with real numbers: known transforms, accuracy on synthetic floors,
outlier rejection, the result's fields, convergence modes, visibility and `scan_to_points`."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

import planicp
from geometry_checks import nearest_distance
from planicp import IcpConfig, IcpResult, PlanMap, localize, scan_to_points, se2
from planicp import sim as syn

DEG = math.pi / 180.0
LAYOUTS = ("office", "hall", "diagonal")
ACCURACY_SEEDS = (0, 1, 2, 3)
POSES_PER_FLOOR = 15


# --------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------

Segment = tuple[tuple[float, float], tuple[float, float]]


def thick_wall(x0: float, y0: float, x1: float, y1: float) -> list[Segment]:
    """The four faces of an axis-aligned solid wall block [x0, x1] x [y0, y1]."""
    return [
        ((x0, y0), (x1, y0)),
        ((x1, y0), (x1, y1)),
        ((x1, y1), (x0, y1)),
        ((x0, y1), (x0, y0)),
    ]


# Two rooms of an 8 x 5 m block with 0.2 m walls: the outer shell (inner and outer faces), a
# partition at x = 3..3.2 from the bottom up to y = 3 (a 2 m wide opening above it) and a partition
# at y = 2.5..2.7 from x = 5.5 to the right wall (a second room in the right part).
ROOM_FACES: list[Segment] = [
    # inner faces of the shell
    ((0.0, 0.0), (3.0, 0.0)),
    ((3.2, 0.0), (8.0, 0.0)),
    ((8.0, 0.0), (8.0, 2.5)),
    ((8.0, 2.7), (8.0, 5.0)),
    ((8.0, 5.0), (0.0, 5.0)),
    ((0.0, 5.0), (0.0, 0.0)),
    # outer faces of the shell
    ((-0.2, -0.2), (8.2, -0.2)),
    ((8.2, -0.2), (8.2, 5.2)),
    ((8.2, 5.2), (-0.2, 5.2)),
    ((-0.2, 5.2), (-0.2, -0.2)),
    # partition 1 (x = 3 .. 3.2, y = 0 .. 3)
    ((3.0, 0.0), (3.0, 3.0)),
    ((3.0, 3.0), (3.2, 3.0)),
    ((3.2, 3.0), (3.2, 0.0)),
    # partition 2 (y = 2.5 .. 2.7, x = 5.5 .. 8)
    ((8.0, 2.5), (5.5, 2.5)),
    ((5.5, 2.5), (5.5, 2.7)),
    ((5.5, 2.7), (8.0, 2.7)),
]


def sample_segments(segments: list[Segment], spacing: float, phase: float = 0.0) -> np.ndarray:
    """Points along each segment every `spacing` metres, starting `phase * spacing` from its start."""
    out = []
    for (ax, ay), (bx, by) in segments:
        length = math.hypot(bx - ax, by - ay)
        t = np.arange(phase * spacing, length + 1e-9, spacing) / length
        out.append(np.column_stack([ax + t * (bx - ax), ay + t * (by - ay)]))
    return np.concatenate(out)


def visible_mask(position: tuple[float, float], points: np.ndarray, segments: list[Segment]) -> np.ndarray:
    """True where the straight line from `position` to a point crosses no segment before it."""
    c = np.asarray(position, dtype=float)
    d = points - c  # (N, 2)
    ok = np.ones(len(points), dtype=bool)
    for (ax, ay), (bx, by) in segments:
        a = np.array([ax, ay])
        e = np.array([bx - ax, by - ay])
        denom = d[:, 0] * e[1] - d[:, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            w = a - c
            t = (w[0] * e[1] - w[1] * e[0]) / denom  # along the sight line
            u = (w[0] * d[:, 1] - w[1] * d[:, 0]) / denom  # along the segment
        blocked = (np.abs(denom) > 1e-12) & (t > 1e-9) & (t < 1.0 - 1e-6) & (u > -1e-9) & (u < 1.0 + 1e-9)
        ok &= ~blocked
    return ok


def robust_wall_scan(truth: tuple[float, float, float], spacing: float = 0.037, phase: float = 0.35) -> np.ndarray:
    """Map-frame wall points (not on the plan's samples) seen from `truth` and from every point of a
    0.25 m circle around it, so that a guess up to 0.25 m off sees the same walls (no point near an
    occlusion edge, where visibility from the guess and from the truth legitimately differ)."""
    wall = sample_segments(ROOM_FACES, spacing, phase=phase)
    keep = visible_mask(truth[:2], wall, ROOM_FACES)
    for a in np.linspace(0.0, 2 * math.pi, 16, endpoint=False):
        keep &= visible_mask((truth[0] + 0.25 * math.cos(a), truth[1] + 0.25 * math.sin(a)), wall, ROOM_FACES)
    return wall[keep]


def pose_error(truth: tuple[float, float, float], est: tuple[float, float, float]) -> tuple[float, float]:
    """(translation error in metres, absolute yaw error in radians)."""
    dx, dy, dyaw = se2.between(truth, est)
    return math.hypot(dx, dy), abs(dyaw)


@pytest.fixture(scope="module")
def rooms_plan() -> PlanMap:
    return PlanMap.from_points(sample_segments(ROOM_FACES, 0.05))


@pytest.fixture(scope="module")
def office() -> Any:
    return syn.generate_floor(7, "office")


@pytest.fixture(scope="module")
def office_plan(office: Any) -> PlanMap:
    return PlanMap.from_points(office.wall_points())


@pytest.fixture(scope="module")
def office_scan(office: Any) -> tuple[tuple[float, float, float], np.ndarray, np.ndarray]:
    rng = np.random.default_rng(20240607)
    pose = office.sample_pose(rng, clearance=0.6)
    pts, is_clutter = syn.simulate_scan(office, pose, rng)
    return pose, pts, is_clutter


# --------------------------------------------------------------------------------------------------
# known transforms
# --------------------------------------------------------------------------------------------------


KNOWN_POSES = [
    ((5.5, 1.2, 0.4), (0.15, 0.0, 3 * DEG)),
    ((1.5, 2.5, -2.0), (0.0, -0.15, -3 * DEG)),
    ((6.7, 3.9, 2.9), (-0.106, 0.106, 3 * DEG)),
]
SCAN_SAMPLINGS = {
    # (spacing, phase): where along each wall face the noiseless scan points lie
    "plan-samples-5cm": (0.05, 0.0),  # exactly the plan's own points
    "dense-2cm": (0.02, 0.25),
    "offset-3.7cm": (0.037, 0.35),
}


@pytest.mark.parametrize("sampling", [s for s in SCAN_SAMPLINGS if s != "plan-samples-5cm"])
@pytest.mark.parametrize(("truth", "guess_offset"), KNOWN_POSES)
def test_known_transform_recovered_from_noiseless_wall_scan(
    rooms_plan: PlanMap, truth: tuple[float, float, float], guess_offset: tuple[float, float, float], sampling: str
) -> None:
    spacing, phase = SCAN_SAMPLINGS[sampling]
    wall = robust_wall_scan(truth, spacing, phase)
    assert len(wall) > 300
    scan = se2.transform_points(se2.inverse(truth), wall)
    guess = (truth[0] + guess_offset[0], truth[1] + guess_offset[1], truth[2] + guess_offset[2])
    res = localize(scan, rooms_plan, guess)
    dt, dyaw = pose_error(truth, res.pose)
    assert dt < 0.005 and dyaw < 0.1 * DEG, f"error {dt * 1000:.1f} mm, {math.degrees(dyaw):.3f} deg; {res}"
    assert res.converged
    assert res.inlier_ratio == 1.0
    assert res.num_inliers == len(scan)
    assert res.inlier_mask.all()


@pytest.mark.parametrize(("truth", "guess_offset"), KNOWN_POSES)
def test_a_scan_on_the_plans_own_lattice_stops_within_a_lattice_spacing(
    rooms_plan: PlanMap, truth: tuple[float, float, float], guess_offset: tuple[float, float, float]
) -> None:
    """The known limitation (docs/limitations.md): a noiseless scan made of exactly the plan's 5 cm sample points
    is the one case where point-to-point pairing aliases. From 0.15 m / 3 deg off, ICP may stop on
    a lattice-shifted fixed point, which lies less than one lattice spacing from the truth: with
    either search, 0 to 32.5 mm and up to 0.48 deg over these three poses (which pose stops where
    moves with the pairs' ties: the index's cell, the KD-tree's order). This bounds it (real beams
    do not hit walls on the plan's lattice)."""
    wall = robust_wall_scan(truth, 0.05, 0.0)
    scan = se2.transform_points(se2.inverse(truth), wall)
    guess = (truth[0] + guess_offset[0], truth[1] + guess_offset[1], truth[2] + guess_offset[2])
    for config in (IcpConfig(), IcpConfig(correspondence_search="kd_tree")):
        res = localize(scan, rooms_plan, guess, config)
        dt, dyaw = pose_error(truth, res.pose)
        assert dt < 0.05 and dyaw < 0.5 * DEG, f"error {dt * 1000:.1f} mm, {math.degrees(dyaw):.3f} deg; {res}"
        assert res.converged and res.inlier_ratio == 1.0


@pytest.mark.parametrize("truth", [p for p, _ in KNOWN_POSES])
def test_exact_correspondences_from_the_truth_stay_at_the_truth(
    rooms_plan: PlanMap, truth: tuple[float, float, float]
) -> None:
    """The scan IS the plan's points seen from `truth`: every scan point has a plan point at distance 0,
    so starting at the truth, ICP must stay there with zero residual, visibility on or off."""
    wall = robust_wall_scan(truth, 0.05, 0.0)
    scan = se2.transform_points(se2.inverse(truth), wall)
    for cfg in (IcpConfig(use_visibility=False), IcpConfig()):
        res = localize(scan, rooms_plan, truth, cfg)
        dt, dyaw = pose_error(truth, res.pose)
        assert dt < 1e-9 and dyaw < 1e-9, (cfg.use_visibility, res)
        assert res.rmse < 1e-9, (cfg.use_visibility, res)


@pytest.mark.parametrize("truth", [p for p, _ in KNOWN_POSES])
def test_visible_set_does_not_shrink_with_a_shorter_range(
    rooms_plan: PlanMap, truth: tuple[float, float, float]
) -> None:
    """Points visible with max_range=30 that lie well inside 8 m must also be visible with max_range=8
    (localize casts with about the scan's farthest range, so this is the set it matches against)."""
    far = rooms_plan.visible_indices(truth, 30.0)
    near = rooms_plan.visible_indices(truth, 8.0)
    pts = rooms_plan.points[far]
    inside = far[np.hypot(pts[:, 0] - truth[0], pts[:, 1] - truth[1]) < 8.0 - 0.2]
    missing = np.setdiff1d(inside, near)
    assert len(missing) == 0, f"{len(missing)} points lost: {rooms_plan.points[missing].round(3).tolist()}"


# --------------------------------------------------------------------------------------------------
# accuracy on synthetic floors
# --------------------------------------------------------------------------------------------------


def _trials(layout: str, seed: int) -> list[tuple[tuple[float, float, float], IcpResult, IcpResult]]:
    """(truth, result with visibility, result without) for POSES_PER_FLOOR poses of one floor."""
    floor = syn.generate_floor(seed, layout)
    plan = PlanMap.from_points(floor.wall_points())
    rng = np.random.default_rng(1000 + seed)
    no_vis = IcpConfig(use_visibility=False)
    out = []
    for _ in range(POSES_PER_FLOOR):
        truth = floor.sample_pose(rng, clearance=0.6)
        pts, _ = syn.simulate_scan(floor, truth, rng, range_sigma=0.015)
        guess = syn.perturb_pose(truth, rng, 0.2, 3 * DEG)
        out.append((truth, localize(pts, plan, guess), localize(pts, plan, guess, no_vis)))
    return out


def _success(truth: tuple[float, float, float], res: IcpResult) -> bool:
    dt, dyaw = pose_error(truth, res.pose)
    return dt < 0.05 and dyaw < 0.5 * DEG


@pytest.fixture(scope="module")
def accuracy_trials() -> dict[tuple[str, int], list[tuple[Any, IcpResult, IcpResult]]]:
    return {(layout, seed): _trials(layout, seed) for layout in LAYOUTS for seed in ACCURACY_SEEDS}


@pytest.mark.parametrize("layout", LAYOUTS)
def test_accuracy_on_synthetic_floors(layout: str, accuracy_trials: dict[Any, Any]) -> None:
    per_seed = {}
    for seed in ACCURACY_SEEDS:
        trials = accuracy_trials[(layout, seed)]
        per_seed[seed] = sum(_success(t, r) for t, r, _ in trials)
    total = sum(per_seed.values())
    n = POSES_PER_FLOOR * len(ACCURACY_SEEDS)
    failures = [
        (seed, round(pose_error(t, r.pose)[0], 3), round(math.degrees(pose_error(t, r.pose)[1]), 2), r.converged)
        for seed in ACCURACY_SEEDS
        for t, r, _ in accuracy_trials[(layout, seed)]
        if not _success(t, r)
    ]
    assert total >= 0.9 * n, (
        f"{layout}: {total}/{n} successes, per seed {per_seed}; failures (seed, m, deg, converged): {failures}"
    )


def test_visibility_beats_no_visibility_on_office(accuracy_trials: dict[Any, Any]) -> None:
    with_vis = without = 0
    err_vis: list[float] = []
    err_novis: list[float] = []
    for seed in ACCURACY_SEEDS:
        for truth, r_vis, r_novis in accuracy_trials[("office", seed)]:
            with_vis += _success(truth, r_vis)
            without += _success(truth, r_novis)
            err_vis.append(pose_error(truth, r_vis.pose)[0])
            err_novis.append(pose_error(truth, r_novis.pose)[0])
    assert with_vis > without, (with_vis, without)
    assert float(np.mean(err_vis)) < float(np.mean(err_novis)), (np.mean(err_vis), np.mean(err_novis))


# --------------------------------------------------------------------------------------------------
# inliers and outliers
# --------------------------------------------------------------------------------------------------


def test_inlier_mask_separates_clutter_from_walls(office: Any, office_plan: PlanMap) -> None:
    rng = np.random.default_rng(99)
    far_clutter_out = far_clutter = wall_in = wall_total = 0
    plan_pts = office_plan.points
    for _ in range(6):
        truth = office.sample_pose(rng, clearance=0.6)
        pts, is_clutter = syn.simulate_scan(office, truth, rng)
        res = localize(pts, office_plan, syn.perturb_pose(truth, rng, 0.2, 3 * DEG))
        assert _success(truth, res), res
        world = se2.transform_points(truth, pts[is_clutter])
        far = nearest_distance(world, plan_pts) > 0.3
        far_clutter += int(far.sum())
        far_clutter_out += int((~res.inlier_mask[is_clutter][far]).sum())
        wall_total += int((~is_clutter).sum())
        wall_in += int(res.inlier_mask[~is_clutter].sum())
    assert far_clutter >= 100, "the office floor should show some furniture away from walls"
    assert far_clutter_out >= 0.95 * far_clutter, (far_clutter_out, far_clutter)
    assert wall_in >= 0.9 * wall_total, (wall_in, wall_total)


def test_added_far_outliers_are_all_outliers(rooms_plan: PlanMap) -> None:
    truth = (5.5, 1.2, 0.4)
    wall = robust_wall_scan(truth)
    # a cabinet face 0.6 m in front of the top wall, in the map frame
    cabinet = np.column_stack([np.linspace(3.6, 5.0, 120), np.full(120, 4.4)])
    scan = se2.transform_points(se2.inverse(truth), np.vstack([wall, cabinet]))
    res = localize(scan, rooms_plan, (5.6, 1.3, 0.4 + 2 * DEG))
    assert not res.inlier_mask[len(wall) :].any()
    assert res.inlier_mask[: len(wall)].all()
    assert res.num_inliers == len(wall)
    assert res.inlier_ratio == pytest.approx(len(wall) / len(scan))
    dt, dyaw = pose_error(truth, res.pose)
    assert dt < 0.005 and dyaw < 0.1 * DEG


# --------------------------------------------------------------------------------------------------
# result fields
# --------------------------------------------------------------------------------------------------


def test_result_fields_and_covariance(office_plan: PlanMap, office_scan: Any) -> None:
    truth, pts, _ = office_scan
    res = localize(pts, office_plan, syn.perturb_pose(truth, np.random.default_rng(3), 0.2, 3 * DEG))
    assert _success(truth, res), res
    np.testing.assert_allclose(res.T_map_base, se2.pose_to_matrix(res.pose), rtol=0, atol=0)
    m = res.T_map_base
    assert m.shape == (3, 3)
    assert m[0, 2] == res.pose[0] and m[1, 2] == res.pose[1]
    assert math.atan2(m[1, 0], m[0, 0]) == pytest.approx(res.pose[2], abs=1e-12)
    assert res.inlier_mask.shape == (len(pts),) and res.inlier_mask.dtype == np.bool_
    assert res.num_inliers == int(res.inlier_mask.sum())
    assert res.inlier_ratio == pytest.approx(res.num_inliers / len(pts))
    # The nearest-wall index matches against the whole plan (hidden faces are refused pair by
    # pair); the KD-tree search against the subset visible from the guess.
    assert res.num_target_points == len(office_plan)
    guess = syn.perturb_pose(truth, np.random.default_rng(3), 0.2, 3 * DEG)
    kd = localize(pts, office_plan, guess, IcpConfig(correspondence_search="kd_tree"))
    assert 0 < kd.num_target_points < len(office_plan), "visibility should select a subset"
    assert _success(truth, kd), kd
    assert 0.005 < res.rmse < 0.05  # 1.5 cm range noise
    cov = res.covariance
    assert cov.shape == (3, 3)
    assert np.all(np.isfinite(cov))
    np.testing.assert_allclose(cov, cov.T, rtol=0, atol=1e-18)
    assert np.all(np.linalg.eigvalsh(cov) > 0), cov
    sx, sy, syaw = res.std
    assert 0 < sx < 0.02 and 0 < sy < 0.02, res.std
    assert 0 < syaw < 0.5 * DEG, res.std
    with pytest.raises(ValueError, match="read-only"):
        res.inlier_mask[0] = not res.inlier_mask[0]


def test_no_visibility_targets_the_whole_plan(office_plan: PlanMap, office_scan: Any) -> None:
    truth, pts, _ = office_scan
    res = localize(pts, office_plan, truth, IcpConfig(use_visibility=False))
    assert res.num_target_points == len(office_plan)


def test_corridor_covariance_is_unconstrained_along_the_corridor() -> None:
    xs = np.arange(0.0, 60.0 + 1e-9, 0.05)
    plan = PlanMap.from_points(np.vstack([np.column_stack([xs, 0 * xs]), np.column_stack([xs, 0 * xs + 2.0])]))
    rng = np.random.default_rng(0)
    truth = (30.0, 1.0, 0.1)
    sx = rng.uniform(22.0, 38.0, 600)
    sy = np.where(rng.random(600) < 0.5, 0.0, 2.0) + rng.normal(0.0, 0.01, 600)
    scan = se2.transform_points(se2.inverse(truth), np.column_stack([sx, sy]))
    res = localize(scan, plan, (30.05, 1.03, 0.1 + 1 * DEG))
    # across the corridor and in yaw the walls fix the pose
    assert abs(res.pose[1] - truth[1]) < 0.01
    assert abs(res.pose[2] - truth[2]) < 0.2 * DEG
    cov = res.covariance
    var_along, var_across = cov[0, 0], cov[1, 1]
    assert math.isinf(var_along) or var_along > 100 * var_across, cov


def test_room_covariance_is_finite_but_corridor_is_not(rooms_plan: PlanMap) -> None:
    rng = np.random.default_rng(5)
    truth = (5.5, 1.2, 0.4)
    wall = robust_wall_scan(truth)
    noisy = wall + rng.normal(0.0, 0.01, wall.shape)
    res = localize(se2.transform_points(se2.inverse(truth), noisy), rooms_plan, truth)
    sx, sy, syaw = res.std
    assert 0 < sx < 0.02 and 0 < sy < 0.02 and 0 < syaw < 1 * DEG, res


def test_repr_shows_pose_and_inliers(rooms_plan: PlanMap) -> None:
    truth = (4.2, 1.1, -0.7)
    scan = se2.transform_points(se2.inverse(truth), rooms_plan.visible_from(truth))
    res = localize(scan, rooms_plan, truth)
    text = repr(res)
    assert text.startswith("IcpResult(")
    x, y, yaw = res.pose
    assert abs(x - 4.2) < 0.01 and abs(y - 1.1) < 0.01
    assert f"pose=(x={x:.4f} m, y={y:.4f} m, yaw={math.degrees(yaw):.3f} deg)" in text
    # The scan is the cast's visible points, a corner's first layer included; the index's masks
    # may hide one of those from the fit.
    assert res.num_inliers >= len(scan) - 2
    assert f"inliers={res.num_inliers}/{len(scan)} ({100 * res.inlier_ratio:.1f} %)" in text
    assert "converged=True" in text


# --------------------------------------------------------------------------------------------------
# iterations and convergence
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("max_iterations", [1, 2, 7, 30, 45])
def test_zero_tolerances_run_exactly_max_iterations(
    office_plan: PlanMap, office_scan: Any, max_iterations: int
) -> None:
    truth, pts, _ = office_scan
    cfg = IcpConfig(max_iterations=max_iterations, translation_tolerance=0.0, rotation_tolerance=0.0)
    res = localize(pts, office_plan, syn.perturb_pose(truth, np.random.default_rng(1), 0.15, 2 * DEG), cfg)
    assert res.iterations == max_iterations


def test_default_tolerances_stop_early(office_plan: PlanMap, office_scan: Any) -> None:
    truth, pts, _ = office_scan
    guess = syn.perturb_pose(truth, np.random.default_rng(1), 0.15, 2 * DEG)
    res = localize(pts, office_plan, guess)
    assert res.converged
    assert 1 <= res.iterations <= IcpConfig().max_iterations
    fixed = localize(pts, office_plan, guess, IcpConfig(translation_tolerance=0.0, rotation_tolerance=0.0))
    assert fixed.iterations == 30
    assert res.iterations < fixed.iterations
    assert pose_error(fixed.pose, res.pose)[0] < 0.002


def test_one_iteration_does_not_converge(office_plan: PlanMap, office_scan: Any) -> None:
    truth, pts, _ = office_scan
    guess = syn.perturb_pose(truth, np.random.default_rng(2), 0.2, 3 * DEG)
    res = localize(pts, office_plan, guess, IcpConfig(max_iterations=1))
    assert res.iterations == 1
    assert res.converged is False


def test_subsample_two_matches_subsample_one(office_plan: PlanMap, office_scan: Any) -> None:
    truth, pts, _ = office_scan
    guess = syn.perturb_pose(truth, np.random.default_rng(4), 0.2, 3 * DEG)
    full = localize(pts, office_plan, guess)
    half = localize(pts, office_plan, guess, IcpConfig(subsample=2))
    assert _success(truth, full) and _success(truth, half)
    dt, dyaw = pose_error(full.pose, half.pose)
    assert dt < 0.01 and dyaw < 0.2 * DEG
    # every point is still scored
    assert half.inlier_mask.shape == (len(pts),)
    assert abs(half.num_inliers - full.num_inliers) <= 0.02 * len(pts)


def test_input_order_and_dtype_do_not_change_the_result(rooms_plan: PlanMap) -> None:
    truth = (5.5, 1.2, 0.4)
    scan = se2.transform_points(se2.inverse(truth), robust_wall_scan(truth))
    guess = (5.6, 1.1, 0.42)
    a = localize(scan, rooms_plan, guess)
    b = localize(scan.tolist(), rooms_plan, list(guess))
    c = localize(np.asfortranarray(scan), rooms_plan, np.array(guess))
    assert a.pose == b.pose == c.pose
    np.testing.assert_array_equal(a.inlier_mask, c.inlier_mask)


# --------------------------------------------------------------------------------------------------
# PlanMap
# --------------------------------------------------------------------------------------------------


def test_visible_from_inside_a_thick_box_sees_only_inner_faces() -> None:
    inner = thick_wall(0.0, 0.0, 6.0, 4.0)  # the room's inner faces, as a rectangle
    outer = thick_wall(-0.3, -0.3, 6.3, 4.3)
    pts = np.vstack([sample_segments(inner, 0.05), sample_segments(outer, 0.05)])
    plan = PlanMap.from_points(pts)
    vis = plan.visible_from((2.0, 1.5, 0.7))
    on_inner = (
        (np.abs(vis[:, 0]) < 1e-9)
        | (np.abs(vis[:, 0] - 6.0) < 1e-9)
        | (np.abs(vis[:, 1]) < 1e-9)
        | (np.abs(vis[:, 1] - 4.0) < 1e-9)
    )
    assert on_inner.all(), vis[~on_inner]
    n_inner = len(sample_segments(inner, 0.05))
    assert len(vis) >= 0.9 * n_inner, (len(vis), n_inner)
    idx = plan.visible_indices((2.0, 1.5, 0.0))
    assert idx.dtype == np.uint32
    assert np.all(np.diff(idx.astype(np.int64)) > 0), "ascending and unique"
    np.testing.assert_array_equal(plan.points[idx], vis)
    # yaw does not matter; a short range sees only the near walls
    np.testing.assert_array_equal(plan.visible_indices((2.0, 1.5, 2.5)), idx)
    near = plan.visible_from((1.0, 1.0, 0.0), max_range=1.5)
    assert len(near) > 0
    assert np.all(np.hypot(near[:, 0] - 1.0, near[:, 1] - 1.0) < 1.5 + 2 * plan.raster_resolution)
    # from outside, only the outer faces are seen: the face x = 6.3 and, at its corners, the first
    # layer behind them (the end points of the faces around the corner, 5 cm in)
    out = plan.visible_from((8.0, 2.0, 0.0))
    assert len(out) > 0 and np.all(np.abs(out[:, 0] - 6.3) <= plan.raster_resolution), out
    assert np.count_nonzero(np.abs(out[:, 0] - 6.3) > 1e-9) <= 4, out


def test_plan_points_len_and_read_only() -> None:
    pts = sample_segments(thick_wall(0.0, 0.0, 3.0, 2.0), 0.05)
    plan = PlanMap.from_points(pts)
    assert len(plan) == len(pts)
    assert plan.points.shape == (len(pts), 2)
    assert plan.points.dtype == np.float64
    assert plan.points.flags.writeable is False
    with pytest.raises(ValueError):
        plan.points[0, 0] = 1.0
    np.testing.assert_array_equal(plan.points, pts)
    assert plan.extent == pytest.approx((0.0, 0.0, 3.0, 2.0))
    assert plan.normals.shape == (len(pts), 2)
    assert 0.05 <= plan.raster_resolution <= 0.1
    assert "PlanMap(" in repr(plan) and str(len(pts)) in repr(plan)
    # the plan copies its input
    pts[0] = (100.0, 100.0)
    assert plan.points[0, 0] != 100.0
    with pytest.raises(TypeError):
        PlanMap(pts)  # type: ignore[arg-type]


def test_explicit_resolution_is_used() -> None:
    pts = sample_segments(thick_wall(0.0, 0.0, 3.0, 2.0), 0.05)
    assert PlanMap.from_points(pts, resolution=0.2).raster_resolution == 0.2


def test_a_plan_drawn_far_denser_than_useful_is_thinned_to_the_size_its_walls_give() -> None:
    """10^7 points on two 2 km walls took 660 s to build, then 148 s and 3 GB for the first
    localize (issue 19): every part of a plan grew with its points, some faster. A plan with more
    than two points per 5 mm square on average keeps the first point of each square, so its size,
    and the work of building and using it, follow its walls' length. The rooms drawn 10 and 100
    times denser than that give plans of the same size, which localize as the ordinary plan does."""
    ordinary = sample_segments(ROOM_FACES, 0.05)
    assert len(PlanMap.from_points(ordinary)) == len(ordinary)  # ordinary densities are kept as given
    dense = [PlanMap.from_points(sample_segments(ROOM_FACES, spacing)) for spacing in (5e-4, 5e-5)]
    walls = sum(math.hypot(bx - ax, by - ay) for (ax, ay), (bx, by) in ROOM_FACES)  # 64.6 m
    sizes = [len(plan) for plan in dense]
    assert sizes[0] == sizes[1], sizes
    assert abs(sizes[0] - walls / 0.005) < 0.02 * walls / 0.005, (sizes, walls / 0.005)
    truth, guess = (5.5, 1.2, 0.4), (5.6, 1.1, 0.45)
    scan = se2.transform_points(se2.inverse(truth), robust_wall_scan(truth))
    for plan in [PlanMap.from_points(ordinary), *dense]:
        result = localize(scan, plan, guess)
        assert pose_error(truth, result.pose)[0] < 0.005 and result.inlier_ratio > 0.99, result


# --------------------------------------------------------------------------------------------------
# scan_to_points
# --------------------------------------------------------------------------------------------------


def test_scan_to_points_exact_conversion_and_invalid_returns_dropped() -> None:
    ranges = [1.0, np.inf, np.nan, -np.inf, 0.05, 50.0, 2.0, 0.1, 30.0]
    pts = scan_to_points(ranges, angle_min=-0.5, angle_increment=0.25, range_min=0.1, range_max=30.0)
    kept = [(0, 1.0), (6, 2.0), (7, 0.1), (8, 30.0)]  # range_min and range_max themselves are valid
    expected = np.array([[r * math.cos(-0.5 + 0.25 * i), r * math.sin(-0.5 + 0.25 * i)] for i, r in kept])
    assert pts.shape == (4, 2) and pts.dtype == np.float64
    np.testing.assert_allclose(pts, expected, rtol=0, atol=1e-12)
    assert pts.flags.c_contiguous


def test_scan_to_points_mounting_offset() -> None:
    mount = (0.3, -0.1, math.pi / 2)  # laser 30 cm ahead, 10 cm right, turned left by 90 deg
    pts = scan_to_points([2.0, 1.0], angle_min=0.0, angle_increment=math.pi / 2, range_min=0.0,
                         range_max=10.0, sensor_pose=mount)  # fmt: skip
    # beam 0 points along the laser's +x, i.e. the robot's +y: (0.3, -0.1 + 2)
    np.testing.assert_allclose(pts[0], [0.3, 1.9], atol=1e-12)
    # beam 1 points along the laser's +y, i.e. the robot's -x: (0.3 - 1, -0.1)
    np.testing.assert_allclose(pts[1], [-0.7, -0.1], atol=1e-12)


def test_scan_to_points_negative_increment_and_int_ranges() -> None:
    pts = scan_to_points(np.array([1, 2, 3], dtype=np.int32), math.pi / 2, -math.pi / 2, 0.0, 5.0)
    np.testing.assert_allclose(pts, [[0.0, 1.0], [2.0, 0.0], [0.0, -3.0]], atol=1e-12)


def test_scan_to_points_all_invalid_gives_empty() -> None:
    pts = scan_to_points([np.nan, np.inf, 0.0], 0.0, 0.1, 0.1, 5.0)
    assert pts.shape == (0, 2)


def test_scan_to_points_round_trip_with_simulated_ranges(office: Any, office_plan: PlanMap) -> None:
    rng = np.random.default_rng(11)
    truth = office.sample_pose(rng, clearance=0.6)
    ranges, a0, da = syn.simulate_ranges(office, truth, rng, range_sigma=0.01)
    pts = scan_to_points(ranges, a0, da, 0.1, 30.0)
    np.testing.assert_allclose(pts, syn.ranges_to_points(ranges, a0, da, 0.1, 30.0), atol=1e-12)
    res = localize(pts, office_plan, syn.perturb_pose(truth, rng, 0.2, 3 * DEG))
    assert _success(truth, res), res


def test_public_api_exports() -> None:
    for name in planicp.__all__:
        assert hasattr(planicp, name), name
    assert isinstance(planicp.__version__, str) and planicp.__version__


def test_both_correspondence_searches_agree(office: Any, office_plan: PlanMap) -> None:
    """The nearest-wall index (default) and the KD-tree over the visible walls end at the same pose
    on cluttered scans from guesses 0.2 m and 3 degrees off; the index is built once and kept."""
    rng = np.random.default_rng(11)
    stats = office_plan.prepare_index()
    # The plan's points lie 5 cm apart: the index's cells are as wide (3 cm where they lie closer).
    assert office_plan.spacing == pytest.approx(0.05, abs=1e-6)
    assert stats.reach == 0.5 and stats.cell == pytest.approx(office_plan.spacing)
    assert 0 < stats.stored_blocks < stats.blocks and stats.candidates > len(office_plan)
    assert office_plan.prepare_index() == stats
    gaps = []
    for _ in range(12):
        truth = office.sample_pose(rng, clearance=0.6)
        pts, _ = syn.simulate_scan(office, truth, rng)
        guess = syn.perturb_pose(truth, rng, 0.2, 3 * DEG)
        fast = localize(pts, office_plan, guess)
        exact = localize(pts, office_plan, guess, IcpConfig(correspondence_search="kd_tree"))
        if _success(truth, exact):
            gaps.append(math.dist(fast.pose[:2], exact.pose[:2]))
    assert len(gaps) >= 10, gaps
    assert max(gaps) < 0.01, gaps


def test_correspondence_search_is_checked() -> None:
    with pytest.raises(ValueError, match="correspondence_search"):
        IcpConfig(correspondence_search="octree")  # type: ignore[arg-type]
    # The native settings check it too (a PlanicpError is a ValueError).
    from planicp import _core

    # (The core reads the settings off any object with their names.)
    fields = SimpleNamespace(**{**IcpConfig().to_dict(), "correspondence_search": "octree"})
    with pytest.raises(ValueError, match='correspondence_search = "octree": must be "wall_index" or "kd_tree"'):
        _core.IcpSettings(fields)
