"""`planicp_node`: the ROS 1 (rospy) node that localizes the robot in the plan, in place of AMCL.

A thin wrapper: messages become calls of `PlanicpNodeCore` and its results become messages.

Subscribes (names from the parameters, relative to the node's namespace, so remappable):
  * `scan_topic` (sensor_msgs/LaserScan), in the laser's frame; base -> laser comes from tf (or
    the `laser_pose` parameter);
  * `odom_topic` (nav_msgs/Odometry), T_odom_base, interpolated to each scan's stamp;
  * `initial_pose_topic` (geometry_msgs/PoseWithCovarianceStamped in `map_frame`, as RViz's
    "2D Pose Estimate" sends it).

Publishes:
  * `pose_topic` (geometry_msgs/PoseWithCovarianceStamped): T_map_base at each scan's stamp, its
    (x, y, yaw) covariance at indices 0, 1, 5, 6, 7, 11, 30, 31, 35 of the 6x6;
  * tf `map_frame -> odom_frame` (REP-105: T_map_odom = T_map_base * inv(T_odom_base)), stamped
    with the scan's stamp plus `transform_tolerance`, as AMCL does;
  * `plan_topic` (nav_msgs/OccupancyGrid, latched): the plan's walls;
  * `eog_topic` (nav_msgs/OccupancyGrid, latched) every 1 / `eog_rate` seconds: the enhanced
    occupancy grid;
  * /diagnostics (diagnostic_msgs/DiagnosticArray) every 1 / `diagnostics_rate` seconds: estimate
    quality (inlier ratio, accepted / rejected, malformed messages, lost).

Run: `python -m planicp.ros.rospy_node _plan:=/path/map.yaml scan:=/base_scan`, or roslaunch the
launch file of the shipped ROS package (`planicp.ros.ros_package_path()`).
"""

from __future__ import annotations

import math
import sys
import threading
import traceback
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

from .._validation import Pose
from ..mapping.occupancy_grid_message import OccupancyGridMessage
from ..se2 import quaternion_to_yaw, yaw_to_quaternion
from .message_layout import planar_mount
from .node_diagnostics import NodeDiagnostics
from .node_io import PoseOutput
from .node_logic import PlanicpNodeCore
from .node_settings import NodeSettings
from .ros_imports import import_ros, start_node

NODE_NAME = "planicp_node"
LASER_LOOKUP_TIMEOUT = 0.5
"""Seconds the node waits for tf to know base -> laser for a new laser frame."""


