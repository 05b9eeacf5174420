"""`planicp sweep` (issue 10): studies in YAML, their runs, local and Ray execution, resuming,
failed runs, the table, figures and report.

The studies here are small and short (8 simulated seconds, a 361-beam LIDAR: about half a second a
run) so that the whole file runs in well under a minute on 2 cores, Ray start-up included.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from planicp.cli import main as cli_main
from planicp.sweep import (
    ResultStore,
    Study,
    StudyError,
    expand_runs,
    import_ray,
    load_study,
    read_table,
    run_study,
)
from planicp.sweep.report import plot_error_distributions, plot_success_rates
from planicp.sweep.runs import execute_run
from planicp.sweep.store import TIMING_COLUMNS

DATA = Path(__file__).parent / "data"

SMALL = {
    "name": "small",
    "duration_s": 8,
    "plans": ["default", "house.json"],
    "seeds": [0, 1, 2],
    "furniture": [0, 2],
    "people": [1],
    "sensors": {"short": {"beams": 361}},
}
"""2 plans x 3 seeds x 2 clutter levels: 12 runs."""


def write_study(folder: Path, data: dict[str, Any], name: str = "study.yaml") -> Path:
    """The study file, with the HouseExpo sample beside it as house.json."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(DATA / "house_expo_room_0000.json", folder / "house.json")
    path = folder / name
    path.write_text(yaml.safe_dump(data))
    return path


def comparable(table: list[dict[str, str]]) -> list[dict[str, str]]:
    """A table without its timing columns (wall seconds differ between any two executions)."""
    return [{k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in table]


# --- the study file ------------------------------------------------------------------------------


def test_study_round_trips_through_yaml(tmp_path: Path) -> None:
    data = {
        **SMALL,
        "plans": [
            "default",
            {"path": "house.json", "resolution": 0.1},
            {"path": "floor.png", "resolution": 0.05, "origin": [1.0, 2.0, 0.5]},
        ],
        "seeds": {"start": 5, "count": 3},
        "odometry": {"thesis": {}, "double": {"translation_per_message": "1e-4", "rotation_per_message": 1.0e-4}},
        "icp": {"tracking": {}, "no-trim": {"auto_trim": False}, "coarse": {"correspondence_schedule": [1, 0.5]}},
        "success": {"max_position_error_m": 0.2},
    }
    study, base = load_study(write_study(tmp_path, data))
    assert base == tmp_path.resolve()
    assert study.seeds == (5, 6, 7)
    assert study.odometry["double"].translation_per_message == 1e-4  # YAML 1.1 reads 1e-4 as text
    assert study.odometry["double"].drift_deg_per_s == pytest.approx(0.5729577951308232)
    assert study.icp_config("no-trim").auto_trim is False
    assert study.plans[2].origin == (1.0, 2.0, 0.5)
    again = Study.from_dict(yaml.safe_load(study.to_yaml()))
    assert again == study
    assert again.to_dict() == study.to_dict()
    # the defaults: one sensor, one odometry setting, the tracking ICP settings
    minimal = Study.from_dict({"name": "m", "plans": ["default"]})
    assert (list(minimal.sensors), list(minimal.odometry), list(minimal.icp)) == (["utm30"], ["thesis"], ["tracking"])
    assert Study.from_dict(yaml.safe_load(minimal.to_yaml())) == minimal


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"plans": None}, "key 'plans' must be a list"),
        ({"colour": "red"}, r"unknown key\(s\) \['colour'\]"),
        ({"name": ""}, "key 'name' must be a non-empty string"),
        ({"plans": []}, "key 'plans' must list at least one plan"),
        ({"plans": [{"resolution": 0.05}]}, r"key 'plans\[0\]' has no 'path'"),
        ({"plans": [{"path": "a.png", "resolution": -1}]}, r"key 'plans\[0\]'.*resolution must be a positive"),
        ({"plans": [{"path": "a.png", "scale": 2}]}, r"unknown key\(s\) \['plans\[0\].scale'\]"),
        ({"seeds": ["one"]}, "key 'seeds' must hold integers"),
        ({"seeds": {"count": 0}}, "key 'seeds.count' must be an integer >= 1"),
        ({"seeds": [1, 1]}, "key 'seeds' lists a value twice"),
        ({"furniture": [-1]}, "key 'furniture' must hold finite numbers >= 0"),
        ({"people": ["many"]}, r"key 'people\[0\]': people must be a number"),
        ({"duration_s": 0}, "key 'duration_s' must be a positive number"),
        ({"sensors": {"x": {"beems": 100}}}, r"unknown key\(s\) \['sensors.x.beems'\]"),
        ({"sensors": {"x": {"beams": 1}}}, "key 'sensors.x': beams must be at least 2"),
        ({"sensors": {"x": {"beams": 100.5}}}, "key 'sensors.x': beams must be an integer"),
        ({"sensors": {"x": {"fov_deg": 400}}}, "key 'sensors.x': fov must be at most 2 pi"),
        ({"sensors": {}}, "key 'sensors' must name at least one setting"),
        ({"odometry": {"slow": {"rate_hz": 5}}}, r"key 'odometry.slow.rate_hz' \(5.0\) is below the scan rate"),
        (
            {"odometry": {"x": {"rotation_fraction": -1}}},
            "key 'odometry.x': rotation_fraction must be a finite number >= 0",
        ),
        ({"icp": {"x": {"trim_ratio": 2}}}, r"key 'icp.x': trim_ratio must be in \(0, 1\]"),
        ({"icp": {"x": {"max_distance": 2}}}, r"unknown key\(s\) \['icp.x.max_distance'\]; known: .*'max_iterations'"),
        ({"success": {"max_position_error_m": 0}}, "key 'success': max_position_error_m must be a positive"),
    ],
)
def test_study_errors_name_the_key(tmp_path: Path, change: dict[str, Any], message: str) -> None:
    path = write_study(tmp_path, {**SMALL, **change})
    with pytest.raises(StudyError, match=message) as info:
        load_study(path)
    assert str(path) in str(info.value)


