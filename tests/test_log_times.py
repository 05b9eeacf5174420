"""Timestamps as real logs have them: coarse, all equal, out of order (`planicp.io.log_times`)."""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import carmen_excerpt as ex
from planicp.cli import main as cli_main
from planicp.io import DEFAULT_SCAN_PERIOD, read_carmen, repair_times
from planicp.io.log_times import late_copies


def test_increasing_stamps_are_kept_exactly() -> None:
    t = np.array([1.0, 1.2, 1.45, 2.0])
    out, repair = repair_times(t)
    np.testing.assert_array_equal(out, t)
    assert repair.fallback == "none" and repair.message == ""


def test_coarse_stamps_give_the_period_between_their_changes() -> None:
    # A clock printed to 10 s (six significant digits of a UNIX time), scans every 2.5 s from 3 s
    # past a tick: the stamps tick over before records 3 and 7.
    true = 1.10287e9 + 3.0 + 2.5 * np.arange(10)
    t = np.floor(true / 10.0) * 10.0
    out, repair = repair_times(t)
    assert repair.fallback == "coarse" and repair.repeated == 7
    np.testing.assert_allclose(np.diff(out), 2.5)
    assert np.max(np.abs(out - true)) < 2.5  # within one scan period of the truth
    assert "7 of 10 timestamps repeat" in repair.message and "2.5 s apart" in repair.message
    # A clock that ticks over once says nothing of the period.
    once, repair = repair_times(np.array([10.0, 10.0, 20.0, 20.0]), nominal_period=0.25)
    np.testing.assert_allclose(np.diff(once), 0.25)


def test_all_equal_stamps_take_the_nominal_period() -> None:
    out, repair = repair_times(np.zeros(5), nominal_period=0.1)
    assert repair.fallback == "missing"
    np.testing.assert_allclose(out, 0.1 * np.arange(5))
    assert repair_times(np.zeros(3))[0][1] == pytest.approx(DEFAULT_SCAN_PERIOD)


def test_a_stamp_going_back_is_replaced_and_the_record_kept() -> None:
    t = np.arange(60, dtype=np.float64) * 0.2
    t[17] = 1.0  # a glitched stamp
    t[59] = 0.5  # and one on the last record
    out, repair = repair_times(t)
    assert repair.out_of_order == 2
    assert out[17] == pytest.approx(3.4) and out[59] == pytest.approx(11.8)
    np.testing.assert_allclose(np.delete(out, [17, 59]), np.delete(0.2 * np.arange(60), [17, 59]))
    assert repair.fallback == "none" and "earlier than the one before replaced" in repair.message


def test_stamps_mostly_out_of_order_are_replaced() -> None:
    t = np.array([5.0, 1.0, 4.0, 2.0, 3.0, 0.5])
    out, repair = repair_times(t, nominal_period=0.5)
    assert repair.fallback == "disordered"
    np.testing.assert_allclose(out, 5.0 + 0.5 * np.arange(6))


def test_bad_arguments_are_refused_with_the_reason() -> None:
    with pytest.raises(ValueError, match="nominal_period must be a positive number"):
        repair_times(np.zeros(3), nominal_period=0.0)
    with pytest.raises(ValueError, match="timestamps must be finite"):
        repair_times(np.array([0.0, np.nan]))


def _coarse_log(tmp_path: Path, slower: float) -> Path:
    """The reader-test excerpt with its stamps printed as a UNIX time with 6 significant digits (a
    clock ticking over every 10,000 s), the log's time running `slower` times as slow."""

    def coarse(match: re.Match[str]) -> str:
        return f"{1.10287e9 + float(match.group(0)) * slower:.6g}"

    lines = []
    for line in ex.log_lines():
        fields = line.split()
        if fields and fields[0] in ("FLASER", "ODOM"):
            fields[-3] = coarse(re.match(r".*", fields[-3]))  # type: ignore[arg-type]
            fields[-1] = coarse(re.match(r".*", fields[-1]))  # type: ignore[arg-type]
        lines.append(" ".join(fields))
    path = tmp_path / "coarse.log"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_reader_repairs_coarse_stamps_with_a_warning(tmp_path: Path) -> None:
    path = _coarse_log(tmp_path, 1e4)  # scans 2,000 s apart: the clock ticks over four times
    with pytest.warns(UserWarning, match="timestamps repeat the one before"):
        log = read_carmen(path)
    assert len(log) == ex.SCANS and log.time_repair is not None and log.time_repair.fallback == "coarse"
    np.testing.assert_allclose(np.diff(log.times()), 1e4 * ex.SCAN_DT, rtol=0.15)
    # The ODOM stream cannot be matched to repaired stamps: each line's own odometry is used.
    assert log.skipped["ODOM (scan timestamps repaired: the laser lines' odometry is used)"] > 0
    np.testing.assert_allclose(log[5].odometry, ex.odom_pose(1.0 + 5 * ex.SCAN_DT), atol=1e-5)


