"""`planicp-ros2-node`: the ROS 2 (Jazzy, rclpy) lifecycle node that localizes the robot in the plan, in
place of nav2_amcl.

A thin wrapper, as the ROS 1 node is: messages become calls of `PlanicpNodeCore` and its results become
messages; the parameters are read by `ros2_parameters` into the `NodeSettings` both nodes use.

Lifecycle (`rclpy.lifecycle`, driven by Nav2's lifecycle manager or `ros2 lifecycle set`, or by the
`autostart` parameter): configure reads the parameters and the plan (a file, or the first map on
`map_topic`), creates the publishers and services and starts reading tf; activate subscribes to the
scans and initial poses and starts publishing; deactivate stops both (an inactive node publishes
nothing); cleanup and shutdown release everything.

Subscribes (names relative to the node's namespace, so remappable):
  * `scan_topic` (sensor_msgs/LaserScan, sensor-data QoS), in the laser's frame; base -> laser comes
    from tf (`/tf_static`, `/tf`; chains of frames are composed) or the `laser_pose` parameter;
  * `/tf` for odom -> base (`odom_frame_id` -> `base_frame_id`, possibly through frames in between),
    T_odom_base, interpolated to each scan's stamp (tf2_ros is not a wheel: the node keeps the
    transforms it needs itself, `TransformTree` and `OdometryBuffer`);
  * `initial_pose_topic` (geometry_msgs/PoseWithCovarianceStamped in `global_frame_id`, as RViz's
    "2D Pose Estimate" sends it);
  * `map_topic` (nav_msgs/OccupancyGrid, transient local) when `plan` is "".

Publishes (only while active):
  * `pose_topic` (geometry_msgs/PoseWithCovarianceStamped, transient local, default `amcl_pose`):
    T_map_base at each scan's stamp, (x, y, yaw) covariance at indices 0, 1, 5, 6, 7, 11, 30, 31, 35;
  * `/tf` `global_frame_id -> odom_frame_id` (REP-105: T_map_odom = T_map_base * inv(T_odom_base)),
    stamped with the scan's stamp plus `transform_tolerance`, as nav2_amcl does (`tf_broadcast`);
  * `plan_topic` (nav_msgs/OccupancyGrid, transient local; "" by default, map_server publishes the map)
    and `eog_topic` (the enhanced occupancy grid, every 1 / `eog_rate` s);
  * `/diagnostics` (diagnostic_msgs/DiagnosticArray) every 1 / `diagnostics_rate` s.

Services: `reinitialize_global_localization` (std_srvs/Empty: search the whole plan with the next scan)
and `request_nomotion_update` (std_srvs/Empty: planicp aligns every scan, moving or not, so it only
acknowledges), as nav2_amcl names them.

Run: `planicp-ros2-node --ros-args -p plan:=/maps/floor3.yaml -p autostart:=true`, or include the
launch description `planicp.ros.ros2_launch_path() / "planicp.launch.py"` in a Nav2 launch file.
"""

from __future__ import annotations

import math
import sys
import time
import traceback
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

from pydantic import ValidationError

from .._settings import first_error
from .._validation import Pose
from ..mapping.occupancy_grid_message import OccupancyGridMessage
from ..se2 import quaternion_to_yaw, yaw_to_quaternion
from .message_layout import planar_mount
from .node_diagnostics import NodeDiagnostics
from .node_io import PoseOutput
from .node_logic import PlanicpNodeCore
from .node_settings import OCCUPIED, NodeSettings
from .plan_grid import plan_from_occupancy_grid
from .ros2_imports import import_ros2, tf_message_class
from .ros2_interfaces import InterfaceBuildError
from .ros2_parameters import declared_defaults, settings_from_ros2
from .transform_tree import Transform, TransformTree, as_transform, compose3, planar