def test_study_file_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_study(tmp_path / "none.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    with pytest.raises(StudyError, match="is not valid YAML"):
        load_study(bad)
    bad.write_text("- a list\n")
    with pytest.raises(StudyError, match="must be a mapping of keys"):
        load_study(bad)
    for data in ({"plans": ["default"]}, {"name": "x"}):
        bad.write_text(yaml.safe_dump(data))
        with pytest.raises(StudyError, match="missing key"):
            load_study(bad)
    # the command line reports it and exits with 2
    assert cli_main(["sweep", str(bad), "--out", str(tmp_path / "out")]) == 2
    assert "missing key 'plans'" in capsys.readouterr().err


# --- expansion -----------------------------------------------------------------------------------


def test_expansion_ids_and_plan_folders(tmp_path: Path) -> None:
    folder = tmp_path / "houses"
    folder.mkdir()
    for name in ("b.json", "a.json"):
        shutil.copy(DATA / "house_expo_room_0000.json", folder / name)
    study = Study.from_dict(
        {
            **SMALL,
            "plans": ["default", "houses/", {"path": "houses", "resolution": 0.1}],
            "odometry": {"thesis": {}, "none": {"translation_per_message": 0, "rotation_per_message": 0}},
        }
    )
    runs = expand_runs(study, tmp_path)
    assert len(runs) == 5 * 3 * 2 * 2
    assert [r.plan for r in runs[::12]] == [
        "default",
        "houses/a.json",
        "houses/b.json",
        "houses/a.json",
        "houses/b.json",
    ]
    assert {r.plan_resolution for r in runs if r.plan.startswith("houses")} == {0.05, 0.1}
    ids = [r.run_id for r in runs]
    assert len(set(ids)) == len(ids) and all(len(i) == 16 for i in ids)
    # ids depend on the parameters only: not on where the study lives or the order it lists things
    other = tmp_path / "copy"
    shutil.copytree(folder, other / "houses")
    reordered = Study.from_dict({**study.to_dict(), "seeds": [2, 0, 1]})
    assert sorted(r.run_id for r in expand_runs(reordered, other)) == sorted(ids)
    assert runs[0].parameters()["plan"] == "default" and runs[0].plan_file == ""
    with pytest.raises(StudyError, match="the same run twice"):
        expand_runs(Study.from_dict({**SMALL, "plans": ["default", "default"]}), tmp_path)
    (tmp_path / "empty").mkdir()
    with pytest.raises(StudyError, match="plan folder 'empty'.*holds no HouseExpo"):
        expand_runs(Study.from_dict({**SMALL, "plans": ["empty"]}), tmp_path)


def test_one_run_is_deterministic_and_complete(tmp_path: Path) -> None:
    write_study(tmp_path, SMALL)
    study = Study.from_dict(SMALL)
    spec = [r for r in expand_runs(study, tmp_path) if r.plan == "house.json" and r.furniture == 2][0]
    first, second = execute_run(spec), execute_run(spec)
    assert first["status"] == "ok", first["error"]
    for record in (first, second):
        for key in ("run_time_s", "finished_at", "worker"):
            record.pop(key)
    assert first == second
    assert first["scans"] == 81 and first["people_count"] >= 1 and first["furniture_m2"] > 1
    assert first["planicp_position_max_m"] < 0.1 and first["odometry_position_max_m"] > first["planicp_position_max_m"]
    assert first["lost_at_end"] == 0


# --- execution: local, Ray, resuming, failures --------------------------------------------------


def test_local_and_ray_give_identical_tables(tmp_path: Path) -> None:
    """The same 12-run study on the local process pool and on a local Ray instance started here."""
    config = write_study(tmp_path, SMALL)
    study, base = load_study(config)
    local = run_study(study, tmp_path / "local", base_dir=base, workers=2)
    assert (local.total, local.executed, local.skipped, local.failed) == (12, 12, 0, 0)
    ray = import_ray()
    # address="local": a new instance even when this machine runs a Ray cluster (ray.init() would join it)
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        on_ray = run_study(study, tmp_path / "ray", base_dir=base, ray=True)
    finally:
        ray.shutdown()
    assert (on_ray.total, on_ray.executed, on_ray.failed) == (12, 12, 0)
    local_table = read_table(tmp_path / "local" / "results.csv")
    ray_table = read_table(tmp_path / "ray" / "results.csv")
    assert len(local_table) == 12
    assert comparable(local_table) == comparable(ray_table)
    # the workers really were different processes
    workers = {json.loads(line)["worker"] for line in (tmp_path / "ray" / "runs.jsonl").read_text().splitlines()}
    workers |= {json.loads(line)["worker"] for line in (tmp_path / "local" / "runs.jsonl").read_text().splitlines()}
    assert len(workers) >= 3 and str(os.getpid()) not in {w.split(":")[-1] for w in workers}
    # the table: sorted by run id, parameters and metrics; the seeds give different runs
    assert [r["run_id"] for r in local_table] == sorted(r["run_id"] for r in local_table)
    assert {r["plan"] for r in local_table} == {"default", "house.json"}
    assert {r["furniture"] for r in local_table} == {"0.0", "2.0"}
    assert len({r["planicp_position_rms_m"] for r in local_table}) == 12
    assert all(r["success"] == "True" and r["status"] == "ok" for r in local_table)
    report = (tmp_path / "local" / "report.md").read_text()
    assert "**Success: 12 of 12 runs (100.0 %)**" in report and "## By furniture density" in report
    for name in ("errors.png", "success.png", "study.yaml"):
        assert (tmp_path / "local" / name).stat().st_size > 0
    assert Study.from_dict(yaml.safe_load((tmp_path / "local" / "study.yaml").read_text())) == study
    # a second call runs nothing and writes the same table
    again = run_study(study, tmp_path / "local", base_dir=base, workers=2)
    assert (again.executed, again.skipped) == (0, 12)
    assert read_table(tmp_path / "local" / "results.csv") == local_table


def test_interrupted_study_resumes_without_rerunning(tmp_path: Path) -> None:
    """`planicp sweep` killed (SIGKILL, no chance to clean up) after a few runs, then run again:
    the runs recorded before the kill are not run again, the others are, and each run is recorded
    once."""
    data = {**SMALL, "seeds": [0, 1, 2], "furniture": [0], "plans": ["default", "house.json"]}
    config = write_study(tmp_path, data)
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-c",
        "import sys; from planicp.cli import main; sys.exit(main())",
        "sweep",
        str(config),
        "--out",
        str(out),
        "--workers",
        "1",
    ]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    runs_file = out / "runs.jsonl"
    deadline = time.monotonic() + 120
    try:
        while time.monotonic() < deadline and process.poll() is None:
            if runs_file.exists() and len(runs_file.read_bytes().splitlines()) >= 2:
                break
            time.sleep(0.05)
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    before = ResultStore(out).load()
    assert 2 <= len(before) < 6, process.stderr.read() if process.stderr else ""
    # a write cut short by the kill would leave a partial last line: the store drops it
    with open(runs_file, "ab") as f:
        f.write(b'{"run_id": "cut sho')
    study, base = load_study(config)
    resumed = run_study(study, out, base_dir=base, workers=2)
    assert (resumed.total, resumed.skipped, resumed.executed) == (6, len(before), 6 - len(before))
    lines = [json.loads(line) for line in runs_file.read_text().splitlines()]
    assert len(lines) == 6 and len({r["run_id"] for r in lines}) == 6
    after = {r["run_id"]: r for r in lines}
    for run_id, record in before.items():
        assert after[run_id]["finished_at"] == record["finished_at"]  # not run again
    assert len(read_table(out / "results.csv")) == 6


