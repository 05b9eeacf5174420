"""CARMEN reader: real line formats, frames of reference, no returns, odometry, broken input."""

from __future__ import annotations

import gzip
import math
import re
from pathlib import Path

import numpy as np
import pytest

import carmen_excerpt as ex
from planicp.io import open_log, read_carmen
from planicp.se2 import transform_points

INTEL = Path(__file__).resolve().parents[2] / "shared" / "data" / "logs" / "intel-corrected.log.gz"


def write(tmp_path: Path, lines: list[str], name: str = "excerpt.log") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture()
def excerpt(tmp_path: Path) -> Path:
    return write(tmp_path, ex.log_lines())


def test_excerpt_is_read_whole(excerpt: Path) -> None:
    log = read_carmen(excerpt)
    assert len(log) == ex.SCANS
    assert log.skipped == {"NEFF": ex.SCANS}
    assert log.bad_lines == []
    assert log.params["robot_frontlaser_offset"] == "0.25"
    assert log.odometry_poses.shape == (ex.SCANS * ex.ODOM_PER_SCAN + 1, 3)
    np.testing.assert_allclose(log.times(), 1.0 + ex.SCAN_DT * np.arange(ex.SCANS), atol=1e-9)
    frame = log[3]
    assert frame.beams == 180
    assert frame.angle_min == pytest.approx(-math.pi / 2)
    assert frame.angle_increment == pytest.approx(math.radians(1.0))
    assert frame.laser_pose == pytest.approx(ex.MOUNT)


def test_reference_pose_is_the_base_not_the_laser(excerpt: Path) -> None:
    log = read_carmen(excerpt)
    ref = log.reference_poses()
    truth = np.array([ex.true_pose(t) for t in log.times()])
    np.testing.assert_allclose(ref, truth, atol=2e-6)
    # The laser pose itself is 0.25 m ahead: taking it as the base would be off by the mount.
    laser = np.array([ex.laser_world(t) for t in log.times()])
    assert np.all(np.hypot(*(laser[:, :2] - ref[:, :2]).T) > 0.25)


def test_hand_computed_reference_with_laser_offset(tmp_path: Path) -> None:
    # Laser at (1, 2) facing +y, mounted 0.5 m ahead of the base: the base is at (1, 1.5), facing +y.
    ranges = " ".join(["2.0"] * 181)
    path = write(
        tmp_path,
        [
            "PARAM robot_frontlaser_offset 0.5 nohost 0",
            f"FLASER 181 {ranges} 1.0 2.0 1.5707963267948966 7 8 0.1 12.5 host 12.5",
        ],
    )
    frame = read_carmen(path)[0]
    assert frame.reference == pytest.approx((1.0, 1.5, math.pi / 2), abs=1e-12)
    assert frame.odometry == (7.0, 8.0, 0.1)  # no ODOM lines: the laser line's own odometry
    assert frame.time == 12.5
    # 181 beams: -90 to +90 degrees, 1 degree apart; beam 90 looks straight ahead, 2 m past the mount.
    assert frame.angle_increment == pytest.approx(math.pi / 180)
    np.testing.assert_allclose(frame.points()[90], [2.5, 0.0], atol=1e-12)


def test_laser_pose_argument_overrides_params(tmp_path: Path) -> None:
    ranges = " ".join(["2.0"] * 180)
    path = write(
        tmp_path, ["PARAM robot_frontlaser_offset 0.5 nohost 0", f"FLASER 180 {ranges} 1.0 2.0 0.0 0 0 0 3.0 host 3.0"]
    )
    frame = read_carmen(path, laser_pose=(0.0, 0.0, 0.0))[0]
    assert frame.reference == pytest.approx((1.0, 2.0, 0.0))
    assert frame.laser_pose == (0.0, 0.0, 0.0)


def test_scans_at_reference_poses_land_on_the_walls(excerpt: Path) -> None:
    log = read_carmen(excerpt)
    for frame in log:
        assert frame.reference is not None
        world = transform_points(frame.reference, frame.points())
        assert world.shape[0] == 180 - len(range(0, 180, ex.NO_RETURN_EVERY))
        assert distance_to_walls_max(world) < 2e-4


