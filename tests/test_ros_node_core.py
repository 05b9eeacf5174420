"""The ROS node's logic without ROS (issue 9): `planicp.ros.PlanicpNodeCore` and its helpers.

A simulated drive through the shipped office plan is fed as a robot stack delivers it: odometry at
100 Hz and scans at 10 Hz, each as its own message. The live test against a real roscore is
`test_ros_live.py`.
"""

from __future__ import annotations

import importlib.util
import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from planicp import IcpConfig, LostRule, _core
from planicp.plans.default_plan import load_default_plan
from planicp.plans.plan_map import PlanMap
from planicp.ros import (
    NodeSettings,
    OdometryBuffer,
    PlanicpNodeCore,
    PoseOutput,
    ScanInput,
    covariance_from_6x6,
    covariance_to_6x6,
    odometry_buffer,
    plan_occupancy_grid,
    quaternion_to_yaw,
    ros_package_path,
    yaw_to_quaternion,
)
from planicp.ros.message_layout import planar_mount
from planicp.se2 import between, compose, inverse
from planicp.sim.experiment import ExperimentConfig, Recording, run_experiment


@pytest.fixture(scope="module")
def plan() -> PlanMap:
    return load_default_plan()


@pytest.fixture(scope="module")
def drive(plan: PlanMap) -> Recording:
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=12.0, seed=11))
    return recording


def make_core(plan: PlanMap, drive: Recording, **settings: object) -> PlanicpNodeCore:
    return PlanicpNodeCore(plan, NodeSettings(initial_pose=tuple(drive.truth[0]), **settings))  # type: ignore[arg-type]


def scan_fields(drive: Recording, k: int) -> dict[str, object]:
    lidar = drive.lidar
    assert lidar is not None and drive.ranges is not None
    return {
        "stamp": float(drive.times[k]),
        "ranges": drive.ranges[k],
        "angle_min": lidar.angle_min,
        "angle_increment": lidar.angle_increment,
        "range_min": lidar.range_min,
        "range_max": lidar.range_max,
        "angle_max": lidar.angle_min + lidar.angle_increment * (lidar.beams - 1),
        "laser_pose": lidar.mount,
    }


def messages(drive: Recording, first: int = 0, last: int | None = None) -> Iterator[tuple[str, int]]:
    """("odom", i) and ("scan", k) in the order a robot publishes them (odometry first at equal stamps)."""
    times, scans = drive.odometry_stream_times, drive.times
    assert times is not None
    last = len(scans) if last is None else last
    j = int(np.searchsorted(times, scans[first]))
    for k in range(first, last):
        while j < len(times) and times[j] <= scans[k]:
            yield "odom", j
            j += 1
        yield "scan", k


def feed(core: PlanicpNodeCore, drive: Recording, first: int = 0, last: int | None = None) -> dict[int, PoseOutput]:
    """Outputs by scan index."""
    assert drive.odometry_stream is not None and drive.odometry_stream_times is not None
    by_stamp = {float(t): k for k, t in enumerate(drive.times)}
    out: dict[int, PoseOutput] = {}
    for kind, i in messages(drive, first, last):
        if kind == "odom":
            produced = core.add_odometry(float(drive.odometry_stream_times[i]), drive.odometry_stream[i])
        else:
            produced = core.add_scan(**scan_fields(drive, i))  # type: ignore[arg-type]
        for o in produced:
            out[by_stamp[o.stamp]] = o
    return out


def position_error(a: tuple[float, float, float], b: np.ndarray) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


# --- message layouts -------------------------------------------------------------------------------


def test_covariance_goes_to_rows_and_columns_0_1_5_of_the_6x6() -> None:
    cov = np.array([[1.0, 2.0, 3.0], [2.0, 5.0, 6.0], [3.0, 6.0, 9.0]])
    flat = covariance_to_6x6(cov)
    assert len(flat) == 36
    expected = {0: 1.0, 1: 2.0, 5: 3.0, 6: 2.0, 7: 5.0, 11: 6.0, 30: 3.0, 31: 6.0, 35: 9.0}
    assert {i: v for i, v in enumerate(flat) if v != 0.0} == expected
    np.testing.assert_array_equal(covariance_from_6x6(flat), cov)
    with pytest.raises(ValueError, match="36 values"):
        covariance_from_6x6([0.0] * 35)
    with pytest.raises(ValueError, match="non-finite"):
        covariance_from_6x6([math.nan] * 36)
    with pytest.raises(ValueError, match="3x3"):
        covariance_to_6x6(np.eye(2))


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.0, math.pi, -math.pi + 1e-9])
def test_quaternion_round_trip(yaw: float) -> None:
    back = quaternion_to_yaw(*yaw_to_quaternion(yaw))
    assert math.isclose(math.remainder(back - yaw, 2 * math.pi), 0.0, abs_tol=1e-12)