_ros = import_ros2(
    (
        "rclpy",
        "rclpy.executors",
        "rclpy.lifecycle",
        "rclpy.qos",
        "rclpy.publisher",
        "rclpy.service",
        "rclpy.subscription",
        "rclpy.timer",
        "builtin_interfaces.msg",
        "diagnostic_msgs.msg",
        "geometry_msgs.msg",
        "nav_msgs.msg",
        "rcl_interfaces.msg",
        "sensor_msgs.msg",
        "std_srvs.srv",
    )
)
rclpy: Any = _ros["rclpy"]
_qos: Any = _ros["rclpy.qos"]
_lifecycle: Any = _ros["rclpy.lifecycle"]
Time: Any = _ros["builtin_interfaces.msg"].Time
DiagnosticArray: Any = _ros["diagnostic_msgs.msg"].DiagnosticArray
DiagnosticStatus: Any = _ros["diagnostic_msgs.msg"].DiagnosticStatus
KeyValue: Any = _ros["diagnostic_msgs.msg"].KeyValue
PoseWithCovarianceStamped: Any = _ros["geometry_msgs.msg"].PoseWithCovarianceStamped
TransformStamped: Any = _ros["geometry_msgs.msg"].TransformStamped
OccupancyGrid: Any = _ros["nav_msgs.msg"].OccupancyGrid
ParameterDescriptor: Any = _ros["rcl_interfaces.msg"].ParameterDescriptor
LaserScan: Any = _ros["sensor_msgs.msg"].LaserScan
Empty: Any = _ros["std_srvs.srv"].Empty
TransitionCallbackReturn: Any = _lifecycle.TransitionCallbackReturn
Publisher: Any = _ros["rclpy.publisher"].Publisher
Service: Any = _ros["rclpy.service"].Service
Subscription: Any = _ros["rclpy.subscription"].Subscription
Timer: Any = _ros["rclpy.timer"].Timer

WARN_EVERY = 5.0
"""Seconds between two logs of the same warning."""

NODE_NAME = "planicp"
"""The node's default name (a Nav2 launch names it `amcl`, for the lifecycle manager's node list)."""

LATCHED = _qos.QoSProfile(
    depth=1, durability=_qos.DurabilityPolicy.TRANSIENT_LOCAL, reliability=_qos.ReliabilityPolicy.RELIABLE
)
"""Transient local, reliable, depth 1: nav2_amcl's `amcl_pose`, map_server's `map`."""
TF_QOS = _qos.QoSProfile(depth=100, reliability=_qos.ReliabilityPolicy.RELIABLE)
TF_STATIC_QOS = _qos.QoSProfile(
    depth=100, durability=_qos.DurabilityPolicy.TRANSIENT_LOCAL, reliability=_qos.ReliabilityPolicy.RELIABLE
)
DEFAULT_QOS = _qos.QoSProfile(depth=10)


