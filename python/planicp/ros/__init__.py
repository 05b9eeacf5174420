"""planicp as a ROS localization node, in place of AMCL: same inputs, same outputs, same frames.

The node's logic is framework-free and importable without ROS:

* `PlanicpNodeCore` (`node_logic`): scans, odometry and initial poses in; `PoseOutput` (pose with
  covariance, the map -> odom correction), the enhanced occupancy grid and `NodeDiagnostics` out;
* `NodeSettings` (`node_settings`): the node's parameters, validated;
* `ScanInput` (`node_io`), `OdometryBuffer` (`odometry_buffer`), the message layouts of covariances
  and quaternions (`message_layout`) and the plan as an occupancy grid (`plan_grid`).

`planicp.ros.rospy_node` is the ROS 1 node (`python -m planicp.ros.rospy_node`, or `roslaunch` with
the launch files of `ros_package_path()`); `planicp.ros.sim_drive` publishes a simulated drive as a
robot would. Both need rospy (on Debian: `apt-get install ros-base python3-rospy
python3-sensor-msgs python3-nav-msgs python3-geometry-msgs python3-tf2-ros python3-diagnostic-msgs`,
and planicp installed for Debian's `/usr/bin/python3`).

`planicp.ros.rclpy_node` is the ROS 2 (Jazzy) lifecycle node in place of nav2_amcl
(`planicp-ros2-node`, or the launch description in `ros2_launch_path()`), with its parameters read by
`ros2_parameters` and tf by `transform_tree`; `planicp.ros.rclpy_sim_drive` plays the simulated drive
on ROS 2. Both need `pip install 'planicp[ros2]'` (PyPI's ROS 2 wheels; `ros2_interfaces` builds
tf2_msgs, which is not a wheel, on first use).

`planicp.ros.estimate_bag` writes a replay's estimates as a ROS 2 bag (`planicp replay --out-bag`),
without ROS: `pip install 'planicp[ros]'` (rosbags).

Frames and units follow REP-103/105: metres, radians, seconds; poses are (x, y, yaw).
"""

from __future__ import annotations

from pathlib import Path

from ..se2 import quaternion_to_yaw, yaw_to_quaternion
from .message_layout import covariance_from_6x6, covariance_to_6x6
from .node_diagnostics import NodeDiagnostics
from .node_io import PoseOutput, ScanInput
from .node_logic import PlanicpNodeCore
from .node_settings import NodeSettings
from .odometry_buffer import OdometryBuffer
from .plan_grid import plan_occupancy_grid


def ros2_launch_path() -> Path:
    """The folder of the ROS 2 launch description (`planicp.launch.py`) and parameter file
    (`planicp.yaml`) shipped with planicp, for a Nav2 launch file to include."""
    return Path(__file__).resolve().parent / "share" / "planicp_ros2"


def ros_package_path() -> Path:
    """The folder of the ROS package `planicp_ros` shipped with planicp (its launch and parameter
    files, and the node executables roslaunch starts): add it to `ROS_PACKAGE_PATH`."""
    return Path(__file__).resolve().parent / "share"


__all__ = [
    "NodeDiagnostics",
    "NodeSettings",
    "OdometryBuffer",
    "PlanicpNodeCore",
    "PoseOutput",
    "ScanInput",
    "covariance_from_6x6",
    "covariance_to_6x6",
    "plan_occupancy_grid",
    "quaternion_to_yaw",
    "ros2_launch_path",
    "ros_package_path",
    "yaw_to_quaternion",
]
