"""The corrected pose refined to the posterior's mode, or two modes' mean, in the plan's likelihood field
(`planicp.tracking.posterior_refinement`, `planicp._core.LikelihoodGrid`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from planicp import Localizer, PlanMap, PosteriorRefinement, _core
from planicp.plans.ros_map import write_ros_map
from planicp.tracking.decisions import Correction
from planicp.tracking.posterior_refinement import refine_pose
from planicp.tracking.stages.correction import _refined


def room() -> PlanMap:
    """A 6 x 4 m room with a 1 m pillar, walls sampled every 2 cm."""
    segments = [
        ((0, 0), (6, 0)),
        ((6, 0), (6, 4)),
        ((6, 4), (0, 4)),
        ((0, 4), (0, 0)),
        ((2, 1.5), (3, 1.5)),
        ((3, 1.5), (3, 2.5)),
        ((3, 2.5), (2, 2.5)),
        ((2, 2.5), (2, 1.5)),
    ]
    return PlanMap.from_segments(np.array(segments, dtype=float), spacing=0.02)


def corridor() -> PlanMap:
    """Two parallel walls 2 m apart and 40 m long: nothing fixes x."""
    return PlanMap.from_segments(np.array([((0, 0), (40, 0)), ((0, 2), (40, 2))], dtype=float), spacing=0.02)


def comb() -> PlanMap:
    """A 20 m wall with a 0.3 m stub every 0.5 m: a scan fits every 0.5 m along it equally well."""
    segments = [((0, 0), (20, 0))] + [((x, 0), (x, 0.3)) for x in np.arange(0.0, 20.01, 0.5)]
    return PlanMap.from_segments(np.array(segments, dtype=float), spacing=0.02)


def scan_at(plan: PlanMap, pose: tuple[float, float, float], max_range: float = 8.0) -> np.ndarray:
    """The plan's points within `max_range` of `pose`, in the robot frame (a scan of every wall,
    seen through or not: enough for a likelihood)."""
    pts = np.asarray(plan.points)
    near = pts[np.hypot(pts[:, 0] - pose[0], pts[:, 1] - pose[1]) < max_range][::3]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    d = near - np.array(pose[:2])
    return np.ascontiguousarray(np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]]))


def test_the_field_peaks_on_the_walls_and_falls_as_a_gaussian_of_the_plan_spacing() -> None:
    plan = room()
    field = plan.likelihood_field()
    assert field is plan.likelihood_field()  # built once, kept with the plan
    assert field.sigma == pytest.approx(plan.spacing, rel=1e-9)
    assert plan.spacing == pytest.approx(0.02, rel=0.05)
    # Cell centres one sigma apart, bilinear between them: a wall half-way between two centres reads
    # exp(-1/8) = 0.88 at both, and the interpolation falls short of the peak by up to a fifth.
    on, _ = field.value_and_gradient(3.0, 0.0)
    one_sigma, slope = field.value_and_gradient(3.0, field.sigma)
    assert on > 0.75
    assert one_sigma == pytest.approx(math.exp(-0.5), abs=0.12)
    assert one_sigma < on
    assert slope[1] < 0.0  # uphill towards the wall
    assert field.value_and_gradient(3.0, 1.0)[0] == 0.0  # beyond three sigmas of every wall


def test_a_slam_map_wall_drawn_as_a_band_of_cells_peaks_in_its_middle(tmp_path: Path) -> None:
    """A map_server map made by SLAM draws a wall as a band of cells where beams ended, here four
    cells (20 cm at 5 cm). Its field is the cells' summed Gaussians over the largest sum near
    them: it peaks on the band's middle, where the surface most likely is, so a scan cannot slide
    across the band at no cost, as it can in the nearest-point field, flat over the whole band.
    Walls drawn as surfaces keep the nearest-point field: both faces of a 10 cm wall stay peaks."""
    occupancy = np.zeros((40, 60), np.int8)  # image order (row 0 at the top), 5 cm cells
    occupancy[18:22, 5:55] = 100  # rows 18-21: y from 0.925 to 1.075 m, middle 1.0 m
    path = write_ros_map(tmp_path / "slam.yaml", occupancy, 0.05, (0.0, 0.0, 0.0), edge_detector="centres")
    slam = PlanMap.from_ros_map(path, cache=False)  # half its cells inside: it says it is a SLAM map
    assert slam.cells_mark_returns and slam.spacing == pytest.approx(0.05)
    field = slam.likelihood_field()
    nearest = _core.LikelihoodGrid.within_budget(slam.points, slam.spacing, slam.spacing, "nearest")
    middle, shifted = field.value_and_gradient(1.5, 1.0)[0], field.value_and_gradient(1.5, 1.05)[0]
    assert middle > 0.97
    assert middle - shifted > 0.05  # a cell across the band costs
    assert field.value_and_gradient(1.5, 1.04)[1][1] < 0.0 < field.value_and_gradient(1.5, 0.96)[1][1]
    assert nearest.value_and_gradient(1.5, 1.0)[0] == pytest.approx(nearest.value_and_gradient(1.5, 1.05)[0], abs=0.01)
    # Outside the band it falls from its middle's ridge, below the nearest field, to 0 beyond the cut.
    assert 0.0 < field.value_and_gradient(1.5, 1.15)[0] < nearest.value_and_gradient(1.5, 1.15)[0]
    assert field.value_and_gradient(1.5, 1.3)[0] == 0.0

    wall = np.array([((0, 0.0), (3, 0.0)), ((0, 0.1), (3, 0.1))], dtype=float)  # two faces 10 cm apart
    drawn = PlanMap.from_segments(wall, spacing=0.02)
    assert not drawn.cells_mark_returns
    faces = drawn.likelihood_field()
    assert min(faces.value_and_gradient(1.5, 0.0)[0], faces.value_and_gradient(1.5, 0.1)[0]) > 0.75
    assert faces.value_and_gradient(1.5, 0.05)[0] < 0.1  # between the faces: no wall


def test_a_field_profile_must_be_named() -> None:
    with pytest.raises(_core.PlanicpError, match=r'profile must be "nearest" .* or "density" .*, got "flat"'):
        _core.LikelihoodGrid(np.zeros((3, 2)), 0.05, 0.05, "flat")  # type: ignore[arg-type]


def test_a_pose_a_few_centimetres_off_is_brought_back_without_a_prior() -> None:
    plan = room()
    truth = (4.0, 1.0, 0.3)
    scan = scan_at(plan, truth)
    start = (4.035, 0.97, 0.3 + math.radians(1.0))
    refined = refine_pose(scan, start, plan, None, PosteriorRefinement())
    assert refined.prior == "none"
    # From 4.6 cm and 1 degree off to within the field's own sampling (sigma = 2 cm).
    assert math.dist(refined.pose[:2], truth[:2]) < 0.01, refined
    assert abs(refined.pose[2] - truth[2]) < math.radians(0.3), refined
    assert refined.cost < refined.start_cost
    assert refined.moved == pytest.approx(math.dist(start[:2], refined.pose[:2]))


def test_along_a_corridor_the_prior_decides_and_across_it_the_scan() -> None:
    plan = corridor()
    truth = (20.0, 0.8, 0.0)
    scan = scan_at(plan, truth)
    prior_pose = (20.3, 0.8, 0.0)  # 30 cm off along the corridor, where the scan says nothing
    covariance = np.diag([0.1**2, 0.1**2, math.radians(2.0) ** 2])
    start = (20.1, 0.86, 0.0)  # a fit 10 cm along and 6 cm across
    refined = refine_pose(scan, start, plan, ("prediction", prior_pose, covariance), PosteriorRefinement())
    assert refined.prior == "prediction"
    assert refined.pose[0] == pytest.approx(prior_pose[0], abs=0.01)  # along: the prior's
    assert refined.pose[1] == pytest.approx(truth[1], abs=0.005)  # across: the walls'
    # Both climbs end in the one basin: one mode, nothing spread.
    assert refined.other is None and refined.other_share == 0.0 and not refined.spread.any()


def test_of_two_basins_the_one_of_higher_posterior_carries_the_pose_wherever_the_fit_ended() -> None:
    plan = comb()
    truth = (10.0, 1.0, 0.0)
    scan = scan_at(plan, truth, max_range=3.0)
    covariance = np.diag([0.2**2, 0.2**2, math.radians(2.0) ** 2])
    # ICP slid one stub along (0.5 m): from there alone the climb stays in that basin, whose scan
    # likelihood is the true one's; the prediction, 3 cm off, makes the true basin's posterior the
    # higher, and its climb carries the pose.
    slid = (10.5, 1.0, 0.0)
    prediction = (10.03, 1.0, 0.0)
    field = plan.likelihood_field()
    stayed = field.refine(scan, slid, prediction, covariance.tolist(), 0.3)
    assert math.dist(stayed[0][:2], slid[:2]) < 0.02  # the one climb from the fit
    refined = refine_pose(scan, slid, plan, ("prediction", prediction, covariance), PosteriorRefinement())
    assert refined.from_prior
    assert refined.cost < stayed[1] - 4.0  # (0.47 / 0.2)^2 = 5.5 of prior between them
    # The slid basin keeps a share of the mass, e^(-5.5/2) of the true one's, and the mean moves
    # that share of the 0.5 m towards it.
    assert refined.other is not None and math.dist(refined.other[:2], slid[:2]) < 0.02
    assert 0.03 < refined.other_share < 0.1, refined.other_share
    assert math.dist(refined.pose[:2], truth[:2]) < 0.05, refined
    # The prediction where the scan fits nothing (1 m above the wall, turned, a wide covariance): its
    # climb gains nothing, and the fit's basin, of far higher posterior, is kept.
    wide = np.diag([1.0, 1.0, math.radians(10.0) ** 2])
    astray = (10.0, 2.0, 0.3)
    kept = refine_pose(scan, (10.01, 1.0, 0.0), plan, ("prediction", astray, wide), PosteriorRefinement())
    assert not kept.from_prior
    assert kept.other_share < 1e-6
    assert math.dist(kept.pose[:2], truth[:2]) < 0.01, kept


def test_two_modes_of_like_posterior_give_their_mean_and_a_covariance_that_covers_both() -> None:
    # The comb fits every 0.5 m. A prediction 5 cm from the true stub with 0.2 m along the wall:
    # ICP slid to the next stub, and the posterior has a mode at each; the pose is their mean, each
    # weighed by its mass exp(-cost/2) / sqrt(det(information)), and their spread is reported.
    plan = comb()
    truth = (10.0, 1.0, 0.0)
    scan = scan_at(plan, truth, max_range=3.0)
    covariance = np.diag([0.2**2, 0.1**2, math.radians(2.0) ** 2])
    slid, prediction = (10.5, 1.0, 0.0), (10.05, 1.0, 0.0)
    field = plan.likelihood_field()
    ends = [field.refine(scan, start, prediction, covariance.tolist(), 0.3) for start in (prediction, slid)]
    (true_end, true_cost, _, true_info, _), (slid_end, slid_cost, _, slid_info, _) = ends
    assert abs(true_end[0] - 10.0) < 0.02 and abs(slid_end[0] - 10.49) < 0.02
    mass = [math.exp(-c / 2) / math.sqrt(np.linalg.det(i)) for c, i in ((true_cost, true_info), (slid_cost, slid_info))]
    share = mass[1] / sum(mass)
    assert 0.1 < share < 0.4, share  # like posteriors: neither mode's mass is negligible
    refined = refine_pose(scan, slid, plan, ("prediction", prediction, covariance), PosteriorRefinement())
    assert refined.from_prior and refined.other is not None
    assert refined.other_share == pytest.approx(share, rel=1e-6)
    d = slid_end[0] - true_end[0]
    assert refined.pose[0] == pytest.approx(true_end[0] + share * d, abs=1e-6)
    assert refined.spread[0, 0] == pytest.approx(share * (1 - share) * d**2, rel=1e-6)
    # The correction stage reports the pose with the spread added to the fusion's covariance, and
    # says so.
    fused = Correction(slid, np.diag([0.02**2, 0.02**2, math.radians(0.5) ** 2]), True, None, "fused")
    the_rules = Localizer(plan, prediction, refinement=PosteriorRefinement())._rules()
    corrected = _refined(scan, fused, ("prediction", prediction, covariance), the_rules)
    assert corrected.pose == refined.pose
    assert np.allclose(corrected.covariance, fused.covariance + refined.spread)
    assert math.sqrt(corrected.covariance[0, 0]) > 0.15  # half the 0.49 m between the modes, nearly
    assert "mean over two modes" in corrected.why


def test_the_localizer_reports_the_refinement_and_can_be_told_not_to_refine() -> None:
    plan = room()
    truth = (4.0, 1.0, 0.3)
    scan = scan_at(plan, truth)
    on = Localizer(plan, (4.03, 1.02, 0.3), refinement=PosteriorRefinement())
    estimate = on.update(scan, (0.0, 0.0, 0.0))
    correction = estimate.decisions[5]
    assert correction.refinement is not None and correction.refinement.prior == "prediction"
    assert estimate.pose == correction.refinement.pose
    assert math.dist(estimate.pose[:2], truth[:2]) < 0.02
    off = Localizer(plan, (4.03, 1.02, 0.3), refinement=PosteriorRefinement(enabled=False))
    assert off.update(scan, (0.0, 0.0, 0.0)).decisions[5].refinement is None


def test_bad_refinement_inputs_are_refused_with_the_fix() -> None:
    field = room().likelihood_field()
    scan = scan_at(room(), (4.0, 1.0, 0.3))
    with pytest.raises(_core.PlanicpError, match="prior_covariance must be finite and invertible"):
        field.refine(scan, (4.0, 1.0, 0.3), (4.0, 1.0, 0.3), np.zeros((3, 3)).tolist(), 0.1)
    with pytest.raises(_core.PlanicpError, match="weight must be a positive finite number"):
        field.refine(scan, (4.0, 1.0, 0.3), (4.0, 1.0, 0.3), np.eye(3).tolist(), 0.0)
    with pytest.raises(_core.PlanicpError, match="sigma"):
        _core.LikelihoodGrid(np.zeros((3, 2)), 0.05, -1.0)
    with pytest.raises(ValueError, match="return_weight"):
        PosteriorRefinement(return_weight=0.0)
    with pytest.raises(TypeError, match="refinement must be a planicp.PosteriorRefinement"):
        Localizer(room(), (0.0, 0.0, 0.0), refinement=0.15)  # type: ignore[arg-type]


def test_a_plan_too_large_for_a_field_at_its_spacing_gets_a_coarser_one_with_the_same_sigma() -> None:
    """A field at the plan's spacing over 820 m square would need 269 Mi cells, over the native
    limit of 256 Mi: it is sampled every 1.25 spacings instead, and its Gaussian is the same (no
    update that refines or weighs a place fails on a campus-size plan)."""
    side = 820.0
    segments = [((0, 0), (side, 0)), ((side, 0), (side, side)), ((side, side), (0, side)), ((0, side), (0, 0))]
    plan = PlanMap.from_segments(np.array(segments, dtype=float), spacing=0.05)
    field = plan.likelihood_field()
    assert field.sigma == pytest.approx(plan.spacing, rel=1e-9)
    assert field.resolution == pytest.approx(1.25 * plan.spacing, rel=1e-9)
    assert field.value_and_gradient(400.0, 0.0)[0] > 0.7  # on the wall
    assert field.value_and_gradient(400.0, 3 * field.sigma + 2 * field.resolution)[0] == 0.0


def test_a_field_that_fits_at_no_useful_sampling_is_refused_with_the_cause() -> None:
    """Points 10^8 m apart (a plan in the wrong units, a stray point) would need samples
    thousands of sigmas apart: refused, naming the field, the resolution asked for and the fix."""
    far = np.array([[0.0, 0.0], [1e8, 1e8]])
    refused = r"likelihood field at 0.05 m would need .* cells .*\(wrong units, stray points\)"
    with pytest.raises(_core.PlanicpError, match=refused):
        _core.LikelihoodGrid.within_budget(far, 0.05, 0.05)
    assert _core.LikelihoodGrid.within_budget(far[:1], 0.05, 0.05).resolution == 0.05