def test_bad_quaternions_are_refused() -> None:
    with pytest.raises(ValueError, match="zero quaternion"):
        quaternion_to_yaw(0.0, 0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="finite quaternion"):
        quaternion_to_yaw(0.0, 0.0, math.nan, 1.0)


def test_an_upside_down_laser_mirrors_its_beams() -> None:
    """Roll pi about x, then yaw 0.4: a beam at +a in the laser points at yaw - a in the base."""
    yaw, roll = 0.4, math.pi
    cy, sy, cr, sr = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(roll / 2), math.sin(roll / 2)
    q = (sr * cy, sr * sy, cr * sy, cr * cy)  # yaw * roll, as (x, y, z, w)
    (x, y, mount_yaw), flipped = planar_mount((0.2, -0.1, 0.3), q)
    assert flipped and (x, y) == (0.2, -0.1) and math.isclose(mount_yaw, yaw, abs_tol=1e-12)
    (_, _, upright_yaw), upright = planar_mount((0.0, 0.0, 0.0), yaw_to_quaternion(0.7))
    assert not upright and math.isclose(upright_yaw, 0.7)


# --- the core on a drive ---------------------------------------------------------------------------


def test_tracks_the_drive_and_map_to_odom_composes_with_odometry(plan: PlanMap, drive: Recording) -> None:
    core = make_core(plan, drive)
    out = feed(core, drive)
    assert sorted(out) == list(range(len(drive.times)))
    errors = np.array([position_error(out[k].pose, drive.truth[k]) for k in out])
    assert np.sqrt(np.mean(errors**2)) < 0.02 and errors.max() < 0.06, (errors.mean(), errors.max())
    for k, o in out.items():
        np.testing.assert_allclose(o.odom_pose, drive.odometry_in_odom[k], atol=1e-9)
        composed = compose(o.map_to_odom, o.odom_pose)
        np.testing.assert_allclose(composed[:2], o.pose[:2], atol=1e-9)
        assert abs(math.remainder(composed[2] - o.pose[2], 2 * math.pi)) < 1e-9
        flat = o.covariance_6x6
        assert all(flat[i] == 0.0 for i in range(36) if i not in (0, 1, 5, 6, 7, 11, 30, 31, 35))
        assert flat[0] > 0 and flat[7] > 0 and flat[35] > 0 and flat[1] == flat[6]
    d = core.diagnostics()
    assert d.level == 0 and d.scans_processed == len(drive.times) and d.accepted + d.rejected == d.scans_processed
    assert d.recent_inlier_ratio > 0.8 and "tracking" in d.message
    assert set(d.values()) >= {"inlier_ratio", "accepted", "rejected", "malformed_scans", "lost"}


def test_a_laser_scan_message_from_an_upside_down_laser_is_the_same_scan(plan: PlanMap, drive: Recording) -> None:
    """`add_scan_message` reads a LaserScan's fields (ROS 1 and 2 alike); a laser mounted upside
    down reports each beam at the negated angle, and its message gives the same poses as the
    upright scan."""
    from types import SimpleNamespace

    upright, mirrored = make_core(plan, drive), make_core(plan, drive)
    assert drive.odometry_stream is not None and drive.odometry_stream_times is not None
    poses: list[tuple[tuple[float, float, float], tuple[float, float, float]]] = []
    for kind, i in messages(drive, 0, 12):
        if kind == "odom":
            t, odom = float(drive.odometry_stream_times[i]), drive.odometry_stream[i]
            upright.add_odometry(t, odom)
            mirrored.add_odometry(t, odom)
            continue
        f = scan_fields(drive, i)
        msg = SimpleNamespace(
            ranges=f["ranges"],
            angle_min=-f["angle_min"],  # type: ignore[operator]
            angle_increment=-f["angle_increment"],  # type: ignore[operator]
            angle_max=-f["angle_max"],  # type: ignore[operator]
            range_min=f["range_min"],
            range_max=f["range_max"],
        )
        a = upright.add_scan(**f)  # type: ignore[arg-type]
        b = mirrored.add_scan_message(f["stamp"], msg, (f["laser_pose"], True))  # type: ignore[arg-type]
        poses.extend((x.pose, y.pose) for x, y in zip(a, b, strict=True))
    assert len(poses) >= 10
    for x, y in poses:
        np.testing.assert_allclose(x, y, atol=1e-9)


