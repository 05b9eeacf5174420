"""A study: the settings a sweep varies, as frozen pydantic dataclasses that round-trip through YAML
(`planicp._settings`; the settings it combines are in `planicp.sweep.study_settings`).

A study file (YAML) names the plans, seeds and settings; `planicp.sweep.runs.expand_runs` turns it
into one run of the simulation loop (`planicp.sim.run_experiment`) per combination:

    name: clutter-and-drift
    duration_s: 40              # simulated seconds per run
    plans:
      - default                 # the office plan that ships with planicp
      - path: plans/house.json  # a HouseExpo plan (rasterised at 5 cm unless `resolution` says otherwise)
      - path: house_expo/       # a folder: every HouseExpo .json in it
      - path: maps/floor.yaml   # a ROS map (its own resolution and origin)
      - {path: scans/hall.png, resolution: 0.05, origin: [0, 0, 0]}   # a plan image
    seeds: [0, 1, 2]            # or {count: 10} or {start: 100, count: 10}
    furniture: [0, 1, 2]        # times the demo's furniture per 100 m^2 of floor
    people: [0, 2]              # walking people per 100 m^2 of floor
    sensors:                    # named LIDAR models (fields of SensorSetting)
      utm30: {}
      budget: {fov_deg: 240, beams: 240, range_max: 8, range_sigma: 0.03}
    odometry:                   # named odometry error settings (fields of OdometrySetting)
      thesis: {}
      double-drift: {translation_per_message: 1.0e-4, rotation_per_message: 1.0e-4}
    icp:                        # named ICP settings: IcpConfig.for_tracking() with these changes
      tracking: {}
      no-trim: {auto_trim: false}
    success:
      max_position_error_m: 0.3

Relative plan paths are relative to the study file. Units: metres, seconds, degrees where a key
says `_deg`, radians elsewhere. Every unknown key or bad value is a `StudyError` naming the key
(e.g. ``sensors.budget.beams``). Numbers written as YAML 1.2 allows (``1e-4``, which PyYAML reads
as text) are accepted.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import field
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, ValidationError, ValidationInfo
from pydantic.dataclasses import dataclass
from pydantic_core import PydanticCustomError

from .._settings import NUMBER_TEXT, SETTINGS, Real, Settings, first_error, key_path, read
from .._validation import brief
from ..io.yaml_documents import read_yaml_file
from ..sim.world import Furnishing
from ..tracking.icp_config import IcpConfig
from .study_settings import OdometrySetting, PlanSource, SensorSetting, SuccessCriterion, changed_fields

__all__ = [
    "DEFAULT_PLAN",
    "FURNITURE_UNIT",
    "OdometrySetting",
    "PlanSource",
    "SensorSetting",
    "Study",
    "StudyError",
    "SuccessCriterion",
    "load_study",
]

DEFAULT_PLAN = "default"
"""The plan name that means the office plan shipped with planicp (`planicp.plans.default_plan`)."""

FURNITURE_UNIT = Furnishing(people=0.0)
"""Furniture density 1: the demo's cabinets, blocks and tables per 100 m^2 of free floor."""

MAX_SEEDS = 100_000
"""Most seeds `seeds: {count: ...}` may ask for (each is a run per combination of the other keys)."""


class StudyError(ValueError):
    """A study file or mapping that cannot describe a study; the message names the key."""


def _about_itself(message: str) -> PydanticCustomError:
    """A refusal whose message says what the value at its key must be ("must be ...", "has no
    ..."): the study's message is "key 'plans[0]' has no 'path'"."""
    return PydanticCustomError("study_value", "{message}", {"message": message})


def _whole_message(message: str) -> PydanticCustomError:
    """A refusal whose message is the study's message as it is (it names its keys itself)."""
    return PydanticCustomError("study_message", "{message}", {"message": message})


# The study's own fields, as a study file writes them: a list may be a single value, seeds a range
# ({start, count}), a plan a bare path, a named setting empty (null).


