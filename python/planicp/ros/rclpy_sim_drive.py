"""`planicp-ros2-sim-drive`: a simulated robot for ROS 2, publishing what a real one would.

The ROS 2 twin of `sim_drive` (same drive: `sim_drive.record_drive`, the thesis experiment with drifting
100 Hz wheel odometry and a 270-degree 1081-beam LIDAR at 10 Hz), played back in real time, stamped
from the ROS clock at the start:

  * `odom_topic` (nav_msgs/Odometry, `odom_frame` -> `base_frame`, 100 Hz) and the same transform on
    `/tf`, as a robot base driver does;
  * `scan_topic` (sensor_msgs/LaserScan in `laser_frame`, 10 Hz, sensor-data QoS) and the static
    transform `base_frame` -> `laser_frame` on `/tf_static` (the LIDAR's mount);
  * `truth_topic` (geometry_msgs/PoseStamped in `map_frame`): the true T_map_base at each scan's
    stamp, to score a localizer against;
  * `initial_pose_topic` (geometry_msgs/PoseWithCovarianceStamped; "" to not send it): the true start
    pose, once, as an operator would give it in RViz.

Parameters (`--ros-args -p name:=value`): those of `sim_drive.DEFAULTS` (`plan`, `duration`, `seed`,
`start_delay`, the topics and frames; `resolution` 0 for none). Metres, radians, seconds.
"""

from __future__ import annotations

import array
import sys
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..sim.experiment import Recording
from .message_layout import (
    covariance_to_6x6,
    fill_odometry,
    fill_transform,
    set_planar_pose,
    set_planar_transform,
)
from .ros2_imports import import_ros2, tf_message_class
from .ros2_interfaces import InterfaceBuildError
from .sim_drive import DEFAULTS, record_drive, sim_parameters

_ros = import_ros2(
    (
        "rclpy",
        "rclpy.node",
        "rclpy.qos",
        "builtin_interfaces.msg",
        "geometry_msgs.msg",
        "nav_msgs.msg",
        "rcl_interfaces.msg",
        "sensor_msgs.msg",
    )
)
rclpy: Any = _ros["rclpy"]
_qos: Any = _ros["rclpy.qos"]
_geometry: Any = _ros["geometry_msgs.msg"]
Time: Any = _ros["builtin_interfaces.msg"].Time
Odometry: Any = _ros["nav_msgs.msg"].Odometry
LaserScan: Any = _ros["sensor_msgs.msg"].LaserScan
ParameterDescriptor: Any = _ros["rcl_interfaces.msg"].ParameterDescriptor

NODE_NAME = "planicp_sim_drive"


def _stamp(ns: int) -> Any:
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def read_parameters(node: Any) -> dict[str, Any]:
    """The player's parameters from `node` (declared with `sim_drive.DEFAULTS`; `resolution` 0: none)."""
    values: dict[str, Any] = {}
    for name, default in DEFAULTS.items():
        if not node.has_parameter(name):
            node.declare_parameter(name, 0.0 if default is None else default, ParameterDescriptor(dynamic_typing=True))
        values[name] = node.get_parameter(name).value
    if values["resolution"] == 0:
        values["resolution"] = None
    return sim_parameters(values)


