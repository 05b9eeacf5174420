"""The ROS 2 node's framework-free parts (issue 21), without ROS 2: its parameters read into `NodeSettings`,
the `TransformTree` it reads tf into, the plan from an occupancy grid, what the core gained for it
(waiting for a pose, global localization, nav2_amcl's laser range overrides), and the shipped launch
description and parameter file. The live test against rclpy is `test_ros2_live.py`.
"""

from __future__ import annotations

import math
import runpy
import sys
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from planicp.plans.default_plan import load_default_plan
from planicp.plans.plan_map import PlanMap
from planicp.plans.ros_map import read_ros_map
from planicp.ros import NodeSettings, PlanicpNodeCore, plan_occupancy_grid, ros2_launch_path
from planicp.ros.plan_grid import plan_from_occupancy_grid
from planicp.ros.ros2_parameters import NAV2_DEFAULTS, settings_from_ros2
from planicp.ros.transform_tree import TransformTree, planar
from planicp.se2 import compose, yaw_to_quaternion
from planicp.sim.experiment import ExperimentConfig, Recording, run_experiment

SHARE = ros2_launch_path()


@pytest.fixture(scope="module")
def plan() -> PlanMap:
    return load_default_plan()


@pytest.fixture(scope="module")
def drive(plan: PlanMap) -> Recording:
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=6.0, seed=11))
    return recording


def feed(
    core: PlanicpNodeCore, drive: Recording, until_s: float, from_s: float = 0.0, **scan: Any
) -> list[tuple[int, Any]]:
    """Odometry and scans of `drive` from `from_s` (exclusive, but for 0) to `until_s` seconds into it;
    (scan index, output) of each pose."""
    times, stream, lidar = drive.odometry_stream_times, drive.odometry_stream, drive.lidar
    assert times is not None and stream is not None and lidar is not None and drive.ranges is not None
    scan_at = {int(i): k for k, i in enumerate(np.searchsorted(times, drive.times))}
    outputs = []
    for i, (t, row) in enumerate(zip(times, stream)):
        if t - times[0] > until_s:
            break
        if from_s > 0.0 and t - times[0] <= from_s:
            continue
        core.add_odometry(float(t), tuple(row))
        k = scan_at.get(i)
        if k is None:
            continue
        fields = {
            "angle_min": lidar.angle_min,
            "angle_increment": lidar.angle_increment,
            "range_min": lidar.range_min,
            "range_max": lidar.range_max,
            "laser_pose": lidar.mount,
            **scan,
        }
        outputs += [(k, out) for out in core.add_scan(float(t), drive.ranges[k], **fields)]
    return outputs


# --- parameters --------------------------------------------------------------------------------------


def test_nav2_names_and_defaults_become_node_settings() -> None:
    settings, ignored = settings_from_ros2({})
    assert (settings.map_frame, settings.odom_frame, settings.base_frame) == ("map", "odom", "base_footprint")
    assert settings.transform_tolerance == 1.0 and settings.publish_tf is True
    assert settings.map_topic == "map" and settings.plan_topic == "" and settings.pose_topic == "amcl_pose"
    assert settings.wait_for_initial_pose is True  # set_initial_pose false: wait, as nav2_amcl does
    assert settings.laser_max_range == 100.0 and settings.laser_min_range == -1.0
    assert ignored == []

    settings, ignored = settings_from_ros2(
        {
            "global_frame_id": "world",
            "odom_frame_id": "wheel_odom",
            "base_frame_id": "base_link",
            "scan_topic": "front/scan",
            "tf_broadcast": False,
            "transform_tolerance": 0.25,
            "set_initial_pose": True,
            "initial_pose.x": 1.5,
            "initial_pose.y": -2.0,
            "initial_pose.z": 9.0,
            "initial_pose.yaw": 0.5,
            "plan": "default",
            "resolution": 0.0,
            "icp.max_iterations": 12,
            "gate.min_inliers": 40,
            "lost.window": 7,
            "alpha1": 0.2,
            "max_particles": 2000,
            "use_sim_time": False,
        }
    )
    assert (settings.map_frame, settings.odom_frame, settings.base_frame) == ("world", "wheel_odom", "base_link")
    assert settings.scan_topic == "front/scan" and settings.publish_tf is False and settings.transform_tolerance == 0.25
    assert settings.initial_pose == (1.5, -2.0, 0.5) and settings.wait_for_initial_pose is False
    assert settings.plan == "default" and settings.map_topic == "" and settings.resolution is None
    assert settings.icp_config().max_iterations == 12 and settings.acceptance_gate().min_inliers == 40
    assert settings.lost_rule().window == 7
    assert ignored == ["alpha1", "max_particles"]


