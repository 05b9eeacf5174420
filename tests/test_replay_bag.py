"""`planicp replay --out-bag`: a simulated drive as a ROS 2 bag (sqlite3 or MCAP) through the replay,
its estimates written back as a ROS 2 bag, read back with rosbags and checked against the replay's
own outputs, the odometry and the plan."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from planicp.cli import main as cli_main  # noqa: E402
from planicp.evaluation.log_replay import TrackedLog, track_log  # noqa: E402
from planicp.io import read_tum  # noqa: E402
from planicp.io.bag import read_bag, write_bag  # noqa: E402
from planicp.plans.default_plan import default_plan_path, load_default_plan  # noqa: E402
from planicp.ros.estimate_bag import write_estimate_bag  # noqa: E402
from planicp.ros.message_layout import FLAT_INDICES, covariance_from_6x6  # noqa: E402
from planicp.se2 import compose, quaternion_to_yaw, wrap_angle  # noqa: E402
from planicp.sim.experiment import ExperimentConfig, Recording, run_experiment  # noqa: E402

Storage = Literal["sqlite3", "mcap"]
EOG_RESOLUTION = 0.1


@pytest.fixture(scope="module")
def recording() -> Recording:
    recording, _ = run_experiment(load_default_plan(), ExperimentConfig(duration_s=8.0, seed=3))
    return recording


def _messages(bag: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message of `bag` by topic: (receive time in ns, deserialised message)."""
    out: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        for conn, ns, raw in reader.messages():
            out.setdefault(conn.topic, []).append((ns, reader.deserialize(raw, conn.msgtype)))
    return out


def _stamp(msg: Any) -> float:
    return int(msg.header.stamp.sec) + int(msg.header.stamp.nanosec) * 1e-9


def _pose(p: Any) -> tuple[float, float, float]:
    q = p.orientation if hasattr(p, "orientation") else p.rotation
    t = p.position if hasattr(p, "position") else p.translation
    assert t.z == 0.0 and q.x == 0.0 and q.y == 0.0
    return float(t.x), float(t.y), quaternion_to_yaw(q.x, q.y, q.z, q.w)


