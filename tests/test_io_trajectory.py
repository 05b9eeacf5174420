"""TUM and KITTI files: our own round trip and evo's file interface reading what we write."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from planicp.io import ScanFrame, ScanLog, interpolate_poses, read_kitti, read_tum, write_kitti, write_tum


def trajectory() -> tuple[np.ndarray, np.ndarray]:
    k = np.arange(50)
    times = 1234.5 + 0.1 * k + 1e-7 * k**2
    yaw = np.angle(np.exp(1j * (0.4 * k - 3.0)))  # passes through +-pi several times
    poses = np.column_stack([0.3 * k + 1e-9, -0.2 * k + np.sin(k), yaw])
    return times, poses


def test_tum_round_trip_is_exact(tmp_path: Path) -> None:
    times, poses = trajectory()
    path = write_tum(tmp_path / "est.txt", times, poses, comment="T_map_base from planicp")
    text = path.read_text().splitlines()
    assert text[:2] == ["# timestamp tx ty tz qx qy qz qw", "# T_map_base from planicp"]
    assert len(text[2].split()) == 8
    t2, p2 = read_tum(path)
    np.testing.assert_array_equal(t2, times)
    np.testing.assert_array_equal(p2[:, :2], poses[:, :2])
    np.testing.assert_allclose(np.angle(np.exp(1j * (p2[:, 2] - poses[:, 2]))), 0.0, atol=1e-12)


def test_evo_reads_our_tum_file(tmp_path: Path) -> None:
    file_interface = pytest.importorskip("evo.tools.file_interface")
    times, poses = trajectory()
    traj = file_interface.read_tum_trajectory_file(str(write_tum(tmp_path / "est.txt", times, poses)))
    np.testing.assert_allclose(traj.timestamps, times, rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.positions_xyz[:, :2], poses[:, :2], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(traj.positions_xyz[:, 2], 0.0)
    w, x, y, z = traj.orientations_quat_wxyz.T
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y**2 + z**2))
    np.testing.assert_allclose(np.angle(np.exp(1j * (yaw - poses[:, 2]))), 0.0, atol=1e-9)


def test_evo_reads_our_kitti_file(tmp_path: Path) -> None:
    file_interface = pytest.importorskip("evo.tools.file_interface")
    _, poses = trajectory()
    path = write_kitti(tmp_path / "est.kitti", poses)
    assert all(len(line.split()) == 12 for line in path.read_text().splitlines())
    traj = file_interface.read_kitti_poses_file(str(path))
    se3 = np.array(traj.poses_se3)
    np.testing.assert_allclose(se3[:, :2, 3], poses[:, :2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        np.angle(np.exp(1j * (np.arctan2(se3[:, 1, 0], se3[:, 0, 0]) - poses[:, 2]))), 0.0, atol=1e-9
    )
    np.testing.assert_array_equal(se3[:, 2, 3], 0.0)
    np.testing.assert_array_equal(read_kitti(path)[:, :2], poses[:, :2])


def test_writers_refuse_bad_input(tmp_path: Path) -> None:
    times, poses = trajectory()
    with pytest.raises(ValueError, match="strictly increasing"):
        write_tum(tmp_path / "a.txt", times[::-1], poses)
    with pytest.raises(ValueError, match=r"shape \(K, 3\)"):
        write_tum(tmp_path / "a.txt", times, poses[:, :2])
    bad = poses.copy()
    bad[7, 1] = np.nan
    with pytest.raises(ValueError, match="row 7"):
        write_kitti(tmp_path / "a.txt", bad)
    path = tmp_path / "bad.txt"
    path.write_text("# c\n1 2 3 0 0 0 0 1\n2 2 3 0.5 0 0 0 1\n")
    with pytest.raises(ValueError, match=r"bad.txt, line 3: not a planar pose"):
        read_tum(path)
    path.write_text("1 2 3 0 0 0 0\n")
    with pytest.raises(ValueError, match=r"line 1: a TUM line needs 8 numbers, got 7"):
        read_tum(path)


def test_interpolation_edges() -> None:
    t = np.array([0.0, 1.0, 1.0, 3.0])
    p = np.array([[0, 0, 0.0], [1, 0, 0.5], [2, 0, 0.5], [4, 2, -0.5]])
    out, inside = interpolate_poses(t, p, np.array([-0.1, 0.0, 0.5, 1.0, 2.0, 3.0, 3.1]))
    assert inside.tolist() == [False, True, True, True, True, True, False]
    assert np.isnan(out[[0, 6]]).all()
    np.testing.assert_allclose(out[1:6], [[0, 0, 0], [0.5, 0, 0.25], [2, 0, 0.5], [3, 1, 0], [4, 2, -0.5]], atol=1e-12)
    single, inside = interpolate_poses(np.array([2.0]), np.array([[1.0, 2.0, 3.0]]), np.array([2.0, 2.5]))
    assert inside.tolist() == [True, False] and single[0].tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match="non-decreasing"):
        interpolate_poses(np.array([1.0, 0.0]), np.zeros((2, 3)), np.array([0.5]))


def test_scan_frame_and_log_containers() -> None:
    frame = ScanFrame(1.0, [1.0, np.inf, 2.0, -np.inf], 0.0, math.pi / 2, 0.0, 10.0, laser_pose=(1.0, 0.0, math.pi))
    np.testing.assert_allclose(frame.points(), [[0.0, 0.0], [3.0, 0.0]], atol=1e-12)
    with pytest.raises(ValueError):
        frame.ranges[0] = 5.0  # frozen means frozen
    with pytest.raises(ValueError, match="range_min < range_max"):
        ScanFrame(1.0, [1.0], 0.0, 0.1, 5.0, 1.0)
    log = ScanLog(Path("x.log"), [frame, ScanFrame(2.0, [1.0], 0.0, 0.1, 0.0, 5.0, reference=(1, 2, 3))])
    assert len(log) == 2 and log[1].time == 2.0 and [f.time for f in log] == [1.0, 2.0]
    refs = log.reference_poses()
    assert np.isnan(refs[0]).all() and refs[1].tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match="x.log carries no odometry"):
        log.odometry_at_scans()