NAV2_AMCL_SECTION = """
amcl:
  ros__parameters:
    use_sim_time: True
    alpha1: 0.2
    alpha2: 0.2
    alpha3: 0.2
    alpha4: 0.2
    alpha5: 0.2
    base_frame_id: "base_footprint"
    beam_skip_distance: 0.5
    beam_skip_error_threshold: 0.9
    beam_skip_threshold: 0.3
    do_beamskip: false
    global_frame_id: "map"
    lambda_short: 0.1
    laser_likelihood_max_dist: 2.0
    laser_max_range: 100.0
    laser_min_range: -1.0
    laser_model_type: "likelihood_field"
    max_beams: 60
    max_particles: 2000
    min_particles: 500
    odom_frame_id: "odom"
    pf_err: 0.05
    pf_z: 0.99
    recovery_alpha_fast: 0.0
    recovery_alpha_slow: 0.0
    resample_interval: 1
    robot_model_type: "nav2_amcl::DifferentialMotionModel"
    save_pose_rate: 0.5
    sigma_hit: 0.2
    tf_broadcast: true
    transform_tolerance: 1.0
    update_min_a: 0.2
    update_min_d: 0.25
    z_hit: 0.5
    z_max: 0.05
    z_rand: 0.5
    z_short: 0.05
    scan_topic: scan
"""
"""The amcl: section of Nav2's (Jazzy) nav2_params.yaml."""


def test_a_nav2_parameter_files_amcl_section_works_unchanged() -> None:
    params = yaml.safe_load(NAV2_AMCL_SECTION)["amcl"]["ros__parameters"]
    settings, ignored = settings_from_ros2(params)
    assert settings == settings_from_ros2({})[0]  # its values are nav2_amcl's defaults, and so planicp's
    assert "alpha1" in ignored and "robot_model_type" in ignored and len(ignored) == 29


@pytest.mark.parametrize(
    ("params", "says"),
    [
        ({"plan_file": "x.yaml"}, "unknown parameters ['plan_file']"),
        ({"map_topic": ""}, "no plan: set plan"),
        ({"icp.no_such_field": 1}, "no_such_field"),
        ({"transform_tolerance": -1.0}, "transform_tolerance"),
        ({"plan_topic": "map"}, "map_topic and plan_topic are both 'map'"),
        ({"laser_min_range": 5.0, "laser_max_range": 2.0}, "laser_max_range (2.0 m) must exceed laser_min_range"),
        ({"set_initial_pose": "yes"}, "set_initial_pose must be true or false"),
        ({"base_frame_id": "odom"}, "must differ"),
    ],
)
def test_bad_parameters_are_refused_by_name(params: dict[str, Any], says: str) -> None:
    with pytest.raises(ValueError, match=None) as raised:
        settings_from_ros2(params)
    assert says in str(raised.value)


