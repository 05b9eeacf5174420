"""The drift experiment end to end: odometry drifts, planicp stays on the truth, on several plans."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planicp import EnhancedOccupancyGrid, PlanMap, PlanRaster, compare_grids
from planicp import sim as synthetic
from planicp.cli import main as cli_main
from planicp.plans.default_plan import load_default_plan
from planicp.plans.plan_loading import load_plan
from planicp.sim.experiment import ExperimentConfig, LidarModel, replay, run_experiment
from planicp.tracking.icp_config import IcpConfig


def check_flat(metrics: dict[str, float]) -> None:
    assert metrics["planicp_position_rms_m"] < 0.03
    assert metrics["planicp_heading_rms_deg"] < 0.5
    assert metrics["planicp_position_max_m"] < 0.10
    assert metrics["odometry_position_max_m"] > 5 * metrics["planicp_position_max_m"]
    assert metrics["accepted_share"] > 0.9


def test_default_plan_odometry_drifts_planicp_does_not() -> None:
    recording, world = run_experiment(load_default_plan(), ExperimentConfig(duration_s=60.0, seed=1))
    metrics = recording.metrics()
    check_flat(metrics)
    assert metrics["odometry_heading_max_deg"] > 5.0
    assert len(recording.times) == 601 and len(world.people) >= 3
    assert recording.lost is not None and recording.lost.shape == (601,)
    assert metrics["lost_scans"] == 0 and metrics["lost_at_end"] == 0
    # odometry and truth start together (the odom frame is the start pose)
    np.testing.assert_allclose(recording.odometry[0], recording.truth[0], atol=1e-12)


@pytest.mark.parametrize("layout", ["hall", "diagonal"])
def test_generated_floors(layout: str) -> None:
    floor = synthetic.generate_floor(11, layout, furniture_per_room=0)
    raster = PlanRaster(floor.walls[::-1], floor.resolution, (floor.origin[0], floor.origin[1], 0.0))
    recording, _ = run_experiment(PlanMap.from_raster(raster), ExperimentConfig(duration_s=30.0, seed=2))
    check_flat(recording.metrics())


def test_real_layout_house_expo() -> None:
    """The HouseExpo sample (a real home's outline), rasterised with 15 cm walls."""
    plan = load_plan(Path(__file__).parent / "data" / "house_expo_room_0000.json", resolution=0.05)
    assert plan.raster is not None
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=30.0, seed=3))
    check_flat(recording.metrics())


def test_without_outlier_rejection_is_worse_and_replay_is_deterministic() -> None:
    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=20.0, seed=4))
    again = replay(plan, recording, IcpConfig.for_tracking())
    np.testing.assert_array_equal(again.estimate, recording.estimate)
    naive = replay(
        plan,
        recording,
        IcpConfig(max_correspondence_distance=50.0, use_visibility=False, correspondence_schedule=(1.0,)),
    )
    assert naive.metrics()["planicp_position_rms_m"] > 3 * recording.metrics()["planicp_position_rms_m"]


def test_bad_experiment_settings() -> None:
    with pytest.raises(ValueError, match="duration_s must be a positive"):
        ExperimentConfig(duration_s=-1.0)
    with pytest.raises(ValueError, match="odometry_rate_hz .* must be at least the LIDAR rate"):
        ExperimentConfig(odometry_rate_hz=5.0)
    with pytest.raises(ValueError, match="rate_hz must be a positive"):
        LidarModel(rate_hz=-10.0)
    with pytest.raises(ValueError, match="dropout must be in"):
        LidarModel(dropout=1.5)
    with pytest.raises(ValueError, match="no enclosed free space of 1 m.2 or more to furnish"):
        run_experiment(PlanMap.from_points(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])))
    full = np.ones((40, 40), dtype=bool)
    with pytest.raises(ValueError, match="no enclosed free space"):
        run_experiment(PlanMap.from_raster(PlanRaster(full, 0.05, (0.0, 0.0, 0.0))))