def test_a_scan_ahead_of_the_odometry_waits_for_it(plan: PlanMap, drive: Recording) -> None:
    """Scans often arrive before the odometry message of their stamp: they wait, one at a time."""
    assert drive.odometry_stream is not None and drive.odometry_stream_times is not None
    core = make_core(plan, drive)
    feed(core, drive, 0, 5)
    j = int(np.searchsorted(drive.odometry_stream_times, drive.times[5]))  # odometry at scan 5's stamp
    assert core.add_scan(**scan_fields(drive, 5)) == []  # type: ignore[arg-type]
    produced = core.add_odometry(float(drive.odometry_stream_times[j - 5]), drive.odometry_stream[j - 5])
    assert produced == [] and core.diagnostics().scans_processed == 5
    for i in range(j - 4, j + 1):
        produced = core.add_odometry(float(drive.odometry_stream_times[i]), drive.odometry_stream[i])
    assert len(produced) == 1 and produced[0].stamp == drive.times[5]
    np.testing.assert_allclose(produced[0].odom_pose, drive.odometry_in_odom[5], atol=1e-12)
    # A second scan while one waits replaces it (the older one is counted as dropped).
    assert core.add_scan(**scan_fields(drive, 7)) == []  # type: ignore[arg-type]
    assert core.add_scan(**scan_fields(drive, 8)) == []  # type: ignore[arg-type]
    assert core.diagnostics().scans_without_odometry == 1
    # A scan not newer than the last processed one is dropped.
    assert core.add_scan(**scan_fields(drive, 5)) == []  # type: ignore[arg-type]
    assert core.diagnostics().out_of_order == 1


def test_odometry_is_interpolated_between_messages() -> None:
    buffer = OdometryBuffer(span=1.0)
    buffer.add(10.0, (0.0, 0.0, 3.0))
    buffer.add(10.1, (1.0, 2.0, -3.0))
    x, y, yaw = buffer.at(10.025)  # type: ignore[misc]
    assert math.isclose(x, 0.25) and math.isclose(y, 0.5)
    assert math.isclose(yaw, 3.0 + 0.25 * (2 * math.pi - 6.0))  # along the short arc through pi
    assert buffer.at(9.9) is None and buffer.at(10.2) is None
    with pytest.raises(ValueError, match="older than the previous"):
        buffer.add(10.05, (0.0, 0.0, 0.0))
    buffer.add(11.5, (0.0, 0.0, 0.0))
    assert buffer.oldest == 11.5 and len(buffer) == 1  # older than the span: forgotten
    with pytest.raises(ValueError, match="span must be a positive"):
        OdometryBuffer(0.0)


def test_initial_pose_resets_the_pose(plan: PlanMap, drive: Recording) -> None:
    """RViz's pose (6x6 covariance) replaces the estimate, moved by the odometry since its stamp."""
    core = make_core(plan, drive)
    feed(core, drive, 0, 40)
    stamp = float(drive.times[39])
    wrong = compose(tuple(drive.truth[39]), (2.5, 0.0, 0.0))  # 2.5 m ahead of the robot
    rviz_covariance = [0.0] * 36
    rviz_covariance[0], rviz_covariance[7], rviz_covariance[35] = 0.01, 0.01, 0.003
    core.set_initial_pose(stamp, wrong, rviz_covariance)
    out = feed(core, drive, 40, 41)[40]
    motion = between(tuple(drive.odometry_in_odom[39]), tuple(drive.odometry_in_odom[40]))
    expected = compose(wrong, motion)
    assert position_error(out.pose, np.array(expected)) < 0.5  # at most the gate's correction
    assert position_error(out.pose, drive.truth[40]) > 1.5
    # Back to the truth: tracking resumes.
    feed(core, drive, 41, 61)
    core.set_initial_pose(float(drive.times[60]), tuple(drive.truth[60]))
    out = feed(core, drive, 61, len(drive.times))
    assert all(position_error(out[k].pose, drive.truth[k]) < 0.05 for k in range(61, len(drive.times)))


