"""A study expanded into runs, and the run function: parameters in, one row of metrics out.

Each run is one `planicp.sim.run_experiment` on one plan with one seed and one setting of every
axis. Its id is a hash of its parameters (`RunSpec.parameters`), so the same run has the same id on
every machine and in every later invocation: that is what resuming and comparing tables rely on.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import itertools
import json
import math
import os
import socket
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..plans.plan_loading import house_expo_files, load_plan
from ..plans.plan_map import PlanMap
from ..sim.experiment import ExperimentConfig
from ..sim.world import Furnishing
from ..tracking.icp_config import IcpConfig
from .study import DEFAULT_PLAN, FURNITURE_UNIT, OdometrySetting, PlanSource, SensorSetting, Study, StudyError

__all__ = ["HOUSE_EXPO_RESOLUTION", "METRIC_COLUMNS", "RunSpec", "execute_run", "expand_runs"]

HOUSE_EXPO_RESOLUTION = 0.05
"""Metres per pixel at which a HouseExpo plan is rasterised when its entry gives no resolution."""

METRIC_COLUMNS = (
    "planicp_position_rms_m",
    "planicp_position_max_m",
    "planicp_position_final_m",
    "planicp_heading_rms_deg",
    "planicp_heading_max_deg",
    "planicp_heading_final_deg",
    "odometry_position_rms_m",
    "odometry_position_max_m",
    "odometry_position_final_m",
    "odometry_heading_rms_deg",
    "odometry_heading_max_deg",
    "odometry_heading_final_deg",
    "scans",
    "accepted_share",
    "lost_scans",
    "lost_at_end",
    "path_length_m",
    "furniture_m2",
    "people_count",
)
"""The metrics of a finished run (see `Recording.metrics`): errors against ground truth in metres
and degrees, scan counts, metres driven, square metres of furniture, people placed."""


@dataclass(frozen=True)
class RunSpec:
    """One run of a study: its parameters (the table's parameter columns) and where its plan is.

    Attributes:
        plan: the plan as the study names it ("default", or a path as written, a folder's files
            as folder/name).
        plan_resolution: metres per pixel of an image or rasterised HouseExpo plan (None: the
            plan's own, or not applicable).
        plan_origin: (x, y, yaw) of a plan image's lower-left corner, map frame (m, m, rad).
        seed: seed of furniture, route, people and noise.
        duration_s: simulated seconds.
        furniture: furniture density, times the demo's per 100 m^2.
        people: walking people per 100 m^2.
        sensor, sensor_setting: the LIDAR model's name and settings.
        odometry, odometry_setting: the odometry error setting's name and settings.
        icp, icp_changes: the ICP setting's name and its changes to `IcpConfig.for_tracking()`
            (sorted (key, value) pairs).
        plan_file: the plan's absolute path on the machine that expanded the study (not a
            parameter: it does not enter the id or the table).
    """

    plan: str
    plan_resolution: float | None
    plan_origin: tuple[float, float, float]
    seed: int
    duration_s: float
    furniture: float
    people: float
    sensor: str
    sensor_setting: SensorSetting
    odometry: str
    odometry_setting: OdometrySetting
    icp: str
    icp_changes: tuple[tuple[str, Any], ...]
    plan_file: str = dataclasses.field(default="", compare=False)

    def parameters(self) -> dict[str, Any]:
        """The run's parameters as flat, JSON-friendly columns (the id is their hash)."""
        out: dict[str, Any] = {
            "plan": self.plan,
            "plan_resolution": self.plan_resolution,
            "plan_origin": json.dumps(list(self.plan_origin)),
            "seed": self.seed,
            "duration_s": self.duration_s,
            "furniture": self.furniture,
            "people": self.people,
            "sensor": self.sensor,
        }
        for f in dataclasses.fields(SensorSetting):
            value = getattr(self.sensor_setting, f.name)
            out[f"sensor_{f.name}"] = json.dumps(list(value)) if isinstance(value, tuple) else value
        out["odometry"] = self.odometry
        for f in dataclasses.fields(OdometrySetting):
            out[f"odometry_{f.name}"] = getattr(self.odometry_setting, f.name)
        out["icp"] = self.icp
        out["icp_changes"] = json.dumps(dict(self.icp_changes), sort_keys=True)
        return out

    @property
    def run_id(self) -> str:
        """16 hex digits of the SHA-256 of the parameters: the same run has the same id anywhere."""
        text = json.dumps(self.parameters(), sort_keys=True, allow_nan=False)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def experiment_config(self) -> ExperimentConfig:
        """The simulation's configuration of this run."""
        furnishing = Furnishing(
            cabinets=FURNITURE_UNIT.cabinets * self.furniture,
            blocks=FURNITURE_UNIT.blocks * self.furniture,
            tables=FURNITURE_UNIT.tables * self.furniture,
            people=self.people,
        )
        odom = self.odometry_setting
        return ExperimentConfig(
            duration_s=self.duration_s,
            seed=self.seed,
            lidar=self.sensor_setting.lidar(),
            furnishing=furnishing,
            odometry_rate_hz=odom.rate_hz,
            odometry_noise=odom.noise(),
            error_generator=odom.error_generator(),
            icp=IcpConfig.for_tracking(**dict(self.icp_changes)),
        )


def expand_runs(study: Study, base_dir: str | Path = ".") -> list[RunSpec]:
    """Every run of `study`: plans (folders expanded to their HouseExpo files) x seeds x furniture x
    people x sensors x odometry x ICP settings, in that order. Relative plan paths are resolved
    against `base_dir` (the study file's folder).

    Raises:
        StudyError: a plan folder without HouseExpo files, or two entries giving the same run.
    """
    base = Path(base_dir).resolve()
    plans: list[tuple[str, str, PlanSource]] = []
    for source in study.plans:
        if source.path == DEFAULT_PLAN:
            plans.append((DEFAULT_PLAN, "", source))
            continue
        full = (base / source.path).resolve()
        if full.is_dir():
            try:
                files = house_expo_files(full)
            except ValueError as exc:
                raise StudyError(f"plan folder {source.path!r}: {exc}") from None
            label = source.path.rstrip("/\\")
            plans += [(f"{label}/{f.name}", str(f), source) for f in files]
        else:
            plans.append((source.path, str(full), source))
    runs: list[RunSpec] = []
    for (label, file, source), seed, furniture, people, (sname, sensor), (oname, odom), (
        iname,
        icp,
    ) in itertools.product(
        plans,
        study.seeds,
        study.furniture,
        study.people,
        study.sensors.items(),
        study.odometry.items(),
        study.icp.items(),
    ):
        resolution = source.resolution
        if resolution is None and file.lower().endswith(".json"):
            resolution = HOUSE_EXPO_RESOLUTION
        runs.append(
            RunSpec(
                label,
                resolution,
                source.origin,
                int(seed),
                float(study.duration_s),
                float(furniture),
                float(people),
                sname,
                sensor,
                oname,
                odom,
                iname,
                tuple(sorted(dict(icp).items())),
                plan_file=file,
            )
        )
    seen: dict[str, RunSpec] = {}
    for run in runs:
        if run.run_id in seen:
            raise StudyError(
                f"the study gives the same run twice (plan {run.plan!r}, seed {run.seed}): is a plan listed twice?"
            )
        seen[run.run_id] = run
    return runs


@functools.lru_cache(maxsize=8)
def _plan(file: str, resolution: float | None, origin: tuple[float, float, float]) -> PlanMap:
    """A plan, loaded once per worker process (runs on the same plan share it; PlanMap is read-only)."""
    if not file:
        from ..plans.default_plan import load_default_plan

        return load_default_plan()
    return load_plan(file, resolution=resolution, origin=origin)


def execute_run(spec: RunSpec) -> dict[str, Any]:
    """Runs one simulation and returns its record: `run_id`, the parameters, `status` ("ok" or
    "failed"), `error` ("" or the exception's type and message), the metrics (`METRIC_COLUMNS`,
    absent for a failed run), `run_time_s` (wall seconds), `finished_at` (Unix time) and `worker`
    (host:pid).

    Never raises for a bad plan or parameter: any `Exception` is recorded in `error`. The same
    spec gives the same parameters and metrics on any machine and in any process.
    """
    record: dict[str, Any] = {"run_id": spec.run_id, **spec.parameters(), "status": "ok", "error": ""}
    started = time.perf_counter()
    try:
        from ..sim.experiment import run_experiment

        plan = _plan(spec.plan_file, spec.plan_resolution, spec.plan_origin)
        recording, world = run_experiment(plan, spec.experiment_config())
        metrics = recording.metrics()
        truth = recording.truth[:, :2]
        metrics["path_length_m"] = float(np.sum(np.hypot(*np.diff(truth, axis=0).T))) if len(truth) > 1 else 0.0
        metrics["furniture_m2"] = float(world.floor.clutter[3:-3, 3:-3].sum() * world.floor.resolution**2)
        metrics["people_count"] = float(len(world.people))
        record.update({k: _finite_or_none(metrics.get(k)) for k in METRIC_COLUMNS})
    except Exception as exc:  # noqa: BLE001 - a failed run is a result, not the end of the study
        record["status"] = "failed"
        record["error"] = f"{type(exc).__name__}: {exc}"
    record["run_time_s"] = time.perf_counter() - started
    record["finished_at"] = time.time()
    record["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return record


def failed_record(spec: RunSpec, error: str) -> dict[str, Any]:
    """The record of a run that could not report itself (its worker died): status "failed"."""
    return {
        "run_id": spec.run_id,
        **spec.parameters(),
        "status": "failed",
        "error": error,
        "run_time_s": None,
        "finished_at": time.time(),
        "worker": "",
    }


def _finite_or_none(value: Any) -> float | None:
    if value is None:
        return None
    v = float(value)
    return v if math.isfinite(v) else None


def study_axes(study: Study) -> Mapping[str, list[Any]]:
    """The values of each axis of the study, in study order (for plots and the report)."""
    return {
        "furniture": list(study.furniture),
        "people": list(study.people),
        "sensor": list(study.sensors),
        "odometry": list(study.odometry),
        "icp": list(study.icp),
    }