def distance_to_walls_max(points: np.ndarray) -> float:
    return float(ex.distance_to_walls(points).max())


def test_no_returns_become_inf(excerpt: Path) -> None:
    frame = read_carmen(excerpt)[0]
    no_return = np.arange(0, 180, ex.NO_RETURN_EVERY)
    assert np.all(np.isposinf(frame.ranges[no_return]))
    assert np.isfinite(np.delete(frame.ranges, no_return)).all()
    assert frame.range_max == 80.0


def test_max_range_from_param_and_argument(tmp_path: Path) -> None:
    ranges = " ".join(["25.0", "5.0", "0", "-1"] * 45)
    lines = ["PARAM robot_front_laser_max 20.0 nohost 0", f"FLASER 180 {ranges} 0 0 0 0 0 0 1.0 h 1.0"]
    frame = read_carmen(write(tmp_path, lines))[0]
    assert frame.range_max == 20.0
    assert np.isposinf(frame.ranges[0::4]).all() and (frame.ranges[1::4] == 5.0).all()
    assert np.isnan(frame.ranges[2::4]).all() and np.isnan(frame.ranges[3::4]).all()
    assert frame.points().shape == (45, 2)
    wider = read_carmen(write(tmp_path, lines, "b.log"), max_range=30.0)[0]
    assert (wider.ranges[0::4] == 25.0).all()


def test_odometry_is_the_odom_stream_at_scan_time(excerpt: Path) -> None:
    log = read_carmen(excerpt)
    odo = log.odometry_at_scans()
    expected = np.array([ex.odom_pose(t) for t in log.times()])
    np.testing.assert_allclose(odo, expected, atol=2e-6)
    # Not the odometry printed on the laser line at a neighbouring time: that differs by ~0.1 m.
    assert not np.allclose(odo[:, 0], expected[:, 0] + 0.1, atol=1e-2)


def test_odometry_interpolation_wraps_the_angle(tmp_path: Path) -> None:
    ranges = " ".join(["2.0"] * 180)
    lines = [
        "ODOM 0 0 3.1 0 0 0 10.0 h 10.0",
        "ODOM 1 2 -3.1 0 0 0 11.0 h 11.0",
        f"FLASER 180 {ranges} 0 0 0 0 0 0 10.25 h 10.25",
        f"FLASER 180 {ranges} 0 0 0 0 0 0 10.5 h 10.5",
        f"FLASER 180 {ranges} 0 0 0 0 0 0 12.0 h 12.0",
    ]
    log = read_carmen(write(tmp_path, lines))
    a, b, outside = (f.odometry for f in log)
    step = 2 * math.pi - 6.2  # the short way from 3.1 to -3.1 goes through pi
    assert a == pytest.approx((0.25, 0.5, 3.1 + 0.25 * step), abs=1e-12)
    assert b is not None and abs(b[2]) == pytest.approx(math.pi, abs=1e-12) and b[:2] == pytest.approx((0.5, 1.0))
    assert outside is None  # after the last ODOM line: no odometry rather than an extrapolation


def test_all_zero_odom_lines_are_placeholders(tmp_path: Path) -> None:
    ranges = " ".join(["2.0"] * 180)
    lines = [
        "ODOM 0 0 0 0 0 0 0.5 h 0.5",
        "ODOM 0 0 0 0 0 0 1.5 h 1.5",
        f"FLASER 180 {ranges} 4 5 0.2 1 2 0.3 1.0 h 1.0",
    ]
    log = read_carmen(write(tmp_path, lines))
    assert log[0].odometry == (1.0, 2.0, 0.3)
    assert log.skipped["ODOM (all-zero placeholders)"] == 2
    np.testing.assert_array_equal(log.odometry_poses, [[1.0, 2.0, 0.3]])


