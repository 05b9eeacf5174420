"""ROS 1 bags and ROS 2 bag folders, read and written without ROS through the `rosbags` library.

Reading (`read_bag`):
    * scans: `sensor_msgs/msg/LaserScan` on `scan_topic`, stamped with `header.stamp`; readings above
      `range_max` become +inf (REP-117 "no return"), all others are kept as published (NaN, -inf and
      readings below `range_min` are dropped by `ScanFrame.points`).
    * odometry: `nav_msgs/msg/Odometry` on `odom_topic` (T_odom_base = the message's pose, yaw from its
      quaternion), sorted by `header.stamp` and interpolated to each scan's stamp (linear in x, y; along
      the shorter arc in yaw). Scans outside the odometry's time span get `odometry=None`
      (`outside_odometry="keep"`, the default) or are left out and counted in `skipped` ("drop").
    * laser mount T_base_laser: the `laser_pose` argument, else the chain of `/tf_static` transforms
      from the base frame (`base_frame`, else the odometry's `child_frame_id`, else "base_link") to the
      scan's `header.frame_id`, composed and projected to the plane; with `tf_static=False` and no
      `laser_pose` the laser sits at the base origin.

Writing (`write_bag`): a real ROS 1 bag (`version=1`, a `.bag` file) or ROS 2 bag (`version=2`, a
folder, sqlite3 or MCAP storage) with LaserScan, Odometry and `tf2_msgs/msg/TFMessage` on `/tf_static`.
`rosbag2_writer`, `ros2_typestore` and `ros_time_ns` are the pieces other ROS 2 bag writers share
(`planicp.ros.estimate_bag`). Reading takes either storage: `AnyReader` tells them apart from the
bag's `metadata.yaml`.

Needs the optional dependency: `pip install planicp[ros]`.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .._validation import Pose, as_pose
from ..se2 import compose, inverse, quaternion_to_yaw, yaw_to_quaternion
from .pose_interpolation import interpolate_poses
from .scan_log import ScanFrame, ScanLog

try:
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
except ImportError as _exc:  # pragma: no cover - exercised only without the extra
    raise ImportError(
        "planicp.io.bag reads and writes ROS bags through the rosbags library, which is not installed: "
        "pip install planicp[ros]"
    ) from _exc

LASER_SCAN = "sensor_msgs/msg/LaserScan"
ODOMETRY = "nav_msgs/msg/Odometry"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
TF_MESSAGE_DEF = "geometry_msgs/TransformStamped[] transforms\n"
STORAGES = ("sqlite3", "mcap")
"""Storage formats of ROS 2 bags planicp writes (and reads)."""


def _stamp(header: Any) -> float:
    return int(header.stamp.sec) + int(header.stamp.nanosec) * 1e-9


def _yaw(q: Any) -> float | None:
    """Yaw of a message's quaternion; None when it is not a rotation (NaN, inf, all zero)."""
    try:
        return quaternion_to_yaw(q.x, q.y, q.z, q.w)
    except ValueError:
        return None


_BAD_ODOMETRY = "Odometry (orientation not a rotation)"
_BAD_TRANSFORM = "TransformStamped in /tf_static (rotation not a rotation)"


def _frame(name: str) -> str:
    return name.lstrip("/")


def _topics_text(reader: Any) -> str:
    names = sorted({(c.topic, c.msgtype) for c in reader.connections})
    return ", ".join(f"{t} ({m})" for t, m in names) or "none"


def _connections(reader: Any, source: Path, topic: str, msgtype: str) -> list[Any]:
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        raise ValueError(f"bag {source} has no topic {topic!r}; topics present: {_topics_text(reader)}")
    wrong = [c.msgtype for c in conns if c.msgtype != msgtype]
    if wrong:
        raise ValueError(f"bag {source}: topic {topic!r} carries {wrong[0]}, expected {msgtype}")
    return conns


