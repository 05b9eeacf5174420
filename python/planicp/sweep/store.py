"""Where a study's results live: one JSON line per finished run, then the table.

`runs.jsonl` in the output folder gets each run's record as soon as the run finishes (flushed and
synced), so an interruption loses at most the runs in flight, and a rerun skips every id already
in it. The table (`results.csv`, and `results.parquet` when pyarrow is installed) is written from
those records at the end, one row per run of the study, sorted by run id, so the same study gives
the same table whatever ran it and in whichever order.
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from .runs import METRIC_COLUMNS, RunSpec
from .study import Study

__all__ = ["RESULTS_CSV", "RESULTS_PARQUET", "RUNS_FILE", "ResultStore", "read_table", "table_rows", "write_table"]

RUNS_FILE = "runs.jsonl"
RESULTS_CSV = "results.csv"
RESULTS_PARQUET = "results.parquet"

TIMING_COLUMNS = ("run_time_s",)
"""Columns that measure the machine, not the run: they differ between executions."""


class ResultStore:
    """The records of finished runs in `folder/runs.jsonl`, appended as runs finish."""

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        self.path = self.folder / RUNS_FILE

    def load(self) -> dict[str, dict[str, Any]]:
        """The records so far by run id (a later record of an id replaces an earlier one). A last
        line cut short by an interruption is dropped from the file."""
        if not self.path.exists():
            return {}
        raw = self.path.read_bytes()
        records: dict[str, dict[str, Any]] = {}
        good = 0
        for line in raw.splitlines(keepends=True):
            try:
                record = json.loads(line)
            except (json.JSONDecodeError, UnicodeDecodeError):
                if not line.endswith(b"\n"):
                    break  # an interrupted write: the last line
                raise ValueError(f"{self.path} has a line that is not JSON: {line[:80]!r}") from None
            if not line.endswith(b"\n"):
                break
            if not isinstance(record, dict) or "run_id" not in record:
                raise ValueError(f"{self.path} has a line that is not a run record: {line[:80]!r}")
            records[str(record["run_id"])] = record
            good += len(line)
        if good < len(raw):
            with open(self.path, "r+b") as f:
                f.truncate(good)
        return records

    def append(self, record: dict[str, Any]) -> None:
        """Adds one record, flushed and synced to disk."""
        self.folder.mkdir(parents=True, exist_ok=True)
        line = json.dumps(record, sort_keys=True) + "\n"
        with open(self.path, "a", encoding="utf-8") as f:
            f.write(line)
            f.flush()
            os.fsync(f.fileno())


def table_rows(study: Study, runs: Sequence[RunSpec], records: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per run of `runs` that has a record, sorted by run id: `run_id`, `status`, `error`,
    `success`, the parameters, derived columns (`odometry_drift_deg_per_s`, `odometry_drift_mm_per_s`),
    the metrics and `run_time_s`."""
    rows = []
    criterion = study.success
    for run in runs:
        record = records.get(run.run_id)
        if record is None:
            continue
        ok = record.get("status") == "ok"
        max_error = record.get("planicp_position_max_m")
        lost_at_end = record.get("lost_at_end")
        success = bool(
            ok
            and max_error is not None
            and max_error < criterion.max_position_error_m
            and (criterion.allow_lost_at_end or not lost_at_end)
        )
        row: dict[str, Any] = {
            "run_id": run.run_id,
            "status": record.get("status", "failed"),
            "error": record.get("error", ""),
            "success": success,
        }
        row.update(run.parameters())
        row["odometry_drift_deg_per_s"] = run.odometry_setting.drift_deg_per_s
        row["odometry_drift_mm_per_s"] = run.odometry_setting.drift_mm_per_s
        for key in METRIC_COLUMNS:
            row[key] = record.get(key)
        for key in TIMING_COLUMNS:
            row[key] = record.get(key)
        rows.append(row)
    rows.sort(key=lambda r: str(r["run_id"]))
    return rows


def write_table(rows: Sequence[dict[str, Any]], folder: str | Path) -> list[Path]:
    """Writes `results.csv` (floats as Python writes them, exactly; None as an empty cell) and,
    when pyarrow can be imported, `results.parquet`. Returns the paths written."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    columns = _columns(rows)
    path = out / RESULTS_CSV
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: "" if row.get(k) is None else row[k] for k in columns})
    written = [path]
    try:
        import pyarrow as pa  # type: ignore[import-not-found,unused-ignore]
        import pyarrow.parquet as pq  # type: ignore[import-not-found,unused-ignore]
    except ImportError:
        return written
    table = pa.table({k: [row.get(k) for row in rows] for k in columns})
    pq.write_table(table, out / RESULTS_PARQUET)
    written.append(out / RESULTS_PARQUET)
    return written


def read_table(path: str | Path) -> list[dict[str, str]]:
    """The rows of a `results.csv` as text cells (for comparing tables)."""
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _columns(rows: Iterable[dict[str, Any]]) -> list[str]:
    columns: list[str] = []
    seen: set[str] = set()
    for row in rows:
        for key in row:
            if key not in seen:
                seen.add(key)
                columns.append(key)
    return columns