def test_initial_pose_covariance_forms(plan: PlanMap, drive: Recording) -> None:
    core = make_core(plan, drive, initial_std=(0.2, 0.3, 0.1))
    feed(core, drive, 0, 2)
    core.set_initial_pose(float(drive.times[1]), tuple(drive.truth[1]), [0.0] * 36)  # zeros: the default
    feed(core, drive, 2, 3)
    assert core.diagnostics().malformed_initial_poses == 0
    for bad, error in (
        ([1.0] * 35, ValueError),
        (np.full((3, 3), math.nan), ValueError),
        (-np.eye(3), ValueError),
        ("wide", ValueError),
    ):
        with pytest.raises(error):
            core.set_initial_pose(1.0, (0.0, 0.0, 0.0), bad)
    with pytest.raises(ValueError, match="initial pose must be finite"):
        core.set_initial_pose(1.0, (math.nan, 0.0, 0.0))
    with pytest.raises(ValueError, match="initial pose stamp"):
        core.set_initial_pose(-1.0, (0.0, 0.0, 0.0))
    assert core.diagnostics().malformed_initial_poses == 6


MALFORMED = [
    ({"ranges": []}, ValueError, "the scan is empty"),
    ({"ranges": np.ones(500)}, ValueError, "ranges has 500 beams but angle_min"),
    ({"angle_increment": math.nan}, ValueError, "angle_increment must be finite"),
    ({"angle_increment": 0.0}, ValueError, "angle_increment must not be 0"),
    ({"range_min": 40.0}, ValueError, "need 0 <= range_min < range_max"),
    ({"ranges": np.ones((2, 1081))}, ValueError, "one-dimensional"),
    ({"ranges": ["far"] * 1081}, TypeError, "real numbers"),
    ({"stamp": math.inf}, ValueError, "scan stamp must be a finite time"),
    ({"laser_pose": (0.0, math.nan, 0.0)}, ValueError, "laser_pose must be finite"),
    ({"angle_max": math.nan}, ValueError, "angle_max must be finite"),
]


@pytest.mark.parametrize(("change", "error", "message"), MALFORMED)
def test_a_malformed_scan_is_refused_and_changes_nothing(
    plan: PlanMap, drive: Recording, change: dict[str, object], error: type[Exception], message: str
) -> None:
    core = make_core(plan, drive)
    feed(core, drive, 0, 10)
    before = (core.localizer.pose, core.localizer.covariance, core.diagnostics())
    fields = {**scan_fields(drive, 10), **change}
    with pytest.raises(error, match=message):
        core.add_scan(**fields)  # type: ignore[arg-type]
    after = core.diagnostics()
    assert core.localizer.pose == before[0]
    np.testing.assert_array_equal(core.localizer.covariance, before[1])
    assert after.malformed_scans == before[2].malformed_scans + 1 and message.split()[0] in after.last_problem
    assert after.scans_processed == before[2].scans_processed
    # The node goes on: the same scan, well formed, is localized.
    out = feed(core, drive, 10, 11)
    assert out[10].accepted and position_error(out[10].pose, drive.truth[10]) < 0.05


def test_a_scan_without_returns_leaves_a_standing_robot_where_it_is(plan: PlanMap, drive: Recording) -> None:
    """All NaN (REP-117: erroneous) is a valid message with nothing to align: the pose follows odometry."""
    core = make_core(plan, drive)
    feed(core, drive, 0, 10)
    assert drive.odometry_stream is not None and drive.odometry_stream_times is not None
    pose = core.localizer.pose
    t = float(drive.times[9])
    odom = tuple(drive.odometry_in_odom[9])
    for i, ranges in enumerate((np.full(1081, math.nan), np.full(1081, math.inf), np.full(1081, 100.0))):
        core.add_odometry(t + 0.01 * (i + 1), odom)  # standing still
        out = core.add_scan(**{**scan_fields(drive, 9), "stamp": t + 0.01 * (i + 1), "ranges": ranges})  # type: ignore[arg-type]
        assert len(out) == 1 and not out[0].accepted and "usable points" in out[0].estimate.reason
        assert out[0].pose == pose
    assert core.diagnostics().rejected == 3


def test_malformed_odometry_and_a_clock_that_jumps_back(plan: PlanMap, drive: Recording) -> None:
    core = make_core(plan, drive)
    feed(core, drive, 0, 30)
    with pytest.raises(ValueError, match="odometry pose must be finite"):
        core.add_odometry(float(drive.times[29]) + 0.001, (0.0, math.nan, 0.0))
    with pytest.raises(ValueError, match="older than the previous"):
        core.add_odometry(float(drive.times[29]) - 0.05, (0.0, 0.0, 0.0))
    assert core.diagnostics().malformed_odometry == 2
    # A bag played again: time goes back by more than a second; the node starts over.
    core.add_odometry(0.0, (0.0, 0.0, 0.0))
    assert "time went back" in core.diagnostics().last_problem
    assert len(core.add_scan(**{**scan_fields(drive, 0), "stamp": 0.0})) == 1  # type: ignore[arg-type]


