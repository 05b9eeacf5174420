"""Tests of replaying logs (`track_log`, `planicp replay`), the log evaluation (`evaluate_log`,
`planicp evaluate-log`), the bag round trip of a simulated run, and the trajectory metrics."""

from __future__ import annotations

import io
import json
import math
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Literal

import numpy as np
import pytest

import carmen_excerpt as ex
from planicp import IcpConfig, PlanMap, PlanScaleWarning
from planicp.cli import main as cli_main
from planicp.evaluation.figures import plot_quality
from planicp.evaluation.log_evaluation import OdometryDrift, evaluate_log, plan_from_scans, synthesise_odometry
from planicp.evaluation.log_replay import track_log
from planicp.evaluation.trajectory_metrics import error_summary, pose_errors
from planicp.io import open_log, read_tum
from planicp.plans.default_plan import default_plan_path, load_default_plan
from planicp.progress import progress_bar
from planicp.se2 import between
from planicp.sim.experiment import ExperimentConfig, Recording, run_experiment
from planicp.sim.odometry import ErrorGenerator

RES = 0.05


@pytest.fixture(scope="module")
def carmen_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("log") / "room.log"
    path.write_text("\n".join(ex.log_lines()) + "\n")
    return path


@pytest.fixture(scope="module")
def room_image(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The excerpt's 10 x 6 m room as a plan image: 0.1 m walls outside the free interior, origin
    (-0.5, -0.5), 5 cm pixels."""
    import cv2

    rows, cols = int(7.0 / RES), int(11.0 / RES)
    image = np.full((rows, cols), 255, dtype=np.uint8)
    inside = np.zeros((rows, cols), dtype=bool)
    # Image row r covers y in [-0.5 + (rows - r - 1) * RES, ...): interior x 0..10, y 0..6.
    inside[int(0.5 / RES) : rows - int(0.5 / RES), int(0.5 / RES) : cols - int(0.5 / RES)] = True
    wall = np.zeros_like(inside)
    wall[int(0.4 / RES) : rows - int(0.4 / RES), int(0.4 / RES) : cols - int(0.4 / RES)] = True
    image[wall & ~inside] = 0
    path = tmp_path_factory.mktemp("plan") / "room.png"
    cv2.imwrite(str(path), image)
    return path


@pytest.fixture(scope="module")
def recording() -> Recording:
    recording, _ = run_experiment(load_default_plan(), ExperimentConfig(duration_s=20.0, seed=8))
    return recording


def test_replay_command_on_a_carmen_log(
    carmen_log: Path, room_image: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "replay"
    code = cli_main(
        [
            "replay",
            str(carmen_log),
            "--plan",
            str(room_image),
            "--resolution",
            str(RES),
            "--origin",
            "-0.5",
            "-0.5",
            "0",
            "--out",
            str(out),
        ]
    )
    assert code == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    assert "40 scans" in printed and "ATE RMS" in printed
    assert {p.name for p in out.iterdir()} == {
        "trajectory.tum",
        "odometry.tum",
        "reference.tum",
        "paths.png",
        "quality.png",
        "position_error.png",
        "heading_error.png",
        "eog.png",
        "eog.yaml",
        "eog.pgm",
        "metrics.json",
    }
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["scans"] == 40 and metrics["accepted_share"] == 1.0
    assert metrics["skipped"] == {"NEFF": 40}
    # The excerpt's odometry drifts 2.2 cm per second; planicp follows the reference poses.
    assert metrics["planicp"]["ate_rms_m"] < 0.01 and metrics["planicp"]["position_max_m"] < 0.02
    assert metrics["odometry"]["position_max_m"] > 0.15
    times, poses = read_tum(out / "trajectory.tum")
    assert len(times) == 40 and times[0] == pytest.approx(1.0)
    log = open_log(carmen_log)
    errors, _ = pose_errors(poses, log.reference_poses())
    assert np.sqrt(np.mean(errors**2)) == pytest.approx(metrics["planicp"]["ate_rms_m"], abs=1e-6)


def test_replay_errors_name_the_problem(
    carmen_log: Path, room_image: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x"
    assert cli_main(["replay", str(carmen_log), "--plan", str(room_image), "--out", str(out)]) == 2
    assert "needs a resolution" in capsys.readouterr().err
    assert (
        cli_main(
            ["replay", str(tmp_path / "none.log"), "--plan", str(room_image), "--resolution", "0.05", "--out", str(out)]
        )
        == 2
    )
    assert "log not found" in capsys.readouterr().err
    frames = [replace(f, reference=None) for f in open_log(carmen_log)]
    plan = PlanMap.from_image(room_image, RES, (-0.5, -0.5, 0.0), cache=False)
    with pytest.raises(ValueError, match="first scan has no reference pose"):
        track_log(frames, plan)
    with pytest.raises(ValueError, match="no scans"):
        track_log([], plan)
    # Without odometry the prediction is "no motion" and ICP alone tracks the slow arc.
    still = [replace(f, odometry=None) for f in open_log(carmen_log)]
    tracked = track_log(still, plan, initial_pose=open_log(carmen_log)[0].reference)
    assert tracked.metrics()["planicp"]["ate_rms_m"] < 0.01
    assert np.isnan(tracked.odometry).all() and "odometry" not in tracked.metrics()


def test_evaluate_log_command(carmen_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "evaluation"
    assert cli_main(["evaluate-log", str(carmen_log), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "plan drawn from 20 scans" in printed and "tracked the other 20" in printed
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["protocol"]["plan_scans"] == 20 and metrics["protocol"]["odometry"] == "synthetic"
    # The room's walls lie exactly on pixel boundaries of the drawn plan, so end points fall on both
    # sides and the drawn walls are two pixels thick. The plan's likelihood field peaks on such a
    # band's middle, the wall (`PlanMap.likelihood_field`): 0.9 cm; a field flat on top across the
    # band (the nearest-point field) left the pose wherever the prior put it in the band: 4.5 cm.
    assert metrics["planicp"]["ate_rms_m"] < 0.02 and metrics["planicp"]["position_max_m"] < 0.04
    assert (out / "plan.yaml").is_file() and (out / "trajectory.tum").is_file()
    assert cli_main(["evaluate-log", str(carmen_log), "--odometry", "log", "--out", str(tmp_path / "o")]) == 0
    # With the log's odometry: 4.7 cm (5.5 cm in the nearest-point field).
    assert json.loads((tmp_path / "o" / "metrics.json").read_text())["planicp"]["ate_rms_m"] < 0.052


def test_evaluate_log_on_a_simulated_run(recording: Recording) -> None:
    frames = recording.scan_frames()
    evaluation = evaluate_log(frames)
    assert evaluation.plan_scans == 101 and evaluation.tracked_scans == 100 and evaluation.skipped_scans == 0
    # Tracked as a user who loads the drawn plan is: its cell centres matched through the index.
    assert evaluation.config == IcpConfig.for_tracking(evaluation.plan)
    assert evaluation.config.correspondence_search == "wall_index"
    m = evaluation.tracked.metrics()
    # The bar for the Intel log; the plan drawn here has the 2.5 cm quantisation noted above.
    assert m["planicp"]["ate_rms_m"] < 0.05 and m["planicp"]["position_max_m"] < 0.15
    assert m["odometry"]["ate_rms_m"] > 3 * m["planicp"]["ate_rms_m"]
    assert evaluation.grid.scans == 100
    with pytest.raises(ValueError, match="at least 4"):
        evaluate_log(frames[:3])
    with pytest.raises(ValueError, match="odometry must be one of"):
        evaluate_log(frames, odometry="wheel")
    with pytest.raises(ValueError, match="needs a log with odometry"):
        evaluate_log([replace(f, odometry=None) for f in frames], odometry="log")
    with pytest.raises(ValueError, match="max_correspondence_distance"):
        evaluate_log(frames, icp={"max_correspondence_distance": -1.0})


def test_a_log_spanning_more_than_a_grid_holds_is_evaluated_with_a_coarser_grid(recording: Recording) -> None:
    # Two of the plan's scans placed 300 m away (a campus's span): the plan at 5 cm holds them, the
    # enhanced occupancy grid at 5 cm would need 3.6e7 cells, more than it may have (2^24).
    frames = recording.scan_frames()
    far = {2: (300.0, 0.0), 4: (0.0, 300.0)}
    moved = [
        replace(f, reference=(f.reference[0] + far[i][0], f.reference[1] + far[i][1], f.reference[2]))
        if i in far and f.reference is not None
        else f
        for i, f in enumerate(frames)
    ]
    with pytest.warns(UserWarning, match=r"the enhanced occupancy grid is made at 0\.0[78] m"):
        evaluation = evaluate_log(moved)
    assert evaluation.plan.raster is not None and evaluation.plan.raster.resolution == 0.05
    assert 0.07 <= evaluation.grid.resolution <= 0.08
    assert evaluation.tracked.metrics()["planicp"]["ate_rms_m"] < 0.05  # the tracking is as without


def test_plan_from_scans_puts_walls_where_the_scans_end(carmen_log: Path) -> None:
    log = open_log(carmen_log)
    plan = plan_from_scans(log.frames, RES, min_hits=2)
    assert plan.raster is not None
    assert np.max(ex.distance_to_walls(plan.points)) < RES  # pixel centres on the walls
    assert len(plan) > 500
    assert plan.metric  # the scans' own metres: its scale is not watched
    with pytest.raises(ValueError, match="no pixel of 0.05 m holds 1000"):
        plan_from_scans(log.frames, RES, min_hits=1000)
    with pytest.raises(ValueError, match="has no reference pose"):
        plan_from_scans([replace(log[0], reference=None)])


def test_synthesised_odometry() -> None:
    times = np.array([0.0, 1.0, 2.5, 3.0])
    reference = np.array([[1.0, 2.0, 0.5], [2.0, 2.5, 0.8], [2.5, 4.0, 2.0], [2.0, 4.5, 3.1]])
    exact = OdometryDrift(
        ErrorGenerator(0.0, 0.0), translation_noise_fraction=0.0, rotation_noise_per_rad=0.0, rotation_noise_per_m=0.0
    )
    odom = synthesise_odometry(times, reference, exact, np.random.default_rng(0))
    assert tuple(odom[0]) == (0.0, 0.0, 0.0)
    for k in range(1, 4):
        want = between(tuple(reference[k - 1]), tuple(reference[k]))
        got = between(tuple(odom[k - 1]), tuple(odom[k]))
        np.testing.assert_allclose(got, want, atol=1e-12)
    # Drift alone on a straight 1 m, 1 s step: 100 messages of +5e-5 m and +5e-5 rad.
    straight = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    drifting = OdometryDrift(translation_noise_fraction=0.0, rotation_noise_per_rad=0.0, rotation_noise_per_m=0.0)
    odom = synthesise_odometry(np.array([0.0, 1.0]), straight, drifting, np.random.default_rng(0))
    assert odom[1, 2] == pytest.approx(100 * 5e-5, rel=1e-9)
    arc = (0.01 + 5e-5) * np.array([[math.cos(j * 5e-5), math.sin(j * 5e-5)] for j in range(100)]).sum(axis=0)
    np.testing.assert_allclose(odom[1, :2], arc, rtol=1e-9)  # the error generator's arc
    # Noise: seeded and of the stated size (2 % of 1 m on x and y).
    noisy = np.array(
        [
            synthesise_odometry(
                np.array([0.0, 1.0]), straight, OdometryDrift(ErrorGenerator(0.0, 0.0)), np.random.default_rng(s)
            )[1]
            for s in range(400)
        ]
    )
    assert np.std(noisy[:, 1]) == pytest.approx(0.02, rel=0.15)
    with pytest.raises(ValueError, match="translation_noise_fraction"):
        OdometryDrift(translation_noise_fraction=-1.0)


def test_a_bag_of_a_simulated_run_replays_to_the_same_trajectory(recording: Recording, tmp_path: Path) -> None:
    pytest.importorskip("rosbags")
    from planicp.io.bag import write_bag

    frames = recording.scan_frames()
    x, y, yaw = recording.truth[0]
    runs: tuple[tuple[Literal[1, 2], str], ...] = ((2, "run_ros2"), (1, "run.bag"))
    for version, name in runs:
        bag = write_bag(tmp_path / name, frames, version=version)
        out = tmp_path / f"out{version}"
        code = cli_main(
            [
                "replay",
                str(bag),
                "--plan",
                str(default_plan_path()),
                "--initial-pose",
                str(x),
                str(y),
                str(yaw),
                "--out",
                str(out),
            ]
        )
        assert code == 0
        times, poses = read_tum(out / "trajectory.tum")
        np.testing.assert_allclose(times, recording.times, atol=1e-6)
        # Ranges travel as float32 in a LaserScan: the same trajectory to well under a millimetre.
        position, heading = pose_errors(poses, recording.estimate)
        assert position.max() < 5e-4 and np.abs(heading).max() < math.radians(0.01), (version, position.max())
        metrics = json.loads((out / "metrics.json").read_text())
        assert metrics["accepted_share"] == float(recording.accepted.mean())


def test_recording_without_ranges_has_no_frames(recording: Recording) -> None:
    bare = replace(recording, ranges=None)
    with pytest.raises(ValueError, match="no ranges"):
        bare.scan_frames()


def test_trajectory_metrics() -> None:
    reference = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 3.1], [2.0, 0.0, 0.0], [np.nan, np.nan, np.nan]])
    estimate = reference + np.array([[0.03, 0.04, 0.0], [0.0, 0.0, 0.1], [0.0, 0.5, -0.02], [0.0, 0.0, 0.0]])
    estimate[3] = (5.0, 5.0, 0.0)
    position, heading = pose_errors(estimate, reference)
    np.testing.assert_allclose(position[:3], [0.05, 0.0, 0.5])
    np.testing.assert_allclose(heading[:3], [0.0, 0.1, -0.02], atol=1e-12)
    assert np.isnan(position[3])
    summary = error_summary(estimate, reference)
    assert summary["compared_poses"] == 3
    assert summary["ate_rms_m"] == pytest.approx(math.sqrt((0.05**2 + 0.5**2) / 3))
    assert summary["position_max_m"] == pytest.approx(0.5) and summary["lost_share"] == pytest.approx(1 / 3)
    assert summary["heading_max_deg"] == pytest.approx(math.degrees(0.1))
    # Across +-pi the heading error is the short way round.
    _, across = pose_errors(np.array([[0.0, 0.0, math.pi - 0.01]]), np.array([[0.0, 0.0, -math.pi + 0.01]]))
    assert across[0] == pytest.approx(-0.02)
    with pytest.raises(ValueError, match="both be \\(N, 3\\)"):
        pose_errors(np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="no pose has a reference"):
        error_summary(np.zeros((1, 3)), np.full((1, 3), np.nan))


def test_quality_figure_and_progress_bar() -> None:
    fig = plot_quality([0.0, 1.0, 2.0], [0.9, np.nan, 0.8], [0.01, np.nan, 0.02], [True, False, True])
    assert len(fig.axes) == 2
    with pytest.raises(ValueError, match="must have one shape"):
        plot_quality([0.0, 1.0], [0.9], [0.01], [True])
    stream = io.StringIO()  # a file or a pipe: plain lines, no carriage-return frames
    report = progress_bar(stream, 1000, "scans")
    for k in range(1, 1001):
        report(k)
    text = stream.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert len(lines) == 10 and "100 %" in lines[-1] and "1,000 / 1,000 scans" in lines[-1]
    progress_bar(None, 10, "scans")(5)  # silent without a stream

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    terminal = Terminal()  # a terminal: one bar redrawn in place
    report = progress_bar(terminal, 10, "scans")
    for k in range(1, 11):
        report(k)
    assert "\r" in terminal.getvalue() and "10/10" in terminal.getvalue()


INTEL = Path(__file__).resolve().parents[2] / "shared" / "data" / "logs" / "intel-corrected.log.gz"


@pytest.mark.skipif(not INTEL.is_file(), reason="the Intel Research Lab log is in ../shared, not in the project")
def test_intel_research_lab_evaluation() -> None:
    """The real-data numbers of docs/benchmarks.md: the issue's bar is ATE < 5 cm and no error over 0.3 m;
    and the plan drawn from the log's own scans is never said to be off in scale (its walls, bands
    of end points, looked like a plan 2.7 % too small to the scale check)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlanScaleWarning)
        evaluation = evaluate_log(open_log(INTEL))
    m = evaluation.tracked.metrics()
    assert evaluation.plan_scans == 455 and evaluation.tracked_scans == 455
    assert m["planicp"]["ate_rms_m"] < 0.05 and m["planicp"]["position_max_m"] < 0.3
    assert m["planicp"]["lost_share"] == 0.0
    assert m["odometry"]["ate_rms_m"] > 10.0