def broken_lines() -> tuple[list[str], dict[int, str]]:
    """The excerpt with damaged lines; returns the lines and {line number: expected reason pattern}."""
    lines = ex.log_lines()
    flaser_rows = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    damage = {}
    i = flaser_rows[2]
    lines[i] = lines[i][: len(lines[i]) // 2]  # truncated mid-ranges
    damage[i + 1] = "truncated"
    i = flaser_rows[5]
    lines[i] = lines[i] + " extra"
    damage[i + 1] = "wrong field count"
    i = flaser_rows[7]
    fields = lines[i].split()
    fields[40] = "1.2.3"
    lines[i] = " ".join(fields)
    damage[i + 1] = r"field 41 \('1.2.3'\) is not a number"
    i = flaser_rows[9]
    lines[i] = lines[i].replace("FLASER 180", "FLASER 18x0", 1)
    damage[i + 1] = "not a number"
    odom_row = flaser_rows[11] - 1
    lines[odom_row] = "ODOM 1 2"
    damage[odom_row + 1] = "truncated"
    lines.insert(flaser_rows[12] + 1, "GARBAGE 1 2 3")
    lines.append(ex.flaser_line(1.0 + ex.SCANS * ex.SCAN_DT)[:200])  # the log was cut while writing
    damage[len(lines)] = "truncated"
    return lines, damage


def test_bad_lines_are_skipped_counted_and_located(tmp_path: Path) -> None:
    lines, damage = broken_lines()
    path = write(tmp_path, lines)
    with pytest.warns(UserWarning, match=r"skipped 6 malformed line\(s\)"):
        log = read_carmen(path)
    assert len(log) == ex.SCANS - 4  # every intact scan around the bad lines survives
    assert log.skipped["FLASER (malformed)"] == 5
    assert log.skipped["ODOM (malformed)"] == 1
    assert log.skipped["GARBAGE"] == 1
    assert {b.line for b in log.bad_lines} == set(damage)
    for bad in log.bad_lines:
        assert re.search(damage[bad.line], bad.reason), (bad, damage[bad.line])
    # The scans kept are exactly the undamaged ones, still on the walls.
    for frame in log:
        assert frame.reference is not None
        assert distance_to_walls_max(transform_points(frame.reference, frame.points())) < 2e-4


@pytest.mark.parametrize("which", range(6))
def test_strict_mode_names_file_and_line(tmp_path: Path, which: int) -> None:
    lines, damage = broken_lines()
    bad_line = sorted(damage)[which]
    keep = set(damage) - {bad_line}
    # Leave only one damaged line in the file (replace the others by their intact originals).
    good = ex.log_lines()
    good.insert(next(i for i, line in enumerate(lines) if line.startswith("GARBAGE")), "GARBAGE 1 2 3")
    mixed = [lines[i] if i + 1 not in keep else good[i] for i in range(len(good))]
    if bad_line == len(lines):
        mixed.append(lines[-1])
    path = write(tmp_path, mixed)
    expected = rf"{re.escape(str(path))}, line {bad_line}: bad \w+ line: .*{damage[bad_line]}"
    with pytest.raises(ValueError, match=expected):
        read_carmen(path, errors="raise")


def test_gzip_log_reads_like_plain(tmp_path: Path, excerpt: Path) -> None:
    packed = tmp_path / "excerpt.log.gz"
    packed.write_bytes(gzip.compress(excerpt.read_bytes()))
    plain, zipped = read_carmen(excerpt), read_carmen(packed)
    assert len(zipped) == len(plain)
    np.testing.assert_array_equal(zipped.reference_poses(), plain.reference_poses())
    np.testing.assert_array_equal(zipped[-1].ranges, plain[-1].ranges)


def test_truncated_gzip_keeps_the_lines_before(tmp_path: Path, excerpt: Path) -> None:
    data = gzip.compress(excerpt.read_bytes())
    cut = tmp_path / "cut.log.gz"
    cut.write_bytes(data[: len(data) * 2 // 3])
    with pytest.warns(UserWarning, match="compressed data ends early"):
        log = read_carmen(cut)
    assert 5 < len(log) < ex.SCANS
    assert log.skipped["(compressed stream ends early)"] == 1
    np.testing.assert_allclose(log.reference_poses()[0], ex.true_pose(1.0), atol=2e-6)
    with pytest.raises(ValueError, match="compressed data ends early"):
        read_carmen(cut, errors="raise")


def robotlaser_line(
    t: float,
    laser: tuple[float, float, float],
    robot: tuple[float, float, float],
    ranges: list[float],
    max_range: float = 50.0,
) -> str:
    r = " ".join(f"{v}" for v in ranges)
    return (
        f"ROBOTLASER1 0 -1.0 2.0 0.5 {max_range} 0.1 0 {len(ranges)} {r} 2 0.3 0.4 "
        f"{laser[0]} {laser[1]} {laser[2]} {robot[0]} {robot[1]} {robot[2]} 0.1 0.2 0.5 0.3 0 {t} host {t}"
    )


def test_robotlaser1_own_geometry_and_mount(tmp_path: Path) -> None:
    line = robotlaser_line(5.0, (1.0, 1.0, math.pi / 2), (1.0, 0.8, math.pi / 2), [1.0, 2.0, 60.0, 3.0, 4.0])
    ranges = " ".join(["2.0"] * 180)
    path = write(tmp_path, [line, f"FLASER 180 {ranges} 0 0 0 0 0 0 5.0 h 5.0"])
    log = read_carmen(path)
    frame = log[0]
    assert (frame.angle_min, frame.angle_increment, frame.range_max) == (-1.0, 0.5, 50.0)
    assert frame.laser_pose == pytest.approx((0.2, 0.0, 0.0), abs=1e-12)  # 0.2 m ahead of the robot
    assert frame.reference == pytest.approx((1.0, 0.8, math.pi / 2), abs=1e-12)
    assert frame.odometry == pytest.approx((1.0, 0.8, math.pi / 2))
    assert np.isposinf(frame.ranges[2]) and frame.ranges[3] == 3.0
    assert log.skipped == {"FLASER (other laser)": 1}
    flaser = read_carmen(path, laser="FLASER")
    assert flaser[0].beams == 180 and flaser.skipped == {"ROBOTLASER1 (other laser)": 1}


def test_robotlaser1_wrong_remission_count(tmp_path: Path) -> None:
    line = robotlaser_line(5.0, (0, 0, 0), (0, 0, 0), [1.0, 2.0, 3.0]).replace(" 2 0.3 0.4 ", " 3 0.3 0.4 ")
    with pytest.raises(ValueError, match=r"line 1: bad ROBOTLASER1 line: truncated: .*n_rem=3"):
        read_carmen(write(tmp_path, [line]), errors="raise")


def test_log_without_laser_lines(tmp_path: Path) -> None:
    path = write(tmp_path, ["ODOM 1 2 0.1 0 0 0 1.0 h 1.0", "FOO bar"])
    with pytest.raises(ValueError, match=r"no usable FLASER, RLASER or ROBOTLASER1 line.*skipped: FOO: 1"):
        read_carmen(path)
    with pytest.raises(FileNotFoundError, match="log file not found"):
        read_carmen(tmp_path / "missing.log")


def test_open_log_picks_carmen(tmp_path: Path, excerpt: Path) -> None:
    assert len(open_log(excerpt)) == ex.SCANS
    odd_name = tmp_path / "recording.txt"
    odd_name.write_bytes(excerpt.read_bytes())
    assert len(open_log(odd_name)) == ex.SCANS  # recognised by content
    assert len(open_log(excerpt, laser="FLASER")) == ex.SCANS


@pytest.mark.skipif(not INTEL.is_file(), reason="needs ../shared/data/logs/intel-corrected.log.gz")
def test_real_intel_log() -> None:
    log = read_carmen(INTEL)
    assert len(log) == 910
    assert log.skipped == {"NEFF": 910}
    first = log[0]
    assert first.time == 32.9068
    assert first.reference == pytest.approx((0.600266, -0.0320327, -0.354665))
    assert first.beams == 180 and np.isposinf(first.ranges).sum() == 15
    assert log.odometry_poses.shape == (14541, 3)
    assert not np.isnan(log.odometry_at_scans()).any()
    # Consecutive scans at their corrected poses overlap: most points within 5 cm of the previous scan.
    for k in (1, 300, 600, 909):
        a = transform_points(log[k - 1].reference, log[k - 1].points())
        b = transform_points(log[k].reference, log[k].points())
        b = b[np.hypot(*b.T - np.array(log[k].reference[:2])[:, None]) < 8.0]
        nearest = np.sqrt(((b[:, None, :] - a[None, :, :]) ** 2).sum(-1)).min(axis=1)
        assert np.median(nearest) < 0.05, (k, np.median(nearest))