def _replay(recording: Recording, tmp_path: Path, storage: Storage) -> tuple[Path, Path, Path, list[str]]:
    """The input bag, the replay's output folder and bag, and the command's arguments."""
    source = write_bag(tmp_path / "drive", recording.scan_frames(), version=2, storage=storage)
    out, out_bag = tmp_path / "replay", tmp_path / "estimates"
    x, y, yaw = recording.truth[0]
    args = [
        "replay",
        str(source),
        "--plan",
        str(default_plan_path()),
        "--initial-pose",
        str(x),
        str(y),
        str(yaw),
        "--eog-resolution",
        str(EOG_RESOLUTION),
        "--out",
        str(out),
        "--out-bag",
        str(out_bag),
        "--bag-storage",
        storage,
    ]
    return source, out, out_bag, args


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_replay_writes_its_estimates_as_a_ros2_bag(
    recording: Recording, tmp_path: Path, storage: Storage, capsys: pytest.CaptureFixture[str]
) -> None:
    source, out, out_bag, args = _replay(recording, tmp_path, storage)
    # The input bag is in the storage asked for, and the replay reads it.
    assert f"storage_identifier: {storage}" in (source / "metadata.yaml").read_text()
    assert cli_main(args) == 0, capsys.readouterr().err
    assert f"wrote {out_bag}" in capsys.readouterr().out
    meta = (out_bag / "metadata.yaml").read_text()
    assert f"storage_identifier: {storage}" in meta
    assert any(p.suffix == (".mcap" if storage == "mcap" else ".db3") for p in out_bag.iterdir())
    got = _messages(out_bag)
    assert set(got) == {"/amcl_pose", "/tf", "/tf_static", "/map", "/eog"}

    # One pose per scan, stamped with the scan's time, in the map frame, equal to trajectory.tum.
    log = read_bag(source)
    times, poses = read_tum(out / "trajectory.tum")
    amcl = got["/amcl_pose"]
    assert len(amcl) == len(log) == len(times) == len(recording.times)
    for k, (ns, msg) in enumerate(amcl):
        assert msg.header.frame_id == "map"
        assert _stamp(msg) == pytest.approx(log[k].time, abs=1e-9) and ns == round(log[k].time * 1e9)
        assert _stamp(msg) == pytest.approx(times[k], abs=1e-6)
        x, y, yaw = _pose(msg.pose.pose)
        assert (x, y) == pytest.approx((poses[k, 0], poses[k, 1]), abs=1e-6)
        assert abs(wrap_angle(yaw - poses[k, 2])) < 1e-6

    # The covariance in the 6x6 layout: (x, y, yaw) at rows/columns 0, 1, 5, the rest 0; it is the
    # replay's own (the same replay in Python), symmetric and positive definite.
    plan = load_default_plan()
    tracked = track_log(log, plan, initial_pose=recording.truth[0])
    np.testing.assert_allclose(tracked.estimate[:, :2], poses[:, :2], atol=1e-6)
    for k, (_, msg) in enumerate(amcl):
        flat = np.asarray(msg.pose.covariance)
        assert flat.shape == (36,)
        others = np.ones(36, dtype=bool)
        others[list(FLAT_INDICES)] = False
        assert not flat[others].any()
        cov = covariance_from_6x6(flat)
        np.testing.assert_allclose(cov, tracked.covariance[k], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(cov, cov.T, atol=1e-15)
        assert np.linalg.eigvalsh(cov).min() > 0.0

    # /tf per scan: map -> odom, composed with the log's odometry, is the pose; odom -> base is that
    # odometry. The laser mount is on /tf_static.
    tf = got["/tf"]
    assert len(tf) == len(log)
    for k, (_, msg) in enumerate(tf):
        map_odom, odom_base = msg.transforms
        assert (map_odom.header.frame_id, map_odom.child_frame_id) == ("map", "odom")
        assert (odom_base.header.frame_id, odom_base.child_frame_id) == ("odom", "base_link")
        assert _stamp(map_odom) == _stamp(amcl[k][1])
        odometry = log[k].odometry
        assert odometry is not None
        assert _pose(odom_base.transform) == pytest.approx(odometry, abs=1e-9)
        composed = compose(_pose(map_odom.transform), odometry)
        assert composed[:2] == pytest.approx(poses[k, :2], abs=1e-6)
        assert abs(wrap_angle(composed[2] - poses[k, 2])) < 1e-6
    ((_, static),) = got["/tf_static"]
    (mount,) = static.transforms
    assert (mount.header.frame_id, mount.child_frame_id) == ("base_link", "laser")
    assert _pose(mount.transform) == pytest.approx(log[0].laser_pose, abs=1e-9)

    # The plan on /map at the first scan: its wall cells lie on the plan's walls (within the walls'
    # thickness of the wall points, which sit on the walls' faces) and cover every wall point.
    ((map_ns, plan_msg),) = got["/map"]
    assert map_ns == amcl[0][0] and plan_msg.header.frame_id == "map"
    assert len(_occupied_centres(plan_msg)) > 100
    assert _distances(_occupied_centres(plan_msg), plan.points).max() < 0.2
    _check_rows_from_the_origin(plan_msg, plan.points)

    # The EOG on /eog at the last scan: the grid eog.pgm holds (row 0 at the origin: the PGM's last
    # row), -1/0/100, every plan wall point in an occupied cell, and its occupied cells on the walls
    # but for the few the scans saw on the furniture.
    ((eog_ns, eog),) = got["/eog"]
    assert eog_ns == amcl[-1][0] and eog.header.frame_id == "map"
    info = eog.info
    assert info.resolution == pytest.approx(EOG_RESOLUTION)
    data = np.asarray(eog.data, dtype=np.int8).reshape(info.height, info.width)
    assert set(np.unique(data).tolist()) == {-1, 0, 100}
    _check_against_map_server_files(out / "eog.yaml", data, info)
    _check_rows_from_the_origin(eog, plan.points)
    near = _distances(_occupied_centres(eog), plan.points) < 1.5 * EOG_RESOLUTION
    assert near.mean() > 0.95
    # Free space where the robot drove (its cell is seen free by every scan around it).
    cells = np.floor((poses[:, :2] - [info.origin.position.x, info.origin.position.y]) / info.resolution).astype(int)
    assert (data[cells[:, 1], cells[:, 0]] == 0).mean() > 0.9


def _occupied_centres(msg: Any) -> np.ndarray:
    info = msg.info
    data = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
    rows, cols = np.nonzero(data == 100)
    yaw = quaternion_to_yaw(
        info.origin.orientation.x, info.origin.orientation.y, info.origin.orientation.z, info.origin.orientation.w
    )
    local = np.column_stack([(cols + 0.5) * info.resolution, (rows + 0.5) * info.resolution])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.asarray(local @ np.array([[c, s], [-s, c]]) + [info.origin.position.x, info.origin.position.y])


def _check_rows_from_the_origin(msg: Any, points: np.ndarray) -> None:
    """The plan's wall points (on the walls' faces, so on cell borders) touch occupied cells, and would
    not were the rows the other way up."""
    info = msg.info
    data = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
    cols = np.floor((points[:, 0] - info.origin.position.x) / info.resolution).astype(int)
    rows = np.floor((points[:, 1] - info.origin.position.y) / info.resolution).astype(int)

    def touching(grid: np.ndarray) -> float:
        occupied = np.pad(grid == 100, 1)
        near = np.zeros(len(points), dtype=bool)
        for dr in (0, 1, 2):
            for dc in (0, 1, 2):
                near |= occupied[rows + dr, cols + dc]
        return float(near.mean())

    assert touching(data) == 1.0
    assert touching(data[::-1]) < 0.8


def _distances(points: np.ndarray, walls: np.ndarray) -> np.ndarray:
    from scipy.spatial import cKDTree

    return np.asarray(cKDTree(walls).query(points)[0])


def _check_against_map_server_files(yaml_path: Path, data: np.ndarray, info: Any) -> None:
    import cv2
    import yaml

    meta = yaml.safe_load(yaml_path.read_text())
    assert meta["resolution"] == pytest.approx(info.resolution)
    assert meta["origin"][:2] == pytest.approx([info.origin.position.x, info.origin.position.y])
    image = cv2.imread(str(yaml_path.parent / meta["image"]), cv2.IMREAD_UNCHANGED)
    assert image is not None
    expected = np.full(image.shape, -1, dtype=np.int8)
    expected[image == 254] = 0
    expected[image == 0] = 100
    np.testing.assert_array_equal(data, expected[::-1])


def test_an_existing_bag_is_not_written_over(
    recording: Recording, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source, out, out_bag, args = _replay(recording, tmp_path, "sqlite3")
    out_bag.mkdir()
    (out_bag / "keep.txt").write_text("mine")
    assert cli_main(args) == 2
    err = capsys.readouterr().err
    assert f"{out_bag} exists already" in err and "--out-bag" in err
    assert [p.name for p in out_bag.iterdir()] == ["keep.txt"]
    assert not out.exists()  # refused before the replay
    # The input bag itself is an existing path too.
    args[args.index("--out-bag") + 1] = str(source)
    assert cli_main(args) == 2
    assert "exists already" in capsys.readouterr().err


def test_without_rosbags_the_error_names_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    for name in ("planicp.io.bag", "planicp.ros.estimate_bag"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    args = ["replay", str(tmp_path / "run.log"), "--plan", str(default_plan_path()), "--out", str(tmp_path / "o")]
    assert cli_main([*args, "--out-bag", str(tmp_path / "bag")]) == 2
    assert "pip install planicp[ros]" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_write_estimate_bag_refuses_what_it_cannot_write(recording: Recording, tmp_path: Path) -> None:
    log = recording.scan_frames()[:3]
    tracked = track_log(log, load_default_plan(), initial_pose=recording.truth[0])
    with pytest.raises(ValueError, match="storage must be one of sqlite3, mcap"):
        write_estimate_bag(tmp_path / "a", tracked, storage="zip")  # type: ignore[arg-type]
    bare = TrackedLog(
        tracked.times,
        tracked.estimate,
        tracked.accepted,
        tracked.inlier_ratio,
        tracked.rmse,
        tracked.reasons,
        tracked.odometry,
        None,
        0.0,
    )
    with pytest.raises(ValueError, match="pass the TrackedLog that track_log returns"):
        write_estimate_bag(tmp_path / "b", bare)
    with pytest.raises(ValueError, match="for ROS 2 bags"):
        write_bag(tmp_path / "c.bag", log, version=1, storage="mcap")
    path = write_estimate_bag(tmp_path / "d", tracked)
    assert set(_messages(path)) == {"/amcl_pose", "/tf"}
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_a_rosbags_without_mcap_writing_names_the_upgrade(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import planicp.io.bag as bag

    class OldWriter:  # rosbags' rosbag2 Writer before it took a storage plugin
        def __init__(self, path: Path) -> None:
            self.path = path

    monkeypatch.setattr(bag, "Writer2", OldWriter)
    with pytest.raises(ImportError, match="writes no MCAP bags: pip install -U rosbags"):
        bag.rosbag2_writer(tmp_path / "x", "mcap")
    assert isinstance(bag.rosbag2_writer(tmp_path / "y"), OldWriter)
    with pytest.raises(ValueError, match="storage must be one of sqlite3, mcap"):
        bag.rosbag2_writer(tmp_path / "z", "zip")