def test_failed_runs_are_recorded_and_do_not_stop_the_study(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "blank.png").write_bytes(b"not an image")
    data = {
        **SMALL,
        "seeds": [0],
        "furniture": [0],
        "plans": ["default", "missing.json", "blank.png", {"path": "house.json", "resolution": 50.0}],
    }
    config = write_study(tmp_path, data)
    out = tmp_path / "out"
    # The study goes on past the failed runs, and the exit status says they failed (it said 0).
    assert cli_main(["sweep", str(config), "--out", str(out), "--workers", "2"]) == 1
    captured = capsys.readouterr()
    printed = captured.out
    assert "4 runs recorded (3 failed), 1 successes" in printed
    assert "3 of 4 runs failed" in captured.err and "--retry-failed" in captured.err
    table = {r["plan"]: r for r in read_table(out / "results.csv")}
    assert table["default"]["status"] == "ok" and table["default"]["success"] == "True"
    assert table["missing.json"]["error"].startswith("FileNotFoundError: ")
    assert "needs a resolution" in table["blank.png"]["error"]  # an image plan without one
    assert table["house.json"]["error"].startswith("ValueError: ")  # 50 m pixels: nothing to drive in
    for row in table.values():
        if row["status"] == "failed":
            assert row["success"] == "False" and row["planicp_position_max_m"] == ""
    report = (out / "report.md").read_text()
    assert "## Failed runs" in report and "missing.json" in report
    # failures are results: a rerun keeps them, --retry-failed runs only them again
    again = run_study(load_study(config)[0], out, base_dir=tmp_path)
    assert (again.executed, again.skipped) == (0, 4)
    retried = run_study(load_study(config)[0], out, base_dir=tmp_path, retry_failed=True)
    assert (retried.executed, retried.skipped, retried.failed) == (3, 1, 3)