def test_default_demo_writes_figures_metrics_and_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # The demo exactly as `planicp demo` runs it (300 s, seed 0), only the output folder differs.
    out = tmp_path / "demo"
    assert cli_main(["demo", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "odometry" in printed and "planicp" in printed
    names = {p.name for p in out.iterdir()}
    assert names == {
        "position_error.png",
        "heading_error.png",
        "paths.png",
        "plan.png",
        "scan_without_rejection.png",
        "scan_with_rejection.png",
        "metrics.json",
        "report.md",
        "eog_odometry.png",
        "eog_planicp.png",
        "eog_comparison.png",
        "eog_planicp.yaml",
        "eog_planicp.pgm",
    }
    metrics = json.loads((out / "metrics.json").read_text())
    default = metrics["runs"]["planicp (default)"]
    assert metrics["scans"] == 3001 and set(metrics["runs"]) == {
        "planicp (default)",
        "without outlier rejection",
        "without automatic trimming",
    }
    # The enhanced occupancy grid from planicp's poses agrees with the ground-truth grid; the one
    # from odometry does not.
    grid = metrics["occupancy_grid"]
    for share in ("occupied_near_reference", "free_in_reference"):
        assert grid["planicp"][share] >= 0.95
        assert grid["odometry"][share] < grid["planicp"][share] - 0.2
    assert grid["planicp"]["occupied_cells"] > 1000 and grid["planicp"]["free_cells"] > 100_000
    report = (out / "report.md").read_text()
    # The report states this run's numbers.
    assert f"{default['planicp_position_rms_m']:.3f} m" in report
    assert f"{default['odometry_heading_max_deg']:.2f} deg" in report
    assert f"{grid['planicp']['free_in_reference']:.3f}" in report
    assert f"{grid['odometry']['occupied_near_reference']:.3f}" in report
    # The exported grid is a map_server map whose walls include the plan's.
    exported = PlanMap.from_ros_map(out / "eog_planicp.yaml", cache=False)
    assert len(exported) > len(load_default_plan())
    assert cli_main(["demo", "--plan", str(tmp_path / "none.png"), "--resolution", "0.05", "--out", str(out)]) == 2
    assert cli_main(["demo", "--plan", str(out / "plan.png"), "--out", str(out)]) == 2
    assert "--resolution" in capsys.readouterr().err


def test_recording_occupancy_grids() -> None:
    plan = load_default_plan()
    config = ExperimentConfig(duration_s=10.0, seed=5)
    recording, _ = run_experiment(plan, config)
    grid = recording.occupancy_grid(plan, "estimate", config.lidar.mount, 0.1)
    by_hand = EnhancedOccupancyGrid(plan, 0.1)
    for scan, pose in zip(recording.scans, recording.estimate):
        by_hand.integrate(scan, pose, config.lidar.mount)
    assert grid.scans == len(recording.scans) == 101
    np.testing.assert_array_equal(grid.states(), by_hand.states())
    truth = recording.occupancy_grid(plan, "truth", config.lidar.mount, 0.1)
    assert compare_grids(grid, truth).free_in_reference > 0.99
    with pytest.raises(ValueError, match="which must be one of"):
        recording.poses("ground truth")
    with pytest.raises(ValueError, match="which must be 'odometry' or 'estimate'"):
        recording.errors("truth")


def test_recording_keeps_the_whole_odometry_stream() -> None:
    """The 100 Hz odometry a robot publishes is kept; at the scan times it is what the Localizer got."""
    config = ExperimentConfig(duration_s=3.0, seed=6)
    recording, _ = run_experiment(load_default_plan(), config)
    assert recording.odometry_stream is not None and recording.odometry_stream_times is not None
    assert recording.odometry_stream.shape == (len(recording.odometry_stream_times), 3)
    np.testing.assert_allclose(np.diff(recording.odometry_stream_times), 1.0 / config.odometry_rate_hz)
    at_scans = np.searchsorted(recording.odometry_stream_times, recording.times)
    np.testing.assert_array_equal(recording.odometry_stream[at_scans], recording.odometry_in_odom)