def play(node: Any, recording: Recording, params: Mapping[str, Any]) -> None:
    """Publishes `recording` in real time from `node`; returns when it is done or ROS shuts down."""
    TFMessage = tf_message_class()
    p = sim_parameters(params)
    lidar, times, stream = recording.lidar, recording.odometry_stream_times, recording.odometry_stream
    if lidar is None or recording.ranges is None or times is None or stream is None:
        raise ValueError("the recording has no ranges or odometry stream (record it with run_experiment)")
    scan_at = {int(i): k for k, i in enumerate(np.searchsorted(times, recording.times))}
    reliable = _qos.QoSProfile(depth=100, reliability=_qos.ReliabilityPolicy.RELIABLE)
    static_qos = _qos.QoSProfile(
        depth=100, durability=_qos.DurabilityPolicy.TRANSIENT_LOCAL, reliability=_qos.ReliabilityPolicy.RELIABLE
    )
    odom_pub = node.create_publisher(Odometry, p["odom_topic"], reliable)
    scan_pub = node.create_publisher(LaserScan, p["scan_topic"], _qos.qos_profile_sensor_data)
    truth_pub = node.create_publisher(_geometry.PoseStamped, p["truth_topic"], reliable)
    tf_pub = node.create_publisher(TFMessage, "/tf", reliable)
    static_pub = node.create_publisher(TFMessage, "/tf_static", static_qos)
    clock = node.get_clock()
    mount = _geometry.TransformStamped()
    mount.header.stamp = clock.now().to_msg()
    mount.header.frame_id, mount.child_frame_id = p["base_frame"], p["laser_frame"]
    set_planar_transform(mount.transform, lidar.mount)
    static_pub.publish(TFMessage(transforms=[mount]))
    initial_pub = None
    if p["initial_pose_topic"]:
        initial_pub = node.create_publisher(
            _geometry.PoseWithCovarianceStamped, p["initial_pose_topic"], _qos.QoSProfile(depth=1)
        )
    time.sleep(float(p["start_delay"]))

    start_ns = clock.now().nanoseconds
    if initial_pub is not None:
        initial = _geometry.PoseWithCovarianceStamped()
        initial.header.stamp = _stamp(start_ns)
        initial.header.frame_id = p["map_frame"]
        set_planar_pose(initial.pose.pose, tuple(float(v) for v in recording.truth[0]))
        initial.pose.covariance = covariance_to_6x6(np.diag([0.05**2, 0.05**2, 0.02**2]))
        initial_pub.publish(initial)
    wall_start = time.monotonic()
    t_first = float(times[0])
    previous = (float(stream[0, 0]), float(stream[0, 1]), float(stream[0, 2]))
    for i, (t, row) in enumerate(zip(times, stream)):
        if not rclpy.ok():
            return
        delay = wall_start + (t - t_first) - time.monotonic()
        if delay > 0.0:
            time.sleep(delay)
        stamp = _stamp(start_ns + round((float(t) - t_first) * 1e9))
        pose = (float(row[0]), float(row[1]), float(row[2]))
        dt = float(t - times[i - 1]) if i > 0 else 0.0
        odom = Odometry()
        fill_odometry(odom, stamp, (p["odom_frame"], p["base_frame"]), pose, previous, dt)
        previous = pose
        odom_pub.publish(odom)
        tf = _geometry.TransformStamped()
        fill_transform(tf, stamp, (p["odom_frame"], p["base_frame"]), pose)
        tf_pub.publish(TFMessage(transforms=[tf]))
        k = scan_at.get(i)
        if k is None:
            continue
        scan = LaserScan()
        scan.header.stamp = stamp
        scan.header.frame_id = p["laser_frame"]
        scan.angle_min = float(lidar.angle_min)
        scan.angle_increment = float(lidar.angle_increment)
        scan.angle_max = float(lidar.angle_min + lidar.angle_increment * (lidar.beams - 1))
        scan.scan_time = 1.0 / lidar.rate_hz
        scan.time_increment = 0.0  # the simulated scan is instantaneous
        scan.range_min, scan.range_max = float(lidar.range_min), float(lidar.range_max)
        scan.ranges = array.array("f", recording.ranges[k].astype(np.float32).tobytes())
        scan_pub.publish(scan)
        truth = _geometry.PoseStamped()
        truth.header.stamp = stamp
        truth.header.frame_id = p["map_frame"]
        set_planar_pose(truth.pose, tuple(float(v) for v in recording.truth[k]))
        truth_pub.publish(truth)


def main(argv: Sequence[str] | None = None) -> int:
    """Records the drive, then plays it. Returns the exit code (2: bad parameters or interfaces)."""
    rclpy.init(args=list(argv) if argv is not None else sys.argv)
    node = _ros["rclpy.node"].Node(NODE_NAME)
    try:
        params = read_parameters(node)
        began = time.monotonic()
        recording = record_drive(params)
        node.get_logger().info(
            f"simulated {recording.times[-1]:.1f} s of drive ({len(recording.times)} scans) in "
            f"{time.monotonic() - began:.1f} s; playing it"
        )
        play(node, recording, params)
        node.get_logger().info("drive finished")
    except (TypeError, ValueError, FileNotFoundError, InterfaceBuildError) as exc:
        node.get_logger().fatal(str(exc))
        return 2
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