def test_the_shipped_parameter_file_and_launch_description() -> None:
    document = yaml.safe_load((SHARE / "planicp.yaml").read_text())
    params = document["/**"]["ros__parameters"]
    assert {k: params[k] for k in NAV2_DEFAULTS} == NAV2_DEFAULTS
    settings, ignored = settings_from_ros2(params)
    assert settings == settings_from_ros2({})[0] and ignored == []

    # The launch description, with launch and launch_ros (not wheels) stood in for by recorders.
    made: list[tuple[str, tuple[Any, ...], dict[str, Any]]] = []

    def recorder(name: str) -> type:
        def init(self: Any, *args: Any, **kwargs: Any) -> None:
            made.append((name, args, kwargs))

        return type(name, (), {"__init__": init})

    stubs = {
        "launch": {"LaunchDescription": recorder("LaunchDescription")},
        "launch.actions": {"DeclareLaunchArgument": recorder("DeclareLaunchArgument")},
        "launch.substitutions": {"LaunchConfiguration": recorder("LaunchConfiguration")},
        "launch_ros.actions": {"Node": recorder("Node")},
        "launch_ros.parameter_descriptions": {"ParameterValue": recorder("ParameterValue")},
    }
    saved = {name: sys.modules.get(name) for name in [*stubs, "launch_ros"]}
    try:
        sys.modules["launch_ros"] = types.ModuleType("launch_ros")
        for name, attributes in stubs.items():
            module = types.ModuleType(name)
            module.__dict__.update(attributes)
            sys.modules[name] = module
        runpy.run_path(str(SHARE / "planicp.launch.py"))["generate_launch_description"]()
    finally:
        for name, module in saved.items():
            if module is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = module
    arguments = {args[0]: kwargs["default_value"] for name, args, kwargs in made if name == "DeclareLaunchArgument"}
    assert arguments["node_name"] == "amcl" and arguments["autostart"] == "false"
    assert Path(arguments["params_file"]) == (SHARE / "planicp.yaml").resolve()
    (node,) = [kwargs for name, _, kwargs in made if name == "Node"]
    assert node["executable"] == "planicp-ros2-node" and "package" not in node
    assert node["remappings"] == [("/tf", "tf"), ("/tf_static", "tf_static")]


# --- tf ----------------------------------------------------------------------------------------------


