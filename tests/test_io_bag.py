"""ROS bags through rosbags: write real ROS 1 and ROS 2 bags from scans, read them back."""

from __future__ import annotations

import importlib
import math
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from planicp.io import ScanFrame, open_log  # noqa: E402
from planicp.io.bag import read_bag, write_bag  # noqa: E402

MOUNT = (0.2, -0.05, 0.1)


def frames(count: int = 12) -> list[ScanFrame]:
    rng = np.random.default_rng(4)
    out = []
    for k in range(count):
        ranges = rng.uniform(0.5, 9.0, 91)
        ranges[k % 91] = np.inf
        ranges[(5 * k + 3) % 91] = np.nan
        out.append(
            ScanFrame(
                1700000000.0 + 0.1 * k + 1e-4,
                ranges,
                -math.pi / 2,
                math.pi / 90,
                0.1,
                10.0,
                laser_pose=MOUNT,
                odometry=(0.3 * k, -0.1 * k, math.atan2(math.sin(2.9 + 0.05 * k), math.cos(2.9 + 0.05 * k))),
            )
        )
    return out


@pytest.mark.parametrize(("version", "storage"), [(1, "sqlite3"), (2, "sqlite3"), (2, "mcap")])
def test_round_trip(tmp_path: Path, version: int, storage: str) -> None:
    original = frames()
    path = tmp_path / ("run.bag" if version == 1 else "run")
    write_bag(path, original, version=version, storage=storage)  # type: ignore[arg-type]
    if version == 2:
        assert f"storage_identifier: {storage}" in (path / "metadata.yaml").read_text()
        assert len(list(path.glob("*.mcap" if storage == "mcap" else "*.db3"))) == 1
    log = read_bag(path)
    assert log.params["storage"] == f"rosbag{version}"
    assert len(log) == len(original)
    for got, want in zip(log, original):
        assert abs(got.time - want.time) < 1e-9
        # LaserScan carries float32 ranges: exactly the float32 values, inf and NaN included.
        np.testing.assert_array_equal(got.ranges, want.ranges.astype(np.float32).astype(np.float64))
        assert (got.angle_min, got.range_min, got.range_max) == pytest.approx(
            (want.angle_min, want.range_min, want.range_max), abs=1e-6
        )
        assert got.angle_increment == pytest.approx(want.angle_increment, rel=1e-6)
        assert got.laser_pose == pytest.approx(MOUNT, abs=1e-12)
        assert got.odometry == pytest.approx(want.odometry, abs=1e-9)
        assert got.reference is None
    np.testing.assert_allclose(log.odometry_times, [f.time for f in original], atol=1e-9)
    assert open_log(path).params["storage"] == f"rosbag{version}"


def test_odometry_interpolated_to_scan_stamps_across_pi(tmp_path: Path) -> None:
    scan = frames(3)
    odo_t = [scan[0].time - 0.05, scan[2].time + 0.05]
    odo_p = [(0.0, 0.0, 3.1), (1.0, 2.0, -3.1)]
    path = tmp_path / "wrap.bag"
    write_bag(path, scan, version=1, odometry=(odo_t, odo_p))
    log = read_bag(path)
    for frame in log:
        w = (frame.time - odo_t[0]) / (odo_t[1] - odo_t[0])
        yaw = 3.1 + w * (2 * math.pi - 6.2)
        expected = (w, 2 * w, math.atan2(math.sin(yaw), math.cos(yaw)))
        assert frame.odometry == pytest.approx(expected, abs=1e-9)
        assert frame.odometry is not None and abs(frame.odometry[2]) > 3.1  # never through 0


def test_scans_outside_the_odometry_span(tmp_path: Path) -> None:
    scan = frames(6)
    path = tmp_path / "partial"
    write_bag(path, scan, odometry=([scan[1].time, scan[3].time], [(0, 0, 0), (1, 0, 0)]))
    kept = read_bag(path)
    assert [f.odometry is None for f in kept] == [True, False, False, False, True, True]
    # Unix-epoch seconds in float64 resolve ~0.24 us, so the interpolation weight is good to ~1e-6.
    assert kept[2].odometry == pytest.approx((0.5, 0.0, 0.0), abs=2e-6)
    dropped = read_bag(path, outside_odometry="drop")
    assert len(dropped) == 3 and dropped.skipped == {"LaserScan (outside the odometry time span)": 3}
    no_odom = read_bag(path, odom_topic=None)
    assert len(no_odom) == 6 and not no_odom.has_odometry


