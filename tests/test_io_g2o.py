"""g2o reader on a real excerpt of MIT Killian Court (rtb-data, MIT) and on broken input."""

from __future__ import annotations

import math
import zipfile
from pathlib import Path

import numpy as np
import pytest

from planicp.io import open_log, read_g2o, read_g2o_graph
from planicp.se2 import between

KILLIAN = Path(__file__).parent / "data" / "killian-excerpt.g2o"


def raw_records(kind: str) -> list[list[str]]:
    return [line.split() for line in KILLIAN.read_text().splitlines() if line.startswith(kind + " ")]


def test_killian_scans_and_odometry() -> None:
    log = read_g2o(KILLIAN)
    vertices = raw_records("VERTEX_SE2")
    lasers = raw_records("ROBOTLASER1")
    assert len(log) == len(vertices) == len(lasers) == 60
    assert log.skipped == {} and log.bad_lines == []  # edges are read (into the graph), not skipped
    first = log[0]
    assert first.time == 1031745824.658
    assert first.odometry == (1.96, 37.867, -2.01239)
    assert first.reference is None and not log.has_reference
    assert (first.angle_min, first.angle_increment, first.range_max) == (-1.570796, 0.017453, 50.0)
    assert first.beams == 180
    assert first.laser_pose == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)  # laser and robot pose coincide
    np.testing.assert_array_equal(log.odometry_at_scans(), [[float(v) for v in f[2:5]] for f in vertices])
    # "No return": every reading at the 50 m maximum, counted straight from the text.
    readings = np.array([[float(v) for v in f[9:189]] for f in lasers])
    ranges = np.stack([frame.ranges for frame in log])
    assert np.array_equal(np.isposinf(ranges), readings >= 50.0)
    assert np.array_equal(ranges[readings < 50.0], readings[readings < 50.0])
    assert np.all(np.diff(log.times()) > 0)


def test_killian_vertices_are_chained_odometry() -> None:
    graph = read_g2o_graph(KILLIAN)
    assert graph.poses.shape == (60, 3) and graph.edges.shape == (59, 2)
    # The file lists the sequential edges out of order (0-1, 1-2, 4-5, 3-4, ...): all 59 links are there.
    assert sorted(map(tuple, graph.edges.tolist())) == [(k, k + 1) for k in range(59)]
    np.testing.assert_array_equal(graph.information[0], [[500, 0, 0], [0, 500, 0], [0, 0, 5000]])
    # The vertices are wheel odometry; each sequential edge measures nearly the same motion (to a few mm).
    motion = np.array([between(tuple(graph.poses[i]), tuple(graph.poses[j])) for i, j in graph.edges])
    gap = np.hypot(*(motion[:, :2] - graph.measurements[:, :2]).T)
    assert gap.max() < 0.02 and np.median(gap) < 0.003
    assert np.abs(motion[:, 2] - graph.measurements[:, 2]).max() < 0.01
    assert np.hypot(*graph.measurements[:, :2].T).sum() == pytest.approx(32.998, abs=1e-3)  # metres (awk over the file)


def test_zipped_graph_as_rtb_data_ships_it(tmp_path: Path) -> None:
    packed = tmp_path / "killian.g2o.zip"
    with zipfile.ZipFile(packed, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.write(KILLIAN, "killian.g2o")
        archive.writestr("__MACOSX/._killian.g2o", b"\x00\x05")
    log = read_g2o(packed)
    assert len(log) == 60
    np.testing.assert_array_equal(log[-1].ranges, read_g2o(KILLIAN)[-1].ranges)
    assert len(open_log(packed)) == 60


def test_zip_with_two_files_is_refused(tmp_path: Path) -> None:
    packed = tmp_path / "two.g2o.zip"
    with zipfile.ZipFile(packed, "w") as archive:
        archive.writestr("a.g2o", "VERTEX_SE2 0 0 0 0\n")
        archive.writestr("b.g2o", "VERTEX_SE2 0 0 0 0\n")
    with pytest.raises(ValueError, match=r"exactly one file, found \['a.g2o', 'b.g2o'\]"):
        read_g2o(packed)


def test_broken_graph_lines(tmp_path: Path) -> None:
    lines = KILLIAN.read_text().splitlines()[:12]  # 6 vertices with their scans
    lines.insert(0, lines[1])  # a scan before any vertex
    lines[5] = "VERTEX_SE2 2 1.0 nan 0.0"  # replaces vertex 1: its scan belongs to no vertex read
    lines.append("EDGE_SE2 0 1 0.5 0.0")
    lines.append("FIX 0")
    path = tmp_path / "broken.g2o"
    path.write_text("\n".join(lines) + "\n")
    with pytest.warns(UserWarning, match=r"skipped 4 malformed"):
        log = read_g2o(path)
    reasons = {b.line: b.reason for b in log.bad_lines}
    assert reasons[1] == "a ROBOTLASER1 line needs a VERTEX_SE2 before it"
    assert reasons[6].startswith("the vertex pose must be finite")
    assert reasons[7] == "the VERTEX_SE2 line before it is malformed: the scan has no pose"
    assert reasons[14].startswith("truncated: EDGE_SE2")
    assert log.skipped == {
        "ROBOTLASER1 (malformed)": 2,
        "VERTEX_SE2 (malformed)": 1,
        "EDGE_SE2 (malformed)": 1,
        "FIX": 1,
    }
    assert len(log) == 5
    with pytest.raises(ValueError, match=rf"{path}, line 1: bad ROBOTLASER1 line"):
        read_g2o(path, errors="raise")


def test_file_without_vertices(tmp_path: Path) -> None:
    path = tmp_path / "empty.g2o"
    path.write_text("# nothing\n")
    with pytest.raises(ValueError, match="no VERTEX_SE2 line"):
        read_g2o(path)


def test_angles_of_a_killian_scan() -> None:
    frame = read_g2o(KILLIAN)[0]
    pts = frame.points()
    kept = np.flatnonzero(np.isfinite(frame.ranges))
    angles = np.arctan2(pts[:, 1], pts[:, 0])
    np.testing.assert_allclose(angles, -1.570796 + 0.017453 * kept, atol=1e-9)
    assert math.degrees(angles[-1]) == pytest.approx(89.0, abs=5e-3)  # 180 beams: -90 .. +89 degrees