def _name(value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise _about_itself(f"must be a non-empty string, got {brief(value)}")
    return value


def _values(value: Any, info: ValidationInfo) -> Any:
    """A list of values: a single number is one."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return [value]
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (list, tuple)):
        raise _about_itself(f"must be a list, got {brief(value)}")
    if not value:
        raise _about_itself(
            "must list at least one plan" if info.field_name == "plans" else "must list at least one value"
        )
    return value


def _distinct(values: tuple[Any, ...]) -> tuple[Any, ...]:
    if len(set(values)) != len(values):
        raise _about_itself(f"lists a value twice: {brief(list(values))}")
    return values


def _densities(values: tuple[float, ...]) -> tuple[float, ...]:
    for v in values:
        if not (math.isfinite(v) and v >= 0):
            raise _about_itself(f"must hold finite numbers >= 0 (per 100 m^2), got {brief(v)}")
    return values


def _seed_range(value: Any) -> Any:
    """Seeds given as a range {start, count}, as a list."""
    if not isinstance(value, Mapping):
        return value
    unknown = sorted(str(k) for k in value if k not in ("start", "count"))
    if unknown or "count" not in value:
        raise _whole_message(f"key 'seeds' as a mapping needs 'count' and may have 'start', got {brief(dict(value))}")
    start, count = value.get("start", 0), value["count"]
    for k, v in (("start", start), ("count", count)):
        if isinstance(v, bool) or not isinstance(v, int) or v < (1 if k == "count" else 0):
            raise _whole_message(f"key 'seeds.{k}' must be an integer >= {1 if k == 'count' else 0}, got {brief(v)}")
    if count > MAX_SEEDS:
        raise _whole_message(f"key 'seeds.count' asks for {count} seeds; a study runs at most {MAX_SEEDS}")
    return list(range(start, start + count))


def _seed_values(value: Any) -> Any:
    for s in value:
        if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s < 2**63:
            raise _about_itself(f"must hold integers in [0, 2^63), got {brief(s)}")
    return value


def _plan(value: Any) -> Any:
    if isinstance(value, str):
        return {"path": value}
    if isinstance(value, Mapping) and "path" not in value:
        raise _about_itself("has no 'path'")
    if not isinstance(value, (PlanSource, Mapping)):
        raise _about_itself(f"must be a path or a mapping with 'path', got {brief(value)}")
    return value


def _named(value: Any) -> Any:
    """Named settings: at least one, each name a non-empty string, an empty setting (null) the defaults."""
    if not isinstance(value, Mapping):
        raise _about_itself(f"must be a mapping, got {brief(value)}")
    if not value:
        raise _about_itself("must name at least one setting")
    for name in value:
        if not isinstance(name, str) or not name:
            raise _about_itself(f"must name its settings with non-empty strings, got {brief(name)}")
    return {name: {} if setting is None else setting for name, setting in value.items()}


def _icp_settings(value: Mapping[str, Any], info: ValidationInfo) -> dict[str, dict[str, Any]]:
    """Each named ICP setting's changes, checked by making the settings: numbers written as text
    read, schedules made tuples of floats (the changes, not the whole settings, enter run ids)."""
    known = sorted(f.name for f in dataclasses.fields(IcpConfig) if f.init)
    out: dict[str, dict[str, Any]] = {}
    for name, changes in value.items():
        if not isinstance(changes, Mapping):
            raise _whole_message(f"key {brief(f'icp.{name}')} must be a mapping, got {brief(changes)}")
        unknown = sorted(str(k) for k in changes if k not in known)
        if unknown:
            raise _whole_message(f"unknown key(s) {brief([f'icp.{name}.{k}' for k in unknown])}; known: {known}")
        try:
            config = read(IcpConfig, {**IcpConfig.for_tracking().to_dict(), **changes}, context=info.context)
        except ValidationError as exc:
            raise _whole_message(f"key {brief(f'icp.{name}')}: {first_error(exc)}") from None
        out[name] = {
            k: config.correspondence_schedule if k == "correspondence_schedule" else _read_number(v)
            for k, v in changes.items()
        }
    return out


def _read_number(value: Any) -> Any:
    """A number written as text read (1e-4); any other value as it is."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _success(value: Any) -> Any:
    if value is None:
        return {}
    if not isinstance(value, (SuccessCriterion, Mapping)):
        raise _about_itself(f"must be a mapping, got {brief(value)}")
    return value


def _default_sensors() -> dict[str, SensorSetting]:
    return {"utm30": SensorSetting()}


def _default_odometry() -> dict[str, OdometrySetting]:
    return {"thesis": OdometrySetting()}


def _default_icp() -> dict[str, dict[str, Any]]:
    return {"tracking": {}}


# (pydantic runs the before-validators of an annotation from the last to the first, then the
# after-validators from the first to the last.)
Values = BeforeValidator(_values)
Densities = Annotated[
    tuple[Annotated[float, Real(finite=False)], ...], AfterValidator(_densities), AfterValidator(_distinct), Values
]


@dataclass(frozen=True, config=SETTINGS)
class Study(Settings):
    """Everything a sweep varies; every combination of the list and mapping fields is one run.

    Attributes:
        name: the study's name (report title).
        plans: the plans (a folder expands to its HouseExpo files).
        seeds: seeds of furniture, route, people and noise; one run per seed and combination.
        duration_s: simulated seconds per run.
        furniture: furniture densities, times `FURNITURE_UNIT` (the demo's) per 100 m^2.
        people: walking people per 100 m^2 of free floor.
        sensors: named LIDAR models.
        odometry: named odometry error settings.
        icp: named ICP settings: changes to `IcpConfig.for_tracking()` (e.g. {"auto_trim": False}).
        success: when a run counts as a success (applied to the table, not part of a run: changing
            it reruns nothing).
    """

    name: Annotated[str, BeforeValidator(_name)]
    plans: Annotated[tuple[Annotated[PlanSource, BeforeValidator(_plan)], ...], Values]
    seeds: Annotated[
        tuple[int, ...], AfterValidator(_distinct), BeforeValidator(_seed_values), Values, BeforeValidator(_seed_range)
    ] = (0,)
    duration_s: Annotated[float, Real(gt=0.0, says="a positive number of seconds")] = 60.0
    furniture: Densities = (1.0,)
    people: Densities = (1.0,)
    sensors: Annotated[Mapping[str, SensorSetting], BeforeValidator(_named)] = field(default_factory=_default_sensors)
    odometry: Annotated[Mapping[str, OdometrySetting], BeforeValidator(_named)] = field(
        default_factory=_default_odometry
    )
    icp: Annotated[Mapping[str, Mapping[str, Any]], AfterValidator(_icp_settings), BeforeValidator(_named)] = field(
        default_factory=_default_icp
    )
    success: Annotated[SuccessCriterion, BeforeValidator(_success)] = field(default_factory=SuccessCriterion)

    def __post_init__(self) -> None:
        for name, sensor in self.sensors.items():
            for oname, odom in self.odometry.items():
                if odom.rate_hz < sensor.rate_hz:
                    raise _whole_message(
                        f"key {brief(f'odometry.{oname}.rate_hz')} ({odom.rate_hz}) is below the scan "
                        f"rate of {brief(f'sensors.{name}')} ({sensor.rate_hz}): odometry must be at "
                        f"least as fast"
                    )

    def icp_config(self, name: str) -> IcpConfig:
        """The ICP settings named `name`."""
        return IcpConfig.for_tracking(**dict(self.icp[name]))

    def to_dict(self) -> dict[str, Any]:
        """Plain values (YAML friendly); `Study.from_dict` reads them back to an equal study."""
        return {
            "name": self.name,
            "duration_s": self.duration_s,
            "plans": [p.to_yaml() for p in self.plans],
            "seeds": list(self.seeds),
            "furniture": list(self.furniture),
            "people": list(self.people),
            "sensors": {k: changed_fields(v) for k, v in self.sensors.items()},
            "odometry": {k: changed_fields(v) for k, v in self.odometry.items()},
            "icp": {k: {n: list(v) if isinstance(v, tuple) else v for n, v in c.items()} for k, c in self.icp.items()},
            "success": self.success.to_dict(),
        }

    def to_yaml(self) -> str:
        """The study as YAML text."""
        import yaml

        return str(yaml.safe_dump(self.to_dict(), sort_keys=False))

    @classmethod
    def from_dict(cls, data: Any) -> Study:
        """A study from parsed YAML (see the module docstring).

        Raises:
            StudyError: a missing, unknown or bad key; the message names it.
        """
        if not isinstance(data, Mapping):
            raise StudyError(f"a study must be a mapping of keys, got {type(data).__name__}")
        try:
            return read(cls, data, what="key(s)", context={NUMBER_TEXT: True})
        except ValidationError as exc:
            raise StudyError(_study_message(exc)) from None
        except ValueError as exc:  # an unknown key
            raise StudyError(str(exc)) from None


def load_study(path: str | Path) -> tuple[Study, Path]:
    """The study in a YAML file and the folder its relative plan paths are relative to.

    Raises:
        FileNotFoundError: no such file.
        StudyError: not YAML, or not a study (the message names the file and the key).
    """
    source = Path(path)
    if not source.is_file():
        raise FileNotFoundError(f"study file {source} does not exist")
    try:
        data = read_yaml_file(source, f"study {source}")
    except ValueError as exc:
        raise StudyError(str(exc)) from None
    try:
        return Study.from_dict(data), source.resolve().parent
    except StudyError as exc:
        raise StudyError(f"study {source}: {exc}") from None


NESTED: dict[str, tuple[int, type[Any]]] = {
    "plans": (2, PlanSource),
    "sensors": (2, SensorSetting),
    "odometry": (2, OdometrySetting),
    "success": (1, SuccessCriterion),
}
"""The settings inside a study: the length of their key path (`plans[0]`, `sensors.utm30`,
`success`) and their class."""


def _study_message(error: ValidationError) -> str:
    """A ValidationError of a study file as the study's message, which names the key: the first
    refusal, or every unknown key of the first settings that has some."""
    errors = error.errors(include_url=False)
    unknown = [e["loc"] for e in errors if e["type"] == "unexpected_keyword_argument"]
    if unknown:
        depth, cls = NESTED.get(str(unknown[0][0]), (0, Study))
        known = [f.name for f in dataclasses.fields(cls)]
        same = [key_path(loc) for loc in unknown if loc[:depth] == unknown[0][:depth]]
        return f"unknown key(s) {brief(same)}; known: {known}"
    e = errors[0]
    loc, message = e["loc"], e["msg"].removeprefix("Value error, ")
    if e["type"] == "missing":
        return f"missing key {brief(key_path(loc))}"
    if e["type"] == "study_message" or not loc:
        return message
    if e["type"] == "study_value":
        return f"key {brief(key_path(loc))} {message}"
    depth = NESTED.get(str(loc[0]), (len(loc), Study))[0]
    if depth == len(loc) == 1 and message.startswith(f"{loc[0]} "):
        return f"key {brief(str(loc[0]))} {message[len(str(loc[0])) + 1 :]}"
    return f"key {brief(key_path(loc[:depth]))}: {message}"
