"""Evaluation at scale: a study of many simulated runs (`planicp sweep STUDY.yaml --out DIR`).

A study (YAML, `Study`) lists plans, seeds, furniture densities, people, sensor models, odometry
error settings and ICP settings; every combination is one run of the simulation loop
(`planicp.sim.run_experiment`). Runs execute in a local process pool or on a Ray cluster
(`pip install 'planicp[cluster]'`), each finished run is recorded at once (resumable), and the
results become one table (`results.csv`), summary figures and a Markdown report:

    from planicp.sweep import load_study, run_study
    study, base = load_study("study.yaml")
    result = run_study(study, "out", base_dir=base)            # or ray=True, ray_address="auto"
    print(result.total, result.failed, result.rows[0]["planicp_position_max_m"])
"""

from __future__ import annotations

from .executors import import_ray, run_local, run_ray
from .runner import StudyResult, run_study
from .runs import METRIC_COLUMNS, RunSpec, execute_run, expand_runs
from .store import ResultStore, read_table, table_rows, write_table
from .study import OdometrySetting, PlanSource, SensorSetting, Study, StudyError, SuccessCriterion, load_study

__all__ = [
    "METRIC_COLUMNS",
    "OdometrySetting",
    "PlanSource",
    "ResultStore",
    "RunSpec",
    "SensorSetting",
    "Study",
    "StudyError",
    "StudyResult",
    "SuccessCriterion",
    "execute_run",
    "expand_runs",
    "import_ray",
    "load_study",
    "read_table",
    "run_local",
    "run_ray",
    "run_study",
    "table_rows",
    "write_table",
]