def stamp_seconds(stamp: Any) -> float:
    """A `builtin_interfaces/Time` as seconds."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def stamp_plus(stamp: Any, seconds: float) -> Any:
    """A `builtin_interfaces/Time` `seconds` after `stamp` (exact in nanoseconds)."""
    ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec) + round(seconds * 1e9)
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def stamp_from_seconds(seconds: float) -> Any:
    ns = round(seconds * 1e9)
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class PlanicpLifecycleNode(_lifecycle.Node):  # type: ignore[misc]
    """The ROS 2 side of planicp's localization node; see the module's description."""

    def __init__(self, node_name: str = NODE_NAME, **kwargs: Any) -> None:
        """
        Args:
            node_name: the node's name (remappable with `--ros-args -r __node:=NAME`).
            kwargs: passed to `rclpy.lifecycle.Node` (namespace, context, parameter_overrides, ...).
        """
        super().__init__(
            node_name,
            allow_undeclared_parameters=True,
            automatically_declare_parameters_from_overrides=True,
            **kwargs,
        )
        for name, default in declared_defaults().items():
            if not self.has_parameter(name):
                self.declare_parameter(name, default, ParameterDescriptor(dynamic_typing=True))
        self._tf_message = tf_message_class()
        self.settings: NodeSettings | None = None
        self.core: PlanicpNodeCore | None = None
        self._active = False
        self._entities: list[Any] = []  # made by configure, destroyed by cleanup
        self._active_entities: list[Any] = []  # made by activate, destroyed by deactivate
        self._tree = TransformTree()
        self._laser_mounts: dict[str, tuple[Pose, bool]] = {}
        self._stamps: OrderedDict[float, Any] = OrderedDict()
        self._pending_initial: tuple[float, Pose, list[float]] | None = None
        self._warned_at: dict[str, float] = {}
        self._pose_pub: Any = None
        self._tf_pub: Any = None
        self._plan_pub: Any = None
        self._eog_pub: Any = None
        self._diagnostics_pub: Any = None

    # --- lifecycle -------------------------------------------------------------------------------

    def on_configure(self, state: Any) -> Any:
        """Reads the parameters and the plan; creates publishers, services and the tf subscriptions."""
        values = {name: p.value for name, p in self.get_parameters_by_prefix("").items()}
        try:
            settings, ignored = settings_from_ros2(values)
            core = None if settings.map_topic else PlanicpNodeCore.from_settings(settings)
        except ValidationError as exc:
            self.get_logger().error(f"configure failed: bad parameter: {first_error(exc)}")
            return TransitionCallbackReturn.FAILURE
        except (TypeError, ValueError, FileNotFoundError) as exc:
            self.get_logger().error(f"configure failed: {exc}")
            return TransitionCallbackReturn.FAILURE
        except Exception:  # the plan could not be prepared (e.g. more walls than the index holds)
            self.get_logger().error(f"configure failed:\n{traceback.format_exc()}")
            return TransitionCallbackReturn.FAILURE
        if ignored:
            self.get_logger().info(f"nav2_amcl parameters without a meaning for planicp, ignored: {ignored}")
        self.settings, self.core = settings, core
        s = settings
        self._pose_pub = self.create_publisher(PoseWithCovarianceStamped, s.pose_topic, LATCHED)
        self._tf_pub = self.create_publisher(self._tf_message, "/tf", TF_QOS)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", DEFAULT_QOS)
        self._plan_pub = self.create_publisher(OccupancyGrid, s.plan_topic, LATCHED) if s.plan_topic else None
        self._eog_pub = self.create_publisher(OccupancyGrid, s.eog_topic, LATCHED) if s.eog_topic else None
        self._entities = [
            p for p in (self._pose_pub, self._tf_pub, self._diagnostics_pub, self._plan_pub, self._eog_pub) if p
        ]
        self._entities += [
            self.create_subscription(self._tf_message, "/tf", self._on_tf, TF_QOS),
            self.create_subscription(self._tf_message, "/tf_static", self._on_tf, TF_STATIC_QOS),
            self.create_service(Empty, "reinitialize_global_localization", self._on_global_localization),
            self.create_service(Empty, "request_nomotion_update", self._on_nomotion_update),
        ]
        if s.map_topic:
            self._entities.append(self.create_subscription(OccupancyGrid, s.map_topic, self._on_map, LATCHED))
        self.get_logger().info(
            f"configured: plan {'from topic ' + s.map_topic if s.map_topic else s.plan}, scans from {s.scan_topic}, "
            f"{s.odom_frame} -> {s.base_frame} from /tf, publishing {s.pose_topic}"
            + (f" and /tf {s.map_frame} -> {s.odom_frame}" if s.publish_tf else "")
        )
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: Any) -> Any:
        """Subscribes to scans and initial poses and starts publishing."""
        s = self.settings
        assert s is not None, "activate follows configure"
        self._active_entities = [
            self.create_subscription(LaserScan, s.scan_topic, self._on_scan, _qos.qos_profile_sensor_data),
            self.create_subscription(
                PoseWithCovarianceStamped, s.initial_pose_topic, self._on_initial_pose, DEFAULT_QOS
            ),
        ]
        if s.diagnostics_rate > 0.0:
            self._active_entities.append(self.create_timer(1.0 / s.diagnostics_rate, self._publish_diagnostics))
        if self._eog_pub is not None and s.eog_rate > 0.0:
            self._active_entities.append(self.create_timer(1.0 / s.eog_rate, self._publish_eog))
        self._active = True
        self._publish_plan()
        self.get_logger().info("active")
        return TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state: Any) -> Any:
        """Stops reading scans and publishing (tf is still read, so odometry stays current)."""
        self._active = False
        self._destroy(self._active_entities)
        self.get_logger().info("inactive")
        return TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state: Any) -> Any:
        """Releases everything configure made; the next configure reads the parameters again."""
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: Any) -> Any:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: Any) -> Any:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def _release(self) -> None:
        self._active = False
        self._destroy(self._active_entities)
        self._destroy(self._entities)
        self.settings, self.core = None, None
        self._tree = TransformTree()
        self._laser_mounts.clear()
        self._pending_initial = None
        self._pose_pub = self._tf_pub = self._plan_pub = self._eog_pub = self._diagnostics_pub = None

    def _destroy(self, entities: list[Any]) -> None:
        for entity in entities:
            if isinstance(entity, Subscription):
                self.destroy_subscription(entity)
            elif isinstance(entity, Publisher):
                self.destroy_publisher(entity)
            elif isinstance(entity, Service):
                self.destroy_service(entity)
            elif isinstance(entity, Timer):
                self.destroy_timer(entity)
        entities.clear()

    # --- callbacks -------------------------------------------------------------------------------

    def _on_tf(self, msg: Any) -> None:
        s, core = self.settings, self.core
        if s is None:
            return
        outputs: list[PoseOutput] = []
        try:
            for t in msg.transforms:
                parent, child = t.header.frame_id.lstrip("/"), t.child_frame_id.lstrip("/")
                tr, q = t.transform.translation, t.transform.rotation
                if parent == s.odom_frame:
                    if core is None:
                        continue
                    transform = self._odom_to_base(child, (tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w))
                    if transform is not None:
                        outputs += core.add_odometry(stamp_seconds(t.header.stamp), planar(transform))
                    else:
                        self._warn(
                            f"/tf has {s.odom_frame} -> {child} but no transforms from {child} down to "
                            f"base_frame_id {s.base_frame!r} (yet): set base_frame_id to the robot's frame "
                            "(nav2_amcl's default is base_footprint)"
                        )
                elif child != s.odom_frame:
                    self._tree.set(parent, child, (tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w))
        except (TypeError, ValueError) as exc:
            self._warn(f"tf refused: {exc}")
        except Exception:
            self.get_logger().error(f"tf callback failed:\n{traceback.format_exc()}")
        self._publish(outputs)

    def _odom_to_base(self, child: str, translation: Any, rotation: Any) -> Transform | None:
        """T_odom_base from a transform odom -> `child` and the frames from `child` down to the base."""
        s = self.settings
        assert s is not None
        odom_child = as_transform(translation, rotation)
        if child == s.base_frame:
            return odom_child
        below = self._tree.lookup(child, s.base_frame)
        return None if below is None else compose3(odom_child, below)

    def _on_scan(self, msg: Any) -> None:
        core = self.core
        if not self._active or core is None:
            return
        try:
            frame = msg.header.frame_id.lstrip("/")
            mount = self._laser_mount(core, frame)
            if mount is None:
                return
            stamp = stamp_seconds(msg.header.stamp)
            self._remember(stamp, msg.header.stamp)
            outputs = core.add_scan_message(stamp, msg, mount)
        except (TypeError, ValueError) as exc:
            self._warn(str(exc))
            return
        except Exception:  # never let one message stop the node
            self.get_logger().error(f"scan callback failed:\n{traceback.format_exc()}")
            return
        self._publish(outputs)

    def _on_initial_pose(self, msg: Any) -> None:
        s = self.settings
        if s is None:
            return
        try:
            frame = msg.header.frame_id.lstrip("/")
            if frame not in ("", s.map_frame):
                raise ValueError(f"initial pose is in frame {frame!r}, not the map frame {s.map_frame!r}: ignored")
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            pose = (p.x, p.y, quaternion_to_yaw(q.x, q.y, q.z, q.w))
            covariance = list(msg.pose.covariance)
            if self.core is None:  # the plan has not arrived yet: kept for it
                self._pending_initial = (stamp_seconds(msg.header.stamp), pose, covariance)
            else:
                self.core.set_initial_pose(stamp_seconds(msg.header.stamp), pose, covariance)
            self.get_logger().info(
                f"initial pose x={pose[0]:.3f} m y={pose[1]:.3f} m yaw={math.degrees(pose[2]):.1f} deg"
            )
        except (TypeError, ValueError) as exc:
            self.get_logger().warning(str(exc))
        except Exception:
            self.get_logger().error(f"initial pose callback failed:\n{traceback.format_exc()}")

    def _on_map(self, msg: Any) -> None:
        s = self.settings
        if s is None:
            return
        try:
            info = msg.info
            o = info.origin.orientation
            origin = (info.origin.position.x, info.origin.position.y, quaternion_to_yaw(o.x, o.y, o.z, o.w))
            plan = plan_from_occupancy_grid(msg.data, info.width, info.height, info.resolution, origin, OCCUPIED)
            self.core = PlanicpNodeCore(plan, s)
        except (TypeError, ValueError) as exc:
            self.get_logger().error(f"map on {s.map_topic} refused: {exc}")
            return
        except Exception:
            self.get_logger().error(f"map callback failed:\n{traceback.format_exc()}")
            return
        self.get_logger().info(
            f"plan from {s.map_topic}: {info.width} x {info.height} cells of {info.resolution} m, "
            f"{len(plan)} wall points"
        )
        if self._pending_initial is not None:
            stamp, pose, covariance = self._pending_initial
            self._pending_initial = None
            self.core.set_initial_pose(stamp, pose, covariance)

    def _on_global_localization(self, request: Any, response: Any) -> Any:
        if self.core is None:
            self.get_logger().warning("global localization requested before the plan is known: ignored")
        else:
            self.core.request_global_localization()
            self.get_logger().info("global localization: searching the whole plan with the next scan")
        return response

    def _on_nomotion_update(self, request: Any, response: Any) -> Any:
        self.get_logger().debug("no-motion update requested: planicp aligns every scan, moving or not")
        return response

    # --- publishing ------------------------------------------------------------------------------

    def _publish(self, outputs: Sequence[PoseOutput]) -> None:
        s = self.settings
        if not self._active or s is None:
            return
        for out in outputs:
            stamp = self._stamps.get(out.stamp) or stamp_from_seconds(out.stamp)
            self._pose_pub.publish(self._pose_message(out, stamp, s))
            if s.publish_tf:
                self._tf_pub.publish(self._tf_message(transforms=[self._map_to_odom(out, stamp, s)]))

    def _pose_message(self, out: PoseOutput, stamp: Any, s: NodeSettings) -> Any:
        msg = PoseWithCovarianceStamped()
        msg.header.stamp = stamp
        msg.header.frame_id = s.map_frame
        x, y, yaw = out.pose
        msg.pose.pose.position.x, msg.pose.pose.position.y = float(x), float(y)
        o = msg.pose.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(yaw)
        msg.pose.covariance = [float(v) for v in out.covariance_6x6]
        return msg

    def _map_to_odom(self, out: PoseOutput, stamp: Any, s: NodeSettings) -> Any:
        msg = TransformStamped()
        msg.header.stamp = stamp_plus(stamp, s.transform_tolerance)
        msg.header.frame_id = s.map_frame
        msg.child_frame_id = s.odom_frame
        x, y, yaw = out.map_to_odom
        msg.transform.translation.x, msg.transform.translation.y = float(x), float(y)
        r = msg.transform.rotation
        r.x, r.y, r.z, r.w = yaw_to_quaternion(yaw)
        return msg

    def _grid_message(self, grid: OccupancyGridMessage, s: NodeSettings) -> Any:
        msg = OccupancyGrid()
        now = self.get_clock().now().to_msg()
        msg.header.stamp = now
        msg.header.frame_id = s.map_frame
        msg.info.map_load_time = now
        msg.info.resolution = float(grid.resolution)
        msg.info.width, msg.info.height = int(grid.width), int(grid.height)
        ox, oy, oyaw = grid.origin
        msg.info.origin.position.x, msg.info.origin.position.y = float(ox), float(oy)
        o = msg.info.origin.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(oyaw)
        msg.data = grid.data.ravel().tolist()
        return msg

    def _publish_plan(self) -> None:
        s, core = self.settings, self.core
        if self._active and s is not None and core is not None and self._plan_pub is not None:
            self._plan_pub.publish(self._grid_message(core.plan_grid(), s))

    def _publish_eog(self) -> None:
        s, core = self.settings, self.core
        if not self._active or s is None or core is None or self._eog_pub is None:
            return
        try:
            grid = core.eog()
            if grid is not None:
                self._eog_pub.publish(self._grid_message(grid, s))
        except Exception:
            self.get_logger().error(f"publishing the enhanced occupancy grid failed:\n{traceback.format_exc()}")

    def _publish_diagnostics(self) -> None:
        if not self._active or self._diagnostics_pub is None:
            return
        try:
            core, s = self.core, self.settings
            if core is None:
                waiting = s.map_topic if s is not None else "the map topic"
                status = DiagnosticStatus(level=DiagnosticStatus.WARN, message=f"waiting for the plan on {waiting}")
                status.name, status.hardware_id = f"{self.get_name()}: localization", "planicp"
                array = DiagnosticArray()
                array.header.stamp = self.get_clock().now().to_msg()
                array.status = [status]
                self._diagnostics_pub.publish(array)
            else:
                self._diagnostics_pub.publish(self.diagnostics_message(core.diagnostics()))
        except Exception:
            self.get_logger().error(f"publishing diagnostics failed:\n{traceback.format_exc()}")

    def diagnostics_message(self, diagnostics: NodeDiagnostics) -> Any:
        """A `DiagnosticArray` holding one status, "<node name>: localization"."""
        status = DiagnosticStatus()
        status.level = bytes([diagnostics.level])
        status.name = f"{self.get_name()}: localization"
        status.message = diagnostics.message
        status.hardware_id = "planicp"
        status.values = [KeyValue(key=k, value=v) for k, v in diagnostics.values().items()]
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        array.status = [status]
        return array

    # --- helpers ---------------------------------------------------------------------------------

    def _laser_mount(self, core: PlanicpNodeCore, frame: str) -> tuple[Pose, bool] | None:
        """T_base_laser of `frame` (and whether the laser is upside down), or None (counted)."""
        s = self.settings
        assert s is not None
        if s.laser_pose is not None:
            return s.laser_pose, False
        known = self._laser_mounts.get(frame)
        if known is not None:
            return known
        transform = self._tree.lookup(s.base_frame, frame)
        if transform is None:
            core.drop_scan_without_laser_pose(frame, f"no tf {s.base_frame} -> {frame}")
            self.get_logger().warning(
                f"no transform {s.base_frame} -> {frame} on /tf_static or /tf yet; publish it (a URDF, a static "
                "transform publisher) or set the laser_pose parameter",
                throttle_duration_sec=5.0,
            )
            return None
        mount = planar_mount(*transform)
        self._laser_mounts[frame] = mount
        self.get_logger().info(
            f"laser {frame} at x={mount[0][0]:.3f} y={mount[0][1]:.3f} yaw={math.degrees(mount[0][2]):.1f} deg "
            f"in {s.base_frame}" + (" (upside down)" if mount[1] else "")
        )
        return mount

    def _warn(self, message: str) -> None:
        """Logs a warning, each distinct message at most once per `WARN_EVERY` seconds (a stream of
        malformed messages does not flood the log; different problems are each seen)."""
        now = time.monotonic()
        if now - self._warned_at.get(message, -math.inf) >= WARN_EVERY:
            if len(self._warned_at) > 256:
                self._warned_at.clear()
            self._warned_at[message] = now
            self.get_logger().warning(message)

    def _remember(self, stamp: float, ros_stamp: Any) -> None:
        self._stamps[stamp] = ros_stamp
        while len(self._stamps) > 8:
            self._stamps.popitem(last=False)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the node until ROS shuts down (Ctrl-C). Returns the exit code: 2 when the interfaces cannot be
    built, or when `autostart` is set and configure fails."""
    args = list(argv) if argv is not None else sys.argv
    rclpy.init(args=args)
    node = None
    try:
        try:
            node = PlanicpLifecycleNode()
        except InterfaceBuildError as exc:
            print(f"planicp-ros2-node: {exc}", file=sys.stderr)
            return 2
        if node.get_parameter("autostart").value is True:
            node.trigger_configure()
            if node.settings is None:
                node.get_logger().fatal("autostart: configure failed (see above)")
                return 2
            node.trigger_activate()
        executor = _ros["rclpy.executors"].SingleThreadedExecutor()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, _ros["rclpy.executors"].ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
