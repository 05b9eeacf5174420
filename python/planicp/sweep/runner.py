"""`planicp sweep`: a study from YAML to the table, the figures and the report.

The output folder gets:

- `study.yaml`: the study as it was run (normalised);
- `runs.jsonl`: one record per finished run, appended as runs finish (what resuming reads);
- `results.csv` (and `results.parquet` with pyarrow): one row per run, sorted by run id;
- `errors.png`, `success.png`: error distributions per setting, success rate vs clutter and drift;
- `report.md`.

Running the same study into the same folder again runs only what is not in `runs.jsonl` yet; a
study extended with more seeds or settings runs only the new combinations.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from .. import __version__
from ..progress import progress_bar
from .executors import RunFunction, run_local, run_ray
from .report import markdown_report, plot_error_distributions, plot_success_rates
from .runs import RunSpec, execute_run, expand_runs, study_axes
from .store import ResultStore, table_rows, write_table
from .study import Study

__all__ = ["StudyResult", "run_study"]


@dataclass(frozen=True)
class StudyResult:
    """What `run_study` did.

    Attributes:
        rows: the table, one dict per recorded run, sorted by run id.
        total: runs in the study.
        skipped: runs already recorded before this call (not run again).
        executed: runs this call ran.
        failed: recorded runs whose status is "failed".
        files: the files written (table, figures, report).
        wall_s: wall seconds of this call.
    """

    rows: list[dict[str, Any]]
    total: int
    skipped: int
    executed: int
    failed: int
    files: list[Path]
    wall_s: float


def run_study(
    study: Study,
    out: str | Path,
    *,
    base_dir: str | Path = ".",
    ray: bool = False,
    ray_address: str | None = None,
    workers: int | None = None,
    retry_failed: bool = False,
    stream: TextIO | None = None,
    run: RunFunction = execute_run,
    command: str = "",
) -> StudyResult:
    """Runs every run of `study` not yet recorded in `out`, then writes the table, figures and report.

    Args:
        study: the study; relative plan paths are relative to `base_dir`.
        out: output folder (created); a folder of an earlier, interrupted call is resumed.
        ray: run on Ray (`ray_address`: see `executors.run_ray`) instead of a local process pool.
        workers: local processes (default: one per CPU).
        retry_failed: run again the runs recorded as failed (by default a failure is a result).
        stream: where to print the progress (None: silent).
        run: the run function (`execute_run`; tests substitute one that must be importable).
        command: the command line, quoted in the report.

    An interruption (KeyboardInterrupt) propagates after the finished runs are recorded: calling
    again finishes the study.
    """
    started = time.perf_counter()
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    runs = expand_runs(study, base_dir)
    (folder / "study.yaml").write_text(study.to_yaml(), encoding="utf-8")
    store = ResultStore(folder)
    records = store.load()
    ids = {r.run_id for r in runs}
    done = {i for i, rec in records.items() if i in ids and (rec.get("status") == "ok" or not retry_failed)}
    todo = [r for r in runs if r.run_id not in done]
    where = "Ray" + (f" at {ray_address}" if ray_address else "") if ray else f"{workers or 'all'} local processes"
    if stream is not None:
        print(
            f"study {study.name!r}: {len(runs)} runs, {len(done)} already recorded in {folder}, "
            f"{len(todo)} to run on {where}",
            file=stream,
        )
    bar = progress_bar(stream, len(todo), "runs")
    finished = [0]

    def record(rec: dict[str, Any]) -> None:
        store.append(rec)
        records[str(rec["run_id"])] = rec
        finished[0] += 1
        bar(finished[0])

    try:
        if ray:
            run_ray(todo, record, ray_address, run)
        else:
            run_local(todo, record, workers, run)
    finally:
        if stream is not None and todo:
            print(file=stream)
    rows = table_rows(study, runs, records)
    files = write_table(rows, folder) + _summaries(study, runs, rows, folder, command)
    failed = sum(r["status"] != "ok" for r in rows)
    result = StudyResult(rows, len(runs), len(done), finished[0], failed, files, time.perf_counter() - started)
    if stream is not None:
        successes = sum(bool(r["success"]) for r in rows)
        print(
            f"{len(rows)} runs recorded ({failed} failed), {successes} successes; ran {finished[0]} in "
            f"{result.wall_s:.1f} s; wrote {', '.join(p.name for p in files)} to {folder}",
            file=stream,
        )
    return result


def _summaries(
    study: Study, runs: Sequence[RunSpec], rows: list[dict[str, Any]], folder: Path, command: str
) -> list[Path]:
    figures = []
    order = {"plan": list(dict.fromkeys(r.plan for r in runs)), **study_axes(study)}
    if rows:
        plot_error_distributions(rows, study.success.max_position_error_m, order).savefig(folder / "errors.png")
        plot_success_rates(rows, order).savefig(folder / "success.png")
        figures = ["errors.png", "success.png"]
    report = markdown_report(
        study, rows, expected_runs=len(runs), figures=figures, command=command, version=__version__, order=order
    )
    (folder / "report.md").write_text(report, encoding="utf-8")
    return [folder / name for name in figures] + [folder / "report.md"]