def read_bag(
    path: str | Path,
    *,
    scan_topic: str = "/scan",
    odom_topic: str | None = "/odom",
    laser_pose: Pose | None = None,
    tf_static: bool = True,
    base_frame: str | None = None,
    outside_odometry: Literal["keep", "drop"] = "keep",
) -> ScanLog:
    """Scans and odometry of a ROS 1 `.bag` file or a ROS 2 bag folder (see the module doc).

    Args:
        path: the `.bag` file or the ROS 2 bag folder (with its `metadata.yaml`).
        scan_topic: topic of the `sensor_msgs/msg/LaserScan` messages.
        odom_topic: topic of the `nav_msgs/msg/Odometry` messages; None reads no odometry.
        laser_pose: T_base_laser (x, y, yaw); overrides `/tf_static`.
        tf_static: look the mount up on `/tf_static`.
        base_frame: the robot's base frame for the `/tf_static` lookup.
        outside_odometry: "keep" scans outside the odometry's time span (odometry None) or "drop" them.

    Raises:
        FileNotFoundError: no such bag.
        ValueError: a requested topic is missing or has another type (the message lists the topics present),
            no scan, or no `/tf_static` chain from the base to the laser frame.
    """
    if outside_odometry not in ("keep", "drop"):
        raise ValueError(f"outside_odometry must be 'keep' or 'drop', got {outside_odometry!r}")
    source = Path(path)
    if not source.exists():
        raise FileNotFoundError(f"bag not found: {source}")
    mount_override = as_pose(laser_pose, "laser_pose") if laser_pose is not None else None
    scans: list[tuple[float, Any]] = []
    odom: list[tuple[float, float, float, float]] = []
    child_frame: str | None = None
    tree: dict[str, tuple[str, Pose]] = {}
    skipped: dict[str, int] = {}
    with AnyReader([source], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        scan_conns = _connections(reader, source, scan_topic, LASER_SCAN)
        odom_conns = _connections(reader, source, odom_topic, ODOMETRY) if odom_topic is not None else []
        tf_conns = [c for c in reader.connections if c.topic == "/tf_static" and c.msgtype == TF_MESSAGE]
        wanted = scan_conns + odom_conns + (tf_conns if tf_static and mount_override is None else [])
        for conn, _, raw in reader.messages(connections=wanted):
            msg: Any = reader.deserialize(raw, conn.msgtype)
            if conn.msgtype == LASER_SCAN:
                scans.append((_stamp(msg.header), msg))
            elif conn.msgtype == ODOMETRY:
                p = msg.pose.pose
                yaw = _yaw(p.orientation)
                if yaw is None:
                    skipped[_BAD_ODOMETRY] = skipped.get(_BAD_ODOMETRY, 0) + 1
                    continue
                odom.append((_stamp(msg.header), float(p.position.x), float(p.position.y), yaw))
                child_frame = child_frame or _frame(msg.child_frame_id)
            else:
                for tf in msg.transforms:
                    t, tf_yaw = tf.transform.translation, _yaw(tf.transform.rotation)
                    if tf_yaw is None:
                        skipped[_BAD_TRANSFORM] = skipped.get(_BAD_TRANSFORM, 0) + 1
                        continue
                    tree[_frame(tf.child_frame_id)] = (_frame(tf.header.frame_id), (float(t.x), float(t.y), tf_yaw))
        storage = "rosbag2" if reader.is2 else "rosbag1"
    if not scans:
        raise ValueError(f"bag {source}: topic {scan_topic!r} has no messages")
    scans.sort(key=lambda s: s[0])
    laser_frame = _frame(scans[0][1].header.frame_id)
    base = base_frame or child_frame or "base_link"
    if mount_override is not None:
        mount = mount_override
    elif tf_static:
        mount = _chain(tree, base, laser_frame, source)
    else:
        mount = (0.0, 0.0, 0.0)
    odo = np.array(sorted(odom), dtype=np.float64).reshape(-1, 4)
    times = np.array([t for t, _ in scans])
    at_scans, inside = interpolate_poses(odo[:, 0], odo[:, 1:], times)
    frames: list[ScanFrame] = []
    for k, (t, msg) in enumerate(scans):
        if odom_topic is not None and not inside[k] and outside_odometry == "drop":
            skipped["LaserScan (outside the odometry time span)"] = (
                skipped.get("LaserScan (outside the odometry time span)", 0) + 1
            )
            continue
        ranges = np.asarray(msg.ranges, dtype=np.float64).copy()
        with np.errstate(invalid="ignore"):
            ranges[ranges > float(msg.range_max)] = np.inf
        odometry: Pose | None = (
            (float(at_scans[k, 0]), float(at_scans[k, 1]), float(at_scans[k, 2])) if inside[k] else None
        )
        frames.append(
            ScanFrame(
                t,
                ranges,
                float(msg.angle_min),
                float(msg.angle_increment),
                float(msg.range_min),
                float(msg.range_max),
                laser_pose=mount,
                odometry=odometry,
            )
        )
    params = {
        "storage": storage,
        "scan_topic": scan_topic,
        "odom_topic": str(odom_topic),
        "base_frame": base,
        "laser_frame": laser_frame,
    }
    return ScanLog(source, frames, odo[:, 0].copy(), odo[:, 1:].copy(), skipped, [], params)


def _to_root(tree: dict[str, tuple[str, Pose]], frame: str) -> tuple[str, Pose]:
    pose: Pose = (0.0, 0.0, 0.0)
    seen = {frame}
    while frame in tree:
        parent, step = tree[frame]
        pose = compose(step, pose)
        frame = parent
        if frame in seen:
            break
        seen.add(frame)
    return frame, pose


def _chain(tree: dict[str, tuple[str, Pose]], base: str, laser: str, source: Path) -> Pose:
    if base == laser:
        return (0.0, 0.0, 0.0)
    root_b, t_root_base = _to_root(tree, base)
    root_l, t_root_laser = _to_root(tree, laser)
    if root_b != root_l:
        frames = sorted(set(tree) | {p for p, _ in tree.values()})
        raise ValueError(
            f"bag {source}: no /tf_static chain from base frame {base!r} to laser frame {laser!r} "
            f"(frames on /tf_static: {frames or 'none'}); pass laser_pose=(x, y, yaw) or base_frame"
        )
    return compose(inverse(t_root_base), t_root_laser)


def write_bag(
    path: str | Path,
    frames: Iterable[ScanFrame] | ScanLog,
    *,
    version: Literal[1, 2] = 2,
    scan_topic: str = "/scan",
    odom_topic: str = "/odom",
    odometry: tuple[Any, Any] | None = None,
    base_frame: str = "base_link",
    laser_frame: str = "laser",
    odom_frame: str = "odom",
    storage: Literal["sqlite3", "mcap"] = "sqlite3",
) -> Path:
    """Writes scans (and odometry, and the laser mount on `/tf_static`) as a real ROS bag.

    Args:
        path: a new `.bag` file (version 1) or a new folder (version 2); it must not exist.
        frames: the scans, in time order; they must share one `laser_pose`. A `ScanLog` also gives its
            odometry stream when `odometry` is None.
        version: 1 (ROS 1 Noetic message definitions) or 2 (ROS 2 Humble, sqlite3 storage).
        scan_topic: topic name of the scans.
        odom_topic: topic name of the odometry.
        odometry: ((K,) times, (K, 3) T_odom_base) written on `odom_topic`; by default the `ScanLog`'s
            stream, or each frame's `odometry` at its scan time.
        base_frame: the robot's frame id written into the headers.
        laser_frame: the laser's frame id written into the headers.
        odom_frame: the odometry frame id written into the headers.
        storage: a ROS 2 bag's storage, "sqlite3" (rosbag2's default before Iron) or "mcap".

    Returns:
        The bag's path.
    """
    out = Path(path)
    if version not in (1, 2):
        raise ValueError(f"version must be 1 (ROS 1) or 2 (ROS 2), got {version!r}")
    _check_storage(storage)
    if version == 1 and storage != "sqlite3":
        raise ValueError(f"a ROS 1 bag has one storage format; storage={storage!r} is for ROS 2 bags (version=2)")
    if version == 1 and out.suffix != ".bag":
        raise ValueError(f"a ROS 1 bag's file name must end in .bag, got {out}")
    if out.exists():
        raise ValueError(f"{out} exists already; write_bag creates new bags only")
    scan_list: Sequence[ScanFrame] = list(frames)
    if not scan_list:
        raise ValueError("write_bag needs at least one scan")
    mount = scan_list[0].laser_pose
    if any(f.laser_pose != mount for f in scan_list):
        raise ValueError("all scans must share one laser_pose (a bag carries one static base->laser transform)")
    times = [f.time for f in scan_list]
    if any(b < a for a, b in zip(times, times[1:])):
        raise ValueError("scans must be in time order")
    if odometry is not None:
        odo_t = np.asarray(odometry[0], dtype=np.float64)
        odo_p = np.asarray(odometry[1], dtype=np.float64)
    elif isinstance(frames, ScanLog) and len(frames.odometry_times):
        odo_t, odo_p = frames.odometry_times, frames.odometry_poses
    else:
        with_odo = [f for f in scan_list if f.odometry is not None]
        odo_t = np.array([f.time for f in with_odo], dtype=np.float64)
        odo_p = np.array([f.odometry for f in with_odo], dtype=np.float64).reshape(-1, 3)
    if odo_t.ndim != 1 or odo_p.shape != (odo_t.shape[0], 3):
        raise ValueError(f"odometry must be ((K,) times, (K, 3) poses), got {odo_t.shape} and {odo_p.shape}")

    store = get_typestore(Stores.ROS1_NOETIC) if version == 1 else ros2_typestore()
    if TF_MESSAGE not in store.types:
        store.register(get_types_from_msg(TF_MESSAGE_DEF, TF_MESSAGE))
    ser = store.serialize_ros1 if version == 1 else store.serialize_cdr
    types = store.types
    Time, Header = types["builtin_interfaces/msg/Time"], types["std_msgs/msg/Header"]

    def header(t: float, frame_id: str) -> Any:
        ns = ros_time_ns(t)
        stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return Header(seq=0, stamp=stamp, frame_id=frame_id) if version == 1 else Header(stamp=stamp, frame_id=frame_id)

    def quaternion(yaw: float) -> Any:
        x, y, z, w = yaw_to_quaternion(yaw)
        return types["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    vector3, point = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Point"]
    messages: list[tuple[int, str, Any]] = []
    t0 = min(times[0], float(odo_t[0])) if len(odo_t) else times[0]
    transform = types["geometry_msgs/msg/TransformStamped"](
        header=header(t0, base_frame),
        child_frame_id=laser_frame,
        transform=types["geometry_msgs/msg/Transform"](
            translation=vector3(x=mount[0], y=mount[1], z=0.0), rotation=quaternion(mount[2])
        ),
    )
    messages.append((ros_time_ns(t0), "/tf_static", types[TF_MESSAGE](transforms=[transform])))
    for f in scan_list:
        scan = types[LASER_SCAN](
            header=header(f.time, laser_frame),
            angle_min=f.angle_min,
            angle_max=f.angle_min + f.angle_increment * (f.beams - 1),
            angle_increment=f.angle_increment,
            time_increment=0.0,
            scan_time=0.0,
            range_min=f.range_min,
            range_max=f.range_max,
            ranges=f.ranges.astype(np.float32),
            intensities=np.zeros(0, dtype=np.float32),
        )
        messages.append((ros_time_ns(f.time), scan_topic, scan))
    zeros36 = np.zeros(36, dtype=np.float64)
    for t, (x, y, yaw) in zip(odo_t.tolist(), odo_p.tolist()):
        pose = types["geometry_msgs/msg/Pose"](position=point(x=x, y=y, z=0.0), orientation=quaternion(yaw))
        twist = types["geometry_msgs/msg/Twist"](
            linear=vector3(x=0.0, y=0.0, z=0.0), angular=vector3(x=0.0, y=0.0, z=0.0)
        )
        msg = types[ODOMETRY](
            header=header(t, odom_frame),
            child_frame_id=base_frame,
            pose=types["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=zeros36),
            twist=types["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=zeros36),
        )
        messages.append((ros_time_ns(t), odom_topic, msg))
    messages.sort(key=lambda m: m[0])
    msgtypes = {"/tf_static": TF_MESSAGE, scan_topic: LASER_SCAN, odom_topic: ODOMETRY}
    writer: Any = Writer1(out) if version == 1 else rosbag2_writer(out, storage)
    with writer:
        conns = {
            topic: writer.add_connection(topic, msgtype, typestore=store)
            for topic, msgtype in msgtypes.items()
            if topic != odom_topic or len(odo_t)
        }
        for ns, topic, msg in messages:
            writer.write(conns[topic], ns, ser(msg, msgtypes[topic]))
    return out


def _check_storage(storage: str) -> None:
    if storage not in STORAGES:
        raise ValueError(f"storage must be one of {', '.join(STORAGES)} (a ROS 2 bag's storage), got {storage!r}")


def ros2_typestore() -> Any:
    """rosbags' ROS 2 Humble message definitions (the same as Jazzy's for every type planicp
    writes), with `tf2_msgs/msg/TFMessage` registered if the store lacks it."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    if TF_MESSAGE not in store.types:
        store.register(get_types_from_msg(TF_MESSAGE_DEF, TF_MESSAGE))
    return store


def rosbag2_writer(path: Path, storage: str = "sqlite3") -> Any:
    """An unopened rosbags writer of a new ROS 2 bag folder `path` in `storage` ("sqlite3" or
    "mcap"), rosbag2 format version 8 (read by Humble, Jazzy and later).

    Raises:
        ValueError: an unknown storage.
        ImportError: the installed rosbags cannot write MCAP (the message names the upgrade).
    """
    _check_storage(storage)
    params = inspect.signature(Writer2).parameters
    options: dict[str, Any] = {}
    if "version" in params:
        options["version"] = 8
    if storage == "mcap":
        no_mcap = "the installed rosbags writes no MCAP bags: pip install -U rosbags"
        try:
            from rosbags.rosbag2.enums import StoragePlugin
        except ImportError as exc:
            raise ImportError(no_mcap) from exc
        if "storage_plugin" not in params:
            raise ImportError(no_mcap)
        options["storage_plugin"] = StoragePlugin.MCAP
    return Writer2(path, **options)


def ros_time_ns(t: float) -> int:
    """A time in seconds as integer nanoseconds (a ROS stamp, a bag's receive time).

    Raises:
        ValueError: not finite or negative.
    """
    if not (math.isfinite(t) and t >= 0.0):
        raise ValueError(f"a ROS time must be finite and >= 0 seconds, got {t!r}")
    return int(round(t * 1e9))


def latched_qos() -> dict[str, Any]:
    """Keyword arguments of rosbags' `add_connection` that record a latched (transient local, reliable,
    keep last 1) publisher, as `/tf_static` and maps are published: `ros2 bag play` then offers the
    same QoS, and RViz's transient-local subscriptions accept it. Empty with a rosbags too old to
    record QoS that way (the topic then plays with the default QoS)."""
    try:
        from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    except ImportError:
        return {}
    if "offered_qos_profiles" not in inspect.signature(Writer2.add_connection).parameters:
        return {}
    zero = QosTime(sec=0, nsec=0)
    qos = Qos(
        history=QosHistory.KEEP_LAST,
        depth=1,
        reliability=QosReliability.RELIABLE,
        durability=QosDurability.TRANSIENT_LOCAL,
        deadline=zero,
        lifespan=zero,
        liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=zero,
        avoid_ros_namespace_conventions=False,
    )
    return {"offered_qos_profiles": [qos]}
