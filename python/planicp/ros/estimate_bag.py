"""planicp's estimates over a replayed log as a ROS 2 bag, to open the run in RViz or Foxglove.

Written without ROS through `rosbags` (rosbag2 format 8, sqlite3 or MCAP storage, ROS 2 Humble
message definitions, which Jazzy shares for these types). Frames follow REP-105; every stamp is
the scan's time (the log's clock), and each message's receive time in the bag is its stamp.

Topics:
    * `/amcl_pose` (`geometry_msgs/msg/PoseWithCovarianceStamped`), one per scan: T_map_base in
      `map_frame`; the covariance is the (x, y, yaw) covariance in the row-major 6x6 layout of
      `message_layout.covariance_to_6x6` (m^2, m rad, rad^2; other entries 0).
    * `/tf` (`tf2_msgs/msg/TFMessage`), one per scan: `map_frame` -> `odom_frame`
      (T_map_odom = T_map_base * inverse(T_odom_base), as the nodes publish it) and `odom_frame` ->
      `base_frame` (the odometry T_odom_base the localizer received), so the tree is whole.
    * `/tf_static`, once at the first scan: `base_frame` -> `laser_frame` (the laser mount), when given.
    * `/map` (`nav_msgs/msg/OccupancyGrid`), once at the first scan: the plan, when given.
    * `/eog` (`nav_msgs/msg/OccupancyGrid`), once at the last scan: the enhanced occupancy grid
      (-1 unknown, 0 free, 100 occupied; row 0 at the origin, y up), when given.

Needs the optional dependency: `pip install planicp[ros]`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np

from .._validation import Pose
from ..evaluation.log_replay import TrackedLog
from ..io.bag import STORAGES, TF_MESSAGE, latched_qos, ros2_typestore, ros_time_ns, rosbag2_writer
from ..mapping.occupancy_grid_message import OccupancyGridMessage
from ..se2 import compose, inverse, yaw_to_quaternion
from .message_layout import covariance_to_6x6

POSE_WITH_COVARIANCE_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
TOPICS = {
    "/amcl_pose": POSE_WITH_COVARIANCE_STAMPED,
    "/tf": TF_MESSAGE,
    "/tf_static": TF_MESSAGE,
    "/map": OCCUPANCY_GRID,
    "/eog": OCCUPANCY_GRID,
}
"""The topics of an estimate bag and their message types."""
LATCHED = ("/tf_static", "/map", "/eog")
"""Topics recorded as latched (transient local), as a ROS node publishes them."""


def refuse_existing_bag(path: str | Path) -> Path:
    """The bag path, after checking that nothing is there (a bag is never written over).

    Raises:
        ValueError: `path` exists; the message names the fix.
    """
    out = Path(path)
    if out.exists() or out.is_symlink():
        raise ValueError(
            f"{out} exists already; planicp writes new bags only: remove it or give another --out-bag path"
        )
    return out


def write_estimate_bag(
    path: str | Path,
    tracked: TrackedLog,
    *,
    plan: OccupancyGridMessage | None = None,
    eog: OccupancyGridMessage | None = None,
    laser_pose: Pose | None = None,
    storage: Literal["sqlite3", "mcap"] = "sqlite3",
    map_frame: str = "map",
    odom_frame: str = "odom",
    base_frame: str = "base_link",
    laser_frame: str = "laser",
) -> Path:
    """Writes the estimates of `tracked` (from `track_log`) as a new ROS 2 bag folder (module doc).

    Args:
        path: the bag folder to create; it must not exist.
        tracked: the replay's output; its `covariance` and `odom_pose` must cover every scan.
        plan: the plan as a grid (`plan_grid.plan_occupancy_grid`), written on `/map`.
        eog: the enhanced occupancy grid (`EnhancedOccupancyGrid.to_occupancy_grid()`), on `/eog`.
        laser_pose: T_base_laser (x, y, yaw; metres, radians), written on `/tf_static`.
        storage: "sqlite3" (rosbag2's default before Iron) or "mcap" (its default since).
        map_frame: the map frame id (REP-105), of the poses and the grids.
        odom_frame: the odometry frame id.
        base_frame: the robot's base frame id.
        laser_frame: the laser's frame id.

    Returns:
        The bag's path.

    Raises:
        ValueError: `path` exists, no scans, an unknown storage, or `tracked` lacks the covariance
            or odometry of its scans (a `TrackedLog` made by hand).
    """
    out = refuse_existing_bag(path)
    if storage not in STORAGES:
        raise ValueError(f"storage must be one of {', '.join(STORAGES)}, got {storage!r}")
    n = len(tracked.times)
    if n == 0:
        raise ValueError("no scans: an estimate bag needs at least one tracked scan")
    if tracked.covariance.shape != (n, 3, 3) or tracked.odom_pose.shape != (n, 3):
        raise ValueError(
            f"tracked holds {n} scans but covariances of shape {tracked.covariance.shape} and odometry of "
            f"shape {tracked.odom_pose.shape}: pass the TrackedLog that track_log returns"
        )
    store = ros2_typestore()
    types = store.types
    Time, Header = types["builtin_interfaces/msg/Time"], types["std_msgs/msg/Header"]
    TransformStamped, Transform = types["geometry_msgs/msg/TransformStamped"], types["geometry_msgs/msg/Transform"]
    Vector3, Point, Quaternion = (
        types["geometry_msgs/msg/Vector3"],
        types["geometry_msgs/msg/Point"],
        types["geometry_msgs/msg/Quaternion"],
    )

    def stamp(t: float) -> Any:
        ns = ros_time_ns(t)
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def quaternion(yaw: float) -> Any:
        x, y, z, w = yaw_to_quaternion(yaw)
        return Quaternion(x=x, y=y, z=z, w=w)

    def transform(t: float, parent: str, child: str, pose: Pose) -> Any:
        return TransformStamped(
            header=Header(stamp=stamp(t), frame_id=parent),
            child_frame_id=child,
            transform=Transform(translation=Vector3(x=pose[0], y=pose[1], z=0.0), rotation=quaternion(pose[2])),
        )

    def grid_message(t: float, grid: OccupancyGridMessage) -> Any:
        ox, oy, oyaw = grid.origin
        info = types["nav_msgs/msg/MapMetaData"](
            map_load_time=stamp(t),
            resolution=float(grid.resolution),
            width=grid.width,
            height=grid.height,
            origin=types["geometry_msgs/msg/Pose"](position=Point(x=ox, y=oy, z=0.0), orientation=quaternion(oyaw)),
        )
        data = np.ascontiguousarray(grid.data, dtype=np.int8).ravel()
        return types[OCCUPANCY_GRID](header=Header(stamp=stamp(t), frame_id=map_frame), info=info, data=data)

    times = [float(t) for t in tracked.times]
    messages: list[tuple[float, str, Any]] = []
    if laser_pose is not None:
        mount = transform(times[0], base_frame, laser_frame, laser_pose)
        messages.append((times[0], "/tf_static", types[TF_MESSAGE](transforms=[mount])))
    if plan is not None:
        messages.append((times[0], "/map", grid_message(times[0], plan)))
    for k, t in enumerate(times):
        x, y, yaw = (float(v) for v in tracked.estimate[k])
        odom: Pose = (float(tracked.odom_pose[k, 0]), float(tracked.odom_pose[k, 1]), float(tracked.odom_pose[k, 2]))
        pose = types["geometry_msgs/msg/PoseWithCovariance"](
            pose=types["geometry_msgs/msg/Pose"](position=Point(x=x, y=y, z=0.0), orientation=quaternion(yaw)),
            covariance=np.array(covariance_to_6x6(tracked.covariance[k]), dtype=np.float64),
        )
        messages.append(
            (
                t,
                "/amcl_pose",
                types[POSE_WITH_COVARIANCE_STAMPED](header=Header(stamp=stamp(t), frame_id=map_frame), pose=pose),
            )
        )
        map_odom = compose((x, y, yaw), inverse(odom))
        tf = [transform(t, map_frame, odom_frame, map_odom), transform(t, odom_frame, base_frame, odom)]
        messages.append((t, "/tf", types[TF_MESSAGE](transforms=tf)))
    if eog is not None:
        messages.append((times[-1], "/eog", grid_message(times[-1], eog)))
    messages.sort(key=lambda m: m[0])  # stable: at one time, the order above
    with rosbag2_writer(out, storage) as writer:
        used = dict.fromkeys(topic for _, topic, _ in messages)
        conns = {
            topic: writer.add_connection(
                topic, TOPICS[topic], typestore=store, **(latched_qos() if topic in LATCHED else {})
            )
            for topic in used
        }
        for t, topic, msg in messages:
            writer.write(conns[topic], ros_time_ns(t), store.serialize_cdr(msg, TOPICS[topic]))
    return out