def test_a_scan_without_a_laser_transform_is_counted(plan: PlanMap, drive: Recording) -> None:
    core = make_core(plan, drive)
    core.drop_scan_without_laser_pose("laser", "no tf base_link -> laser")
    d = core.diagnostics()
    assert d.scans_without_laser_pose == 1 and d.scans_received == 1 and d.level == 1
    assert "waiting for scans" in d.message


# --- grids -----------------------------------------------------------------------------------------


def test_plan_grid_is_the_plan_raster_bottom_row_first(plan: PlanMap) -> None:
    grid = plan_occupancy_grid(plan)
    raster = plan.raster
    assert raster is not None
    assert (grid.height, grid.width) == raster.shape and grid.resolution == raster.resolution
    assert grid.origin == raster.origin
    np.testing.assert_array_equal(grid.data == 100, raster.walls[::-1])
    assert set(np.unique(grid.data)) == {0, 100}
    points = PlanMap.from_points(plan.points)
    coarse = plan_occupancy_grid(points, 0.1)
    assert coarse.resolution == 0.1 and (coarse.data == 100).sum() > 0
    with pytest.raises(TypeError, match="PlanMap"):
        plan_occupancy_grid("plan.png")  # type: ignore[arg-type]


def test_enhanced_occupancy_grid_on_request(plan: PlanMap, drive: Recording) -> None:
    core = make_core(plan, drive)
    empty = core.eog()
    feed(core, drive, 0, 30)
    grid = core.eog()
    assert empty is not None and grid is not None
    assert (grid.data == 0).sum() > (empty.data == 0).sum() + 1000  # scans cleared free space
    assert make_core(plan, drive, eog_topic="").eog() is None


# --- settings --------------------------------------------------------------------------------------


def test_settings_from_parameters() -> None:
    s = NodeSettings.from_params(
        {
            "plan": "default",
            "initial_pose": [1, 2, 0.5],
            "icp": {"subsample": 2},
            "gate": {"min_inlier_ratio": 0.3},
            "lost": {"min_score": 0.3, "relaxes": False},
            "laser_pose": [0.1, 0.0, 0.0],
        }
    )
    assert s.initial_pose == (1.0, 2.0, 0.5) and s.laser_pose == (0.1, 0.0, 0.0)
    assert s.icp_config().subsample == 2 and s.icp_config().auto_trim  # on top of the tracking defaults
    # ...for the plan the node localizes in: a SLAM map's cells are matched through the index.
    slam = PlanMap.from_ros_map(Path(__file__).parent / "data" / "tb3_sandbox.yaml", cache=False)
    assert s.icp_config(slam) == IcpConfig.for_tracking(slam, subsample=2)
    assert s.icp_config(slam).correspondence_search == "wall_index"
    assert s.icp_config(load_default_plan()).correspondence_search == "kd_tree"
    assert s.acceptance_gate().min_inlier_ratio == 0.3
    assert s.lost_rule() == LostRule(min_score=0.3, relaxes=False)
    assert PlanicpNodeCore(load_default_plan(), s).localizer._detector.rule == s.lost_rule()
    with pytest.raises(ValueError, match=r"unknown planicp_node parameters \['scan_toppic'\]"):
        NodeSettings.from_params({"scan_toppic": "scan"})
    with pytest.raises(ValueError, match="unknown IcpConfig keys"):
        NodeSettings(icp={"max_corr": 1.0})
    with pytest.raises(ValueError, match="unknown gate fields"):
        NodeSettings(gate={"min_inliers_ratio": 1.0})
    with pytest.raises(ValueError, match="unknown lost rule fields"):
        NodeSettings(lost={"min_scores": 0.3})
    with pytest.raises(ValueError, match="lost: min_score"):
        NodeSettings(lost={"min_score": 1.5})
    with pytest.raises(ValueError, match="must differ"):
        NodeSettings(odom_frame="map")
    with pytest.raises(ValueError, match="eog_rate must be >= 0"):
        NodeSettings(eog_rate=-1.0)
    with pytest.raises(ValueError, match="needs a resolution"):
        NodeSettings(plan=str(ros_package_path() / "planicp_ros" / "package.xml")).load_plan()
    with pytest.raises(FileNotFoundError):
        NodeSettings(plan="/nonexistent/map.yaml").load_plan()