class PlanicpRosNode:
    """The ROS side of `planicp_node`: subscriptions, publications, tf; call after `rospy.init_node`."""

    def __init__(self, settings: NodeSettings, core: PlanicpNodeCore | None = None) -> None:
        ros = import_ros()
        self.rospy: Any = ros["rospy"]
        self.tf2_ros: Any = ros["tf2_ros"]
        self.sensor_msgs: Any = ros["sensor_msgs.msg"]
        self.nav_msgs: Any = ros["nav_msgs.msg"]
        self.geometry_msgs: Any = ros["geometry_msgs.msg"]
        self.diagnostic_msgs: Any = ros["diagnostic_msgs.msg"]
        rospy = self.rospy
        self.settings = settings
        self.core = core if core is not None else PlanicpNodeCore.from_settings(settings)
        # Stamps as the messages carried them, for the outputs (float seconds lose nanoseconds).
        self._stamps: OrderedDict[float, Any] = OrderedDict()
        self._laser_mounts: dict[str, tuple[Pose, bool]] = {}
        self._warned: set[str] = set()
        self._publish_lock = threading.Lock()

        self.tf_buffer: Any = None
        if settings.laser_pose is None:
            self.tf_buffer = self.tf2_ros.Buffer()
            self._tf_listener = self.tf2_ros.TransformListener(self.tf_buffer)
        self.tf_broadcaster = self.tf2_ros.TransformBroadcaster() if settings.publish_tf else None

        g, nav = self.geometry_msgs, self.nav_msgs
        self.pose_pub = rospy.Publisher(settings.pose_topic, g.PoseWithCovarianceStamped, queue_size=10)
        self.diagnostics_pub = rospy.Publisher("/diagnostics", self.diagnostic_msgs.DiagnosticArray, queue_size=10)
        self.plan_pub = None
        if settings.plan_topic:
            self.plan_pub = rospy.Publisher(settings.plan_topic, nav.OccupancyGrid, queue_size=1, latch=True)
            self.plan_pub.publish(self._grid_message(self.core.plan_grid(), rospy.Time.now()))
        self.eog_pub = None
        if settings.eog_topic and settings.eog_rate > 0.0:
            self.eog_pub = rospy.Publisher(settings.eog_topic, nav.OccupancyGrid, queue_size=1, latch=True)
            self._eog_timer = rospy.Timer(rospy.Duration(1.0 / settings.eog_rate), self._publish_eog)
        if settings.diagnostics_rate > 0.0:
            self._diagnostics_timer = rospy.Timer(
                rospy.Duration(1.0 / settings.diagnostics_rate), self._publish_diagnostics
            )

        self._odom_sub = rospy.Subscriber(settings.odom_topic, nav.Odometry, self._on_odometry, queue_size=200)
        self._scan_sub = rospy.Subscriber(
            settings.scan_topic, self.sensor_msgs.LaserScan, self._on_scan, queue_size=5, buff_size=1 << 20
        )
        self._initial_sub = rospy.Subscriber(
            settings.initial_pose_topic, g.PoseWithCovarianceStamped, self._on_initial_pose, queue_size=2
        )
        rospy.loginfo(
            f"{NODE_NAME}: plan {settings.plan} ({len(self.core.plan)} wall points), scans from "
            f"{self._scan_sub.resolved_name}, odometry from {self._odom_sub.resolved_name}, "
            f"publishing {self.pose_pub.resolved_name}"
            + (f" and tf {settings.map_frame} -> {settings.odom_frame}" if settings.publish_tf else "")
        )

    # --- callbacks -------------------------------------------------------------------------------

    def _on_scan(self, msg: Any) -> None:
        try:
            frame = msg.header.frame_id.lstrip("/")
            mount = self._laser_mount(frame)
            if mount is None:
                return
            stamp = msg.header.stamp.to_sec()
            self._remember(stamp, msg.header.stamp)
            outputs = self.core.add_scan_message(stamp, msg, mount)
        except (TypeError, ValueError) as exc:
            self.rospy.logwarn_throttle_identical(5.0, f"{NODE_NAME}: {exc}")
            return
        except Exception:  # never let one message kill the node
            self.rospy.logerr(f"{NODE_NAME}: scan callback failed:\n{traceback.format_exc()}")
            return
        self._publish(outputs)

    def _on_odometry(self, msg: Any) -> None:
        try:
            s = self.settings
            self._check_frames("odometry", msg.header.frame_id, s.odom_frame, msg.child_frame_id, s.base_frame)
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            pose = (p.x, p.y, quaternion_to_yaw(q.x, q.y, q.z, q.w))
            outputs = self.core.add_odometry(msg.header.stamp.to_sec(), pose)
        except (TypeError, ValueError) as exc:
            self.rospy.logwarn_throttle_identical(5.0, f"{NODE_NAME}: {exc}")
            return
        except Exception:
            self.rospy.logerr(f"{NODE_NAME}: odometry callback failed:\n{traceback.format_exc()}")
            return
        self._publish(outputs)

    def _on_initial_pose(self, msg: Any) -> None:
        try:
            frame = msg.header.frame_id.lstrip("/")
            if frame not in ("", self.settings.map_frame):
                raise ValueError(
                    f"initial pose is in frame {frame!r}, not the map frame {self.settings.map_frame!r}: ignored"
                )
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            pose = (p.x, p.y, quaternion_to_yaw(q.x, q.y, q.z, q.w))
            self.core.set_initial_pose(msg.header.stamp.to_sec(), pose, list(msg.pose.covariance))
            self.rospy.loginfo(
                f"{NODE_NAME}: initial pose x={pose[0]:.3f} m y={pose[1]:.3f} m yaw={math.degrees(pose[2]):.1f} deg"
            )
        except (TypeError, ValueError) as exc:
            self.rospy.logwarn(f"{NODE_NAME}: {exc}")
        except Exception:
            self.rospy.logerr(f"{NODE_NAME}: initial pose callback failed:\n{traceback.format_exc()}")

    # --- publishing ------------------------------------------------------------------------------

    def _publish(self, outputs: Sequence[PoseOutput]) -> None:
        for out in outputs:
            with self._publish_lock:
                stamp = self._stamps.get(out.stamp) or self.rospy.Time.from_sec(out.stamp)
                self.pose_pub.publish(self._pose_message(out, stamp))
                if self.tf_broadcaster is not None:
                    self.tf_broadcaster.sendTransform(self._map_to_odom_message(out, stamp))

    def _pose_message(self, out: PoseOutput, stamp: Any) -> Any:
        msg = self.geometry_msgs.PoseWithCovarianceStamped()
        msg.header.stamp = stamp
        msg.header.frame_id = self.settings.map_frame
        x, y, yaw = out.pose
        msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
        o = msg.pose.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(yaw)
        msg.pose.covariance = out.covariance_6x6
        return msg

    def _map_to_odom_message(self, out: PoseOutput, stamp: Any) -> Any:
        msg = self.geometry_msgs.TransformStamped()
        msg.header.stamp = stamp + self.rospy.Duration.from_sec(self.settings.transform_tolerance)
        msg.header.frame_id = self.settings.map_frame
        msg.child_frame_id = self.settings.odom_frame
        x, y, yaw = out.map_to_odom
        msg.transform.translation.x, msg.transform.translation.y = x, y
        r = msg.transform.rotation
        r.x, r.y, r.z, r.w = yaw_to_quaternion(yaw)
        return msg

    def _grid_message(self, grid: OccupancyGridMessage, stamp: Any) -> Any:
        msg = self.nav_msgs.OccupancyGrid()
        msg.header.stamp = stamp
        msg.header.frame_id = self.settings.map_frame
        msg.info.map_load_time = stamp
        msg.info.resolution = grid.resolution
        msg.info.width, msg.info.height = grid.width, grid.height
        ox, oy, oyaw = grid.origin
        msg.info.origin.position.x, msg.info.origin.position.y = ox, oy
        o = msg.info.origin.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(oyaw)
        msg.data = grid.data.ravel().tolist()
        return msg

    def _publish_eog(self, _event: Any = None) -> None:
        try:
            grid = self.core.eog()
            if grid is not None and self.eog_pub is not None:
                self.eog_pub.publish(self._grid_message(grid, self.rospy.Time.now()))
        except Exception:
            self.rospy.logerr(f"{NODE_NAME}: publishing the enhanced occupancy grid failed:\n{traceback.format_exc()}")

    def _publish_diagnostics(self, _event: Any = None) -> None:
        try:
            self.diagnostics_pub.publish(self.diagnostics_message(self.core.diagnostics()))
        except Exception:
            self.rospy.logerr(f"{NODE_NAME}: publishing diagnostics failed:\n{traceback.format_exc()}")

    def diagnostics_message(self, diagnostics: NodeDiagnostics) -> Any:
        """A `DiagnosticArray` holding one status, "planicp_node: localization"."""
        d = self.diagnostic_msgs
        status = d.DiagnosticStatus()
        status.level = diagnostics.level
        status.name = f"{NODE_NAME}: localization"
        status.message = diagnostics.message
        status.hardware_id = "planicp"
        status.values = [d.KeyValue(key=k, value=v) for k, v in diagnostics.values().items()]
        array = d.DiagnosticArray()
        array.header.stamp = self.rospy.Time.now()
        array.status = [status]
        return array

    # --- helpers ---------------------------------------------------------------------------------

    def _laser_mount(self, frame: str) -> tuple[Pose, bool] | None:
        """T_base_laser of `frame` (and whether the laser is upside down), or None (counted)."""
        configured = self.settings.laser_pose
        if configured is not None:
            return configured, False
        known = self._laser_mounts.get(frame)
        if known is not None:
            return known
        try:
            t = self.tf_buffer.lookup_transform(
                self.settings.base_frame, frame, self.rospy.Time(0), self.rospy.Duration.from_sec(LASER_LOOKUP_TIMEOUT)
            )
        except Exception as exc:  # tf2 raises its own LookupException, ExtrapolationException, ...
            self.core.drop_scan_without_laser_pose(frame, f"no tf {self.settings.base_frame} -> {frame}: {exc}")
            self.rospy.logwarn_throttle(
                5.0,
                f"{NODE_NAME}: no transform {self.settings.base_frame} -> {frame} "
                f"({exc}); set the laser_pose parameter or publish it",
            )
            return None
        tr, q = t.transform.translation, t.transform.rotation
        mount = planar_mount((tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w))
        self._laser_mounts[frame] = mount
        self.rospy.loginfo(
            f"{NODE_NAME}: laser {frame} at x={mount[0][0]:.3f} y={mount[0][1]:.3f} "
            f"yaw={math.degrees(mount[0][2]):.1f} deg in {self.settings.base_frame}"
            + (" (upside down)" if mount[1] else "")
        )
        return mount

    def _remember(self, stamp: float, ros_stamp: Any) -> None:
        self._stamps[stamp] = ros_stamp
        while len(self._stamps) > 8:
            self._stamps.popitem(last=False)

    def _check_frames(self, what: str, frame: str, expected: str, child: str, expected_child: str) -> None:
        """Warns once when a message's frames differ from the configured ones."""
        frame, child = frame.lstrip("/"), child.lstrip("/")
        if (frame and frame != expected) or (child and child != expected_child):
            key = f"{what}:{frame}:{child}"
            if key not in self._warned:
                self._warned.add(key)
                self.rospy.logwarn(
                    f"{NODE_NAME}: {what} is {frame} -> {child}, the parameters say {expected} -> "
                    f"{expected_child}; using it as {expected} -> {expected_child}"
                )


def main(argv: Sequence[str] | None = None) -> int:
    """Runs `planicp_node` until ROS shuts down. Returns the exit code (2: bad parameters or plan)."""
    started = start_node(NODE_NAME, argv)
    if started is None:
        return 2
    ros, rospy = started
    try:
        settings = NodeSettings.from_params(rospy.get_param("~", {}))
        if settings.map_topic:
            raise ValueError(
                f"map_topic is {settings.map_topic!r}, but the ROS 1 node reads its plan from the plan parameter "
                "only (a map_server YAML works there); only the ROS 2 node takes the plan from a topic"
            )
        core = PlanicpNodeCore.from_settings(settings)
    except (TypeError, ValueError, FileNotFoundError) as exc:
        rospy.logfatal(f"{NODE_NAME}: {exc}")
        return 2
    PlanicpRosNode(settings, core)
    rospy.spin()
    return 0


if __name__ == "__main__":
    sys.exit(main())