def test_transform_tree_composes_chains_as_se2_does() -> None:
    tree = TransformTree()
    tree.set("base_footprint", "base_link", (0.1, 0.0, 0.2), yaw_to_quaternion(0.3))
    tree.set("/base_link", "laser_mount", (0.2, 0.1, 0.1), yaw_to_quaternion(-0.5))
    tree.set("laser_mount", "laser", (0.05, -0.02, 0.0), yaw_to_quaternion(1.0))
    expected = compose(compose((0.1, 0.0, 0.3), (0.2, 0.1, -0.5)), (0.05, -0.02, 1.0))
    found = tree.lookup("base_footprint", "laser")
    assert found is not None
    assert np.allclose(planar(found), expected, atol=1e-12)
    assert found[0][2] == pytest.approx(0.3)  # heights add up along the chain
    assert tree.lookup("base_footprint", "base_footprint") == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    assert tree.lookup("laser", "base_footprint") is None  # only upwards
    assert tree.lookup("odom", "laser") is None  # no such ancestor
    # A newer transform of a frame replaces the old; a loop of parents ends in None, not a hang.
    tree.set("base_link", "laser_mount", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    tree.set("laser", "base_footprint", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    assert tree.lookup("map", "laser") is None


def test_transform_tree_refuses_malformed_transforms() -> None:
    tree = TransformTree()
    with pytest.raises(ValueError, match="zero"):
        tree.set("a", "b", (0, 0, 0), (0, 0, 0, 0))
    with pytest.raises(ValueError, match="finite"):
        tree.set("a", "b", (math.nan, 0, 0), (0, 0, 0, 1))
    with pytest.raises(ValueError, match="two different frames"):
        tree.set("a", "/a", (0, 0, 0), (0, 0, 0, 1))
    assert len(tree) == 0


# --- the plan from a map topic -------------------------------------------------------------------------


def test_plan_from_an_occupancy_grid_lies_on_the_plan(plan: PlanMap) -> None:
    grid = plan_occupancy_grid(plan)
    from_grid = plan_from_occupancy_grid(
        grid.data.ravel().tolist(), grid.width, grid.height, grid.resolution, grid.origin
    )
    a, b = np.asarray(plan.points), np.asarray(from_grid.points)
    nearest = np.array([np.sqrt(((a - p) ** 2).sum(axis=1)).min() for p in b[:: max(1, len(b) // 400)]])
    assert nearest.max() < 0.5 * grid.resolution + 1e-9  # the thick walls' faces, not their cells' centres
    assert from_grid.edge_detector == "auto" and not from_grid.cells_mark_returns  # a drawing
    # nav2's depot map, SLAM output, on the map topic: read as its YAML-less file is, a SLAM map's cells.
    depot = read_ros_map(Path(__file__).parent / "data" / "depot.yaml")
    rows, cols = depot.occupancy.shape
    slam = plan_from_occupancy_grid(depot.occupancy[::-1].ravel().tolist(), cols, rows, depot.resolution, depot.origin)
    assert slam.cells_mark_returns
    np.testing.assert_array_equal(
        slam.points, PlanMap.from_ros_map(Path(__file__).parent / "data" / "depot.yaml", cache=False).points
    )
    with pytest.raises(ValueError, match="holds 3 values"):
        plan_from_occupancy_grid([0, 100, 0], 2, 2, 0.05, (0, 0, 0))
    with pytest.raises(ValueError, match="no cell >= 65"):
        plan_from_occupancy_grid([0, -1, 50, 0], 2, 2, 0.05, (0, 0, 0))


# --- what the core gained ------------------------------------------------------------------------------


def test_waiting_core_drops_scans_until_global_localization_finds_the_robot(plan: PlanMap, drive: Recording) -> None:
    core = PlanicpNodeCore(plan, NodeSettings(wait_for_initial_pose=True, eog_topic=""))
    assert feed(core, drive, 1.0) == []
    d = core.diagnostics()
    assert d.scans_before_initial_pose >= 9 and d.scans_processed == 0 and "waiting for an initial pose" in d.message
    core.request_global_localization()
    outputs = feed(core, drive, 6.0, 1.0)
    assert len(outputs) > 40
    errors = [math.dist(out.pose[:2], drive.truth[k][:2]) for k, out in outputs]
    assert max(errors) < 0.05, errors[:5]


def test_an_initial_pose_ends_the_wait(plan: PlanMap, drive: Recording) -> None:
    core = PlanicpNodeCore(plan, NodeSettings(wait_for_initial_pose=True, eog_topic=""))
    feed(core, drive, 0.5)
    core.set_initial_pose(0.0, tuple(drive.truth[0]), None)
    outputs = feed(core, drive, 3.0, 0.5)
    assert outputs and max(math.dist(out.pose[:2], drive.truth[k][:2]) for k, out in outputs) < 0.05


def test_laser_range_overrides_replace_the_scans_own(plan: PlanMap, drive: Recording) -> None:
    # nav2_amcl's laser_max_range replaces each scan's range_max: at 0.3 m nothing is left to align,
    # so the pose follows odometry and every scan is rejected for too few points.
    start = tuple(float(v) for v in drive.truth[0])
    core = PlanicpNodeCore(plan, NodeSettings(initial_pose=start, laser_max_range=0.3, eog_topic=""))  # type: ignore[arg-type]
    outputs = feed(core, drive, 2.0)
    assert outputs and not any(out.accepted for _, out in outputs)
    core = PlanicpNodeCore(plan, NodeSettings(initial_pose=start, laser_max_range=25.0, eog_topic=""))  # type: ignore[arg-type]
    outputs = feed(core, drive, 2.0)
    assert all(out.accepted for _, out in outputs[1:])
    # laser_min_range above every range: the same.
    core = PlanicpNodeCore(plan, NodeSettings(initial_pose=start, laser_min_range=29.0, eog_topic=""))  # type: ignore[arg-type]
    assert not any(out.accepted for _, out in feed(core, drive, 1.0))