def test_the_shipped_ros_package_has_its_launch_and_parameter_files() -> None:
    package = ros_package_path() / "planicp_ros"
    assert (package / "package.xml").is_file()
    for launch in ("planicp.launch", "sim_drive.launch"):
        assert (package / "launch" / launch).is_file()
    import yaml

    params = yaml.safe_load((package / "config" / "planicp.yaml").read_text())
    assert NodeSettings.from_params(params).plan == "default"  # every shipped name is known
    for node in ("planicp_node", "planicp_sim_drive"):
        assert (package / "nodes" / node).stat().st_mode & 0o111, f"{node} must be executable for roslaunch"


@pytest.mark.skipif(importlib.util.find_spec("rospy") is not None, reason="rospy is installed here")
def test_without_rospy_the_node_says_how_to_get_it(capsys: pytest.CaptureFixture[str]) -> None:
    from planicp.ros import rospy_node, sim_drive

    assert rospy_node.main([]) == 2
    assert "apt-get install ros-base python3-rospy" in capsys.readouterr().err
    assert sim_drive.main([]) == 2
    assert "/usr/bin/python3" in capsys.readouterr().err


def test_scan_input_keeps_a_read_only_copy() -> None:
    ranges = np.ones(5)
    scan = ScanInput(1.0, ranges, -0.1, 0.05, 0.1, 10.0, angle_max=0.1)
    ranges[0] = 7.0
    assert scan.ranges[0] == 1.0 and not scan.ranges.flags.writeable
    assert inverse((0.0, 0.0, 0.0)) == (0.0, 0.0, 0.0)


def test_odometry_far_beyond_any_building_is_refused_and_tracking_goes_on(plan: PlanMap, drive: Recording) -> None:
    """One odometry message at x = 3e9 m was buffered: every scan interpolated near it failed in the
    localizer for the buffer's span (1 of 53 scans processed) while the diagnostics said OK. It is
    now refused as malformed, counted, and the next scans are tracked."""
    core = make_core(plan, drive)
    feed(core, drive, 0, 20)
    stamp = float(drive.times[19]) + 0.001
    with pytest.raises(ValueError, match="beyond"):
        core.add_odometry(stamp, (3e9, 0.0, 0.0))
    d = core.diagnostics()
    assert d.malformed_odometry == 1 and "beyond" in d.last_problem
    out = feed(core, drive, 20, 40)
    assert len(out) == 20 and all(position_error(o.pose, drive.truth[k]) < 0.05 for k, o in out.items())


def test_a_scan_the_localizer_refuses_is_counted_and_reported(
    plan: PlanMap, drive: Recording, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A well-formed scan the localizer still refuses (a `PlanicpError` from the core, which
    changes nothing) raises, and is counted as a failed update with a WARN naming it; the
    diagnostics said OK before, and the next scan is tracked."""
    core = make_core(plan, drive)
    feed(core, drive, 0, 10)
    before = core.localizer.pose

    def refuse(*_: object) -> None:
        raise _core.PlanicpError("initial_pose has a coordinate of 3e9 m, beyond +-1e9 m")

    with monkeypatch.context() as m:
        m.setattr(core.localizer, "update", refuse)
        with pytest.raises(ValueError, match="beyond"):
            feed(core, drive, 10, 11)
    d = core.diagnostics()
    assert d.failed_updates == 1 and d.level == 1 and "refused by the localizer" in d.message, d
    assert core.localizer.pose == before
    out = feed(core, drive, 11, 14)
    assert len(out) == 3 and core.diagnostics().level == 0


def test_odometry_whose_stamps_do_not_advance_does_not_grow_the_buffer() -> None:
    buffer = OdometryBuffer(span=5.0)
    for i in range(30_000):
        buffer.add(1.0, (i * 1e-4, 0.0, 0.0))
    assert len(buffer) == 1 and buffer.latest_pose == (29_999 * 1e-4, 0.0, 0.0)  # the newest reading stands
    for i in range(30_000):  # 6 kHz for 5 s: the oldest go beyond MAX_SAMPLES
        buffer.add(2.0 + i / 6000.0, (0.0, 0.0, 0.0))
    assert len(buffer) == odometry_buffer.MAX_SAMPLES
