"""`planicp_sim_drive`: a simulated robot for ROS, publishing what a real one would.

It runs the thesis experiment (`planicp.sim.run_experiment`: a differential-drive robot touring a
furnished plan, drifting 100 Hz wheel odometry, a 270-degree 1081-beam LIDAR at 10 Hz) and then
plays the drive back in real time, stamped from the ROS clock at the start:

  * `odom_topic` (nav_msgs/Odometry, `odom_frame` -> `base_frame`, 100 Hz) and the same transform
    on tf, as a robot base driver does;
  * `scan_topic` (sensor_msgs/LaserScan in `laser_frame`, 10 Hz) and the static tf
    `base_frame` -> `laser_frame` (the LIDAR's mount);
  * `truth_topic` (geometry_msgs/PoseStamped in `map_frame`): the true T_map_base at each scan's
    stamp, to score a localizer against;
  * `initial_pose_topic` (geometry_msgs/PoseWithCovarianceStamped, latched; "" to not send it):
    the true start pose, once, as an operator would give it in RViz.

So `planicp_node` (or AMCL) can be tried without a robot. Private parameters: `plan` ("default": the
office plan shipped with planicp; or a map YAML / plan image with `resolution` and `origin`),
`duration` (seconds of drive, default 60), `seed` (default 0), `start_delay` (seconds to wait for
subscribers before the drive starts, default 1), and the topic and frame names above (defaults
`scan`, `odom`, `sim/ground_truth`, `initialpose`, `map`, `odom`, `base_link`, `laser`). Metres,
radians, seconds.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..sim.experiment import ExperimentConfig, Recording, run_experiment
from .message_layout import (
    covariance_to_6x6,
    fill_odometry,
    fill_transform,
    set_planar_pose,
    set_planar_transform,
)
from .node_settings import NodeSettings
from .ros_imports import import_ros, start_node

NODE_NAME = "planicp_sim_drive"

DEFAULTS: dict[str, Any] = {
    "plan": "default",
    "resolution": None,
    "origin": (0.0, 0.0, 0.0),
    "duration": 60.0,
    "seed": 0,
    "start_delay": 1.0,
    "scan_topic": "scan",
    "odom_topic": "odom",
    "truth_topic": "sim/ground_truth",
    "initial_pose_topic": "initialpose",
    "map_frame": "map",
    "odom_frame": "odom",
    "base_frame": "base_link",
    "laser_frame": "laser",
}


def sim_parameters(params: Mapping[str, Any]) -> dict[str, Any]:
    """`DEFAULTS` updated with `params` (unknown names: ValueError naming them)."""
    unknown = sorted(str(k) for k in params if k not in DEFAULTS)
    if unknown:
        raise ValueError(f"unknown {NODE_NAME} parameters {unknown}; known: {sorted(DEFAULTS)}")
    return {**DEFAULTS, **params}


def record_drive(params: Mapping[str, Any]) -> Recording:
    """The simulated drive that `params` (see `sim_parameters`) describe."""
    p = sim_parameters(params)
    plan = NodeSettings(plan=p["plan"], resolution=p["resolution"], origin=tuple(p["origin"])).load_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=float(p["duration"]), seed=int(p["seed"])))
    return recording


def play(recording: Recording, params: Mapping[str, Any]) -> None:
    """Publishes `recording` in real time (call after `rospy.init_node`); returns when it is done
    or ROS shuts down."""
    ros = import_ros()
    rospy, tf2_ros = ros["rospy"], ros["tf2_ros"]
    g, nav, sensor = ros["geometry_msgs.msg"], ros["nav_msgs.msg"], ros["sensor_msgs.msg"]
    p = sim_parameters(params)
    lidar, times, stream = recording.lidar, recording.odometry_stream_times, recording.odometry_stream
    if lidar is None or recording.ranges is None or times is None or stream is None:
        raise ValueError("the recording has no ranges or odometry stream (record it with run_experiment)")
    scan_at = {int(i): k for k, i in enumerate(np.searchsorted(times, recording.times))}

    odom_pub = rospy.Publisher(p["odom_topic"], nav.Odometry, queue_size=200)
    scan_pub = rospy.Publisher(p["scan_topic"], sensor.LaserScan, queue_size=10)
    truth_pub = rospy.Publisher(p["truth_topic"], g.PoseStamped, queue_size=50)
    tf_pub = tf2_ros.TransformBroadcaster()
    static_pub = tf2_ros.StaticTransformBroadcaster()
    mount = g.TransformStamped()
    mount.header.stamp = rospy.Time.now()
    mount.header.frame_id, mount.child_frame_id = p["base_frame"], p["laser_frame"]
    set_planar_transform(mount.transform, lidar.mount)
    static_pub.sendTransform(mount)
    initial_pub = None
    if p["initial_pose_topic"]:
        initial_pub = rospy.Publisher(p["initial_pose_topic"], g.PoseWithCovarianceStamped, queue_size=1, latch=True)
    time.sleep(float(p["start_delay"]))

    start = rospy.Time.now()
    if initial_pub is not None:
        initial = g.PoseWithCovarianceStamped()
        initial.header.stamp = start
        initial.header.frame_id = p["map_frame"]
        set_planar_pose(initial.pose.pose, tuple(float(v) for v in recording.truth[0]))
        initial.pose.covariance = covariance_to_6x6(np.diag([0.05**2, 0.05**2, 0.02**2]))
        initial_pub.publish(initial)
    wall_start = time.monotonic()
    t_first = float(times[0])
    previous = (float(stream[0, 0]), float(stream[0, 1]), float(stream[0, 2]))
    for i, (t, row) in enumerate(zip(times, stream)):
        if rospy.is_shutdown():
            return
        delay = wall_start + (t - t_first) - time.monotonic()
        if delay > 0.0:
            time.sleep(delay)
        stamp = start + rospy.Duration.from_sec(float(t) - t_first)
        pose = (float(row[0]), float(row[1]), float(row[2]))
        dt = float(t - times[i - 1]) if i > 0 else 0.0
        odom = nav.Odometry()
        fill_odometry(odom, stamp, (p["odom_frame"], p["base_frame"]), pose, previous, dt)
        previous = pose
        odom_pub.publish(odom)
        tf = g.TransformStamped()
        fill_transform(tf, stamp, (p["odom_frame"], p["base_frame"]), pose)
        tf_pub.sendTransform(tf)
        k = scan_at.get(i)
        if k is None:
            continue
        scan = sensor.LaserScan()
        scan.header.stamp = stamp
        scan.header.frame_id = p["laser_frame"]
        scan.angle_min = lidar.angle_min
        scan.angle_increment = lidar.angle_increment
        scan.angle_max = lidar.angle_min + lidar.angle_increment * (lidar.beams - 1)
        scan.scan_time = 1.0 / lidar.rate_hz
        scan.time_increment = 0.0  # the simulated scan is instantaneous
        scan.range_min, scan.range_max = lidar.range_min, lidar.range_max
        scan.ranges = recording.ranges[k].tolist()
        scan_pub.publish(scan)
        truth = g.PoseStamped()
        truth.header.stamp = stamp
        truth.header.frame_id = p["map_frame"]
        set_planar_pose(truth.pose, tuple(float(v) for v in recording.truth[k]))
        truth_pub.publish(truth)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs `planicp_sim_drive`: records the drive, then plays it. Returns the exit code."""
    started = start_node(NODE_NAME, argv)
    if started is None:
        return 2
    ros, rospy = started
    params = rospy.get_param("~", {})
    try:
        began = time.monotonic()
        recording = record_drive(params)
    except (TypeError, ValueError, FileNotFoundError) as exc:
        rospy.logfatal(f"{NODE_NAME}: {exc}")
        return 2
    rospy.loginfo(
        f"{NODE_NAME}: simulated {recording.times[-1]:.1f} s of drive ({len(recording.times)} scans) "
        f"in {time.monotonic() - began:.1f} s; playing it"
    )
    play(recording, params)
    if not rospy.is_shutdown():
        rospy.loginfo(f"{NODE_NAME}: drive finished")
    return 0


if __name__ == "__main__":
    sys.exit(main())