def test_ray_missing_names_the_extra(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    with pytest.raises(ImportError, match=r"pip install 'planicp\[cluster\]'"):
        import_ray()
    config = write_study(tmp_path, {**SMALL, "seeds": [0], "furniture": [0], "plans": ["default"]})
    assert cli_main(["sweep", str(config), "--out", str(tmp_path / "out"), "--ray"]) == 2
    assert "planicp[cluster]" in capsys.readouterr().err


def test_summary_figures_of_a_table() -> None:
    rows = []
    for i, (furniture, drift, error) in enumerate(
        [(0.0, 0.29, 0.01), (0.0, 0.57, 0.4), (2.0, 0.29, 0.02), (2.0, 0.57, 0.5), (2.0, 0.57, 0.03)]
    ):
        rows.append(
            {
                "run_id": f"{i:016x}",
                "status": "ok",
                "success": error < 0.3,
                "plan": "default",
                "furniture": furniture,
                "people": 1.0,
                "sensor": "s",
                "icp": "tracking",
                "odometry": "thesis" if drift < 0.3 else "double",
                "odometry_drift_deg_per_s": drift,
                "planicp_position_max_m": error,
                "odometry_position_max_m": 10 * error,
                "lost_scans": 0.0,
            }
        )
    rows.append(
        {
            **rows[0],
            "run_id": "f" * 16,
            "status": "failed",
            "success": False,
            "planicp_position_max_m": None,
            "odometry_position_max_m": None,
            "lost_scans": None,
        }
    )
    fig = plot_error_distributions(rows, 0.3)
    assert [ax.get_xlabel() for ax in fig.axes] == ["furniture density (x demo)", "odometry errors"]
    fig = plot_success_rates(rows)
    left, right = fig.axes
    rates = {line.get_label(): list(line.get_ydata()) for line in left.get_lines()}
    assert rates == {"thesis": [0.5, 1.0], "double": [0.0, 0.5]}
    rates = {line.get_label(): list(line.get_ydata()) for line in right.get_lines()}
    assert rates == {"furniture 0": [0.5, 0.0], "furniture 2": [1.0, 0.5]}