def test_reader_keeps_a_line_whose_stamp_goes_back(tmp_path: Path) -> None:
    lines = ex.log_lines()
    flaser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    fields = lines[flaser[20]].split()
    fields[-1] = fields[-3] = "0.5"  # earlier than every scan before it
    lines[flaser[20]] = " ".join(fields)
    path = tmp_path / "disordered.log"
    path.write_text("\n".join(lines) + "\n")
    with pytest.warns(UserWarning, match="1 timestamp"):
        log = read_carmen(path)
    assert len(log) == ex.SCANS and log.time_repair is not None and log.time_repair.out_of_order == 1
    assert log[20].time == pytest.approx(1.0 + 20 * ex.SCAN_DT)
    # Odometry from the ODOM stream at the repaired stamp, as for every other scan.
    np.testing.assert_allclose(log[20].odometry, ex.odom_pose(1.0 + 20 * ex.SCAN_DT), atol=1e-3)


def test_reader_drops_a_line_written_late(tmp_path: Path) -> None:
    """A FLASER line of scan 5 (its stamp, its pose, no returns) written again after scan 30: before,
    it was re-stamped between scans 30 and 31 and fed to the tracker, whose odometry then went back
    and forth (28 scans 0.40 m off in the probe). It is a late copy: dropped, counted and warned of,
    and the log reads exactly as the clean one."""
    lines = ex.log_lines()
    flaser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    fields = lines[flaser[5]].split()
    fields[2 : 2 + ex.BEAMS] = ["nan"] * ex.BEAMS
    dirty = lines[: flaser[30] + 1] + [" ".join(fields)] + lines[flaser[30] + 1 :]
    clean_path, dirty_path = tmp_path / "clean.log", tmp_path / "late.log"
    clean_path.write_text("\n".join(lines) + "\n")
    dirty_path.write_text("\n".join(dirty) + "\n")
    clean = read_carmen(clean_path)
    with pytest.warns(UserWarning, match=rf"dropped 1 FLASER line\(s\) written late .* line {flaser[30] + 2}"):
        log = read_carmen(dirty_path)
    assert log.skipped["FLASER (late copy: stamped before earlier records)"] == 1
    assert len(log) == len(clean) == ex.SCANS and log.time_repair is not None and log.time_repair.out_of_order == 0
    for a, b in zip(log, clean):
        assert a.time == b.time and a.odometry == b.odometry
        np.testing.assert_array_equal(a.ranges, b.ranges)


def test_late_copies_tell_a_late_message_from_a_glitched_clock() -> None:
    # A straight drive at 1 m per record. Record 3's stamp goes back a little and its pose is in
    # place (a clock glitch, as the Intel log's four): kept. Record 6 carries record 1's stamp and
    # pose (a message written late): a late copy.
    poses = np.array(
        [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [4, 0, 0], [5, 0, 0], [1, 0, 0], [6, 0, 0], [7, 0, 0]], dtype=float
    )
    times = np.array([0.0, 1.0, 2.0, 1.9, 4.0, 5.0, 1.0, 6.0, 7.0])
    # Many more records in order so that two stamps going back are a small share of the steps.
    poses = np.vstack([poses, np.column_stack([np.arange(8, 60), np.zeros(52), np.zeros(52)])])
    times = np.concatenate([times, np.arange(8, 60, dtype=float)])
    late = late_copies(times, poses)
    assert np.flatnonzero(late).tolist() == [6]
    # A turn on the spot weighs like a translation: the copy of a heading left long ago is late too.
    turning = np.column_stack([np.zeros(60), np.zeros(60), np.linspace(0.0, 3.0, 60)])
    stamps = np.arange(60, dtype=float)
    turning[40], stamps[40] = turning[10], stamps[10]
    assert np.flatnonzero(late_copies(stamps, turning)).tolist() == [40]
    # When many stamps go back, they say nothing: no record is dropped on their word.
    shuffled = np.random.default_rng(3).permutation(60).astype(float)
    assert not late_copies(shuffled, turning).any()


def test_evaluate_log_takes_a_log_whose_stamps_never_change(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "eval"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # Every stamp prints as 1.10287e+09: before the repair, writing the TUM trajectory refused the log.
        code = cli_main(["evaluate-log", str(_coarse_log(tmp_path, 1.0)), "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["planicp"]["ate_rms_m"] < 0.05
    times = np.loadtxt(out / "trajectory.tum")[:, 0]
    assert np.all(np.diff(times) > 0)


def test_g2o_reader_repairs_stamps_that_never_change(tmp_path: Path) -> None:
    from planicp.io import read_g2o

    killian = Path(__file__).parent / "data" / "killian-excerpt.g2o"
    lines = []
    for line in killian.read_text().splitlines():
        fields = line.split()
        if fields and fields[0] == "ROBOTLASER1":
            fields[-1] = fields[-3] = "0"  # ts and logger_ts
        lines.append(" ".join(fields))
    path = tmp_path / "zero.g2o"
    path.write_text("\n".join(lines) + "\n")
    with pytest.warns(UserWarning, match="every timestamp is 0"):
        log = read_g2o(path)
    assert len(log) == 60 and log.time_repair is not None and log.time_repair.fallback == "missing"
    np.testing.assert_allclose(log.times(), DEFAULT_SCAN_PERIOD * np.arange(60))
    np.testing.assert_array_equal(log.odometry_at_scans(), read_g2o(killian).odometry_at_scans())