def test_an_odometry_message_whose_orientation_is_no_rotation_is_skipped_and_counted(tmp_path: Path) -> None:
    """A NaN quaternion in one odometry message is left out (and counted); the others still serve."""
    scan = frames(3)
    odo_t = [scan[0].time - 0.05, scan[1].time, scan[2].time + 0.05]
    path = tmp_path / "bad-orientation.bag"
    write_bag(path, scan, version=1, odometry=(odo_t, [(0.0, 0.0, 0.0), (5.0, 5.0, math.nan), (1.0, 0.0, 0.0)]))
    log = read_bag(path)
    assert log.skipped == {"Odometry (orientation not a rotation)": 1}
    assert len(log) == 3 and all(f.odometry is not None for f in log)
    middle = log[1].odometry
    assert middle is not None and middle[1] == 0.0 and middle[2] == 0.0  # interpolated, not the bad one


def test_missing_topic_names_bag_and_topics(tmp_path: Path) -> None:
    path = tmp_path / "run.bag"
    write_bag(path, frames(2), version=1)
    with pytest.raises(
        ValueError,
        match=r"run.bag has no topic '/front_scan'; topics present: "
        r"/odom \(nav_msgs/msg/Odometry\), /scan \(sensor_msgs/msg/LaserScan\), "
        r"/tf_static \(tf2_msgs/msg/TFMessage\)",
    ):
        read_bag(path, scan_topic="/front_scan")
    with pytest.raises(ValueError, match=r"has no topic '/wheel_odom'"):
        read_bag(path, odom_topic="/wheel_odom")
    with pytest.raises(ValueError, match=r"topic '/odom' carries nav_msgs/msg/Odometry, expected sensor_msgs"):
        read_bag(path, scan_topic="/odom")
    with pytest.raises(FileNotFoundError, match="bag not found"):
        read_bag(tmp_path / "none.bag")


def test_mount_from_a_tf_static_chain(tmp_path: Path) -> None:
    """base_link -> plate -> laser on /tf_static, written with rosbags directly as a robot would."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    stamp = t["builtin_interfaces/msg/Time"](sec=10, nanosec=0)

    def tf(parent: str, child: str, x: float, y: float, yaw: float) -> object:
        return t["geometry_msgs/msg/TransformStamped"](
            header=t["std_msgs/msg/Header"](stamp=stamp, frame_id=parent),
            child_frame_id=child,
            transform=t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.3),
                rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)),
            ),
        )

    scan = t["sensor_msgs/msg/LaserScan"](
        header=t["std_msgs/msg/Header"](stamp=stamp, frame_id="laser"),
        angle_min=-1.0,
        angle_max=1.0,
        angle_increment=1.0,
        time_increment=0.0,
        scan_time=0.0,
        range_min=0.1,
        range_max=5.0,
        ranges=np.array([1.0, 7.0, 2.0], dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )
    path = tmp_path / "chain"
    writer_options = {"version": 8} if "version" in Writer.__init__.__code__.co_varnames else {}
    with Writer(path, **writer_options) as writer:
        c_tf = writer.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=store)
        c_scan = writer.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=store)
        msg = t["tf2_msgs/msg/TFMessage"](
            transforms=[tf("plate", "laser", 0.1, 0.0, math.pi / 2), tf("base_link", "plate", 0.5, 0.2, math.pi / 2)]
        )
        writer.write(c_tf, 10_000_000_000, store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
        writer.write(c_scan, 10_000_000_000, store.serialize_cdr(scan, "sensor_msgs/msg/LaserScan"))
    log = read_bag(path, odom_topic=None)
    # plate at (0.5, 0.2) turned 90 deg; laser 0.1 m along the plate's x, i.e. +y in base: (0.5, 0.3), 180 deg.
    assert log[0].laser_pose == pytest.approx((0.5, 0.3, math.pi), abs=1e-12)
    assert log[0].ranges[1] == np.inf  # 7 m > range_max 5 m: no return
    np.testing.assert_allclose(
        log[0].points(),
        [[0.5 - math.cos(-1.0), 0.3 - math.sin(-1.0)], [0.5 - 2 * math.cos(1.0), 0.3 - 2 * math.sin(1.0)]],
        atol=1e-7,
    )
    assert read_bag(path, odom_topic=None, laser_pose=(0, 0, 0))[0].laser_pose == (0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match=r"no /tf_static chain from base frame 'base' to laser frame 'laser'"):
        read_bag(path, odom_topic=None, base_frame="base")


def test_write_bag_refuses_bad_input(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"must end in \.bag"):
        write_bag(tmp_path / "run", frames(2), version=1)
    mixed = frames(2)
    mixed[1] = ScanFrame(mixed[1].time, mixed[1].ranges, -1.0, 0.1, 0.1, 10.0, laser_pose=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="share one laser_pose"):
        write_bag(tmp_path / "run.bag", mixed, version=1)
    write_bag(tmp_path / "run.bag", frames(2), version=1)
    with pytest.raises(ValueError, match="exists already"):
        write_bag(tmp_path / "run.bag", frames(2), version=1)


def test_import_without_rosbags_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    monkeypatch.delitem(sys.modules, "planicp.io.bag")
    with pytest.raises(ImportError, match=r"pip install planicp\[ros\]"):
        importlib.import_module("planicp.io.bag")
