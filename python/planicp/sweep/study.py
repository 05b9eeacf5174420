"""A study: the settings a sweep varies, as typed frozen dataclasses that round-trip through YAML.

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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._validation import brief, one_line, unknown_fields
from ..io.yaml_documents import read_yaml_file
from ..sim.experiment import LidarModel
from ..sim.odometry import ErrorGenerator, OdometryNoise
from ..sim.world import Furnishing
from ..tracking.icp_config import IcpConfig

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


class StudyError(ValueError):
    """A study file or mapping that cannot describe a study; the message names the key."""


@dataclass(frozen=True)
class PlanSource:
    """Where a plan comes from.

    Attributes:
        path: "default" (the shipped office plan), a plan file (image, ROS map YAML, HouseExpo
            JSON) or a folder of HouseExpo JSON files, as written in the study (relative paths
            are relative to the study file).
        resolution: metres per pixel: required for plan images; for HouseExpo plans the
            rasterisation's (default 0.05); ignored for ROS maps.
        origin: (x, y, yaw) of a plan image's lower-left corner in the map frame (m, m, rad).
    """

    path: str
    resolution: float | None = None
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not isinstance(self.path, str) or not self.path:
            raise ValueError(f"path must be a non-empty string, got {brief(self.path)}")
        if self.resolution is not None:
            value = _number(self.resolution, "resolution")
            if not (math.isfinite(value) and value > 0):
                raise ValueError(
                    f"resolution must be a positive number of metres per pixel, got {brief(self.resolution)}"
                )
            object.__setattr__(self, "resolution", value)
        origin = self.origin
        if isinstance(origin, (str, bytes)) or not isinstance(origin, (list, tuple)) or len(origin) != 3:
            raise ValueError(f"origin must be [x, y, yaw], got {brief(origin)}")
        values = tuple(_number(v, "origin") for v in origin)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"origin must be finite, got {brief(origin)}")
        object.__setattr__(self, "origin", values)

    def to_yaml(self) -> str | dict[str, Any]:
        """The YAML form: the bare path when nothing else is set."""
        if self.resolution is None and self.origin == (0.0, 0.0, 0.0):
            return self.path
        out: dict[str, Any] = {"path": self.path}
        if self.resolution is not None:
            out["resolution"] = self.resolution
        if self.origin != (0.0, 0.0, 0.0):
            out["origin"] = list(self.origin)
        return out


@dataclass(frozen=True)
class SensorSetting:
    """A LIDAR model in study units (see `planicp.sim.experiment.LidarModel`).

    Attributes:
        fov_deg: field of view, degrees, centred on the laser's x axis.
        beams: beams per scan.
        range_min, range_max: valid range, metres.
        range_sigma: Gaussian range noise, metres.
        dropout: probability that a beam returns nothing.
        rate_hz: scans per second.
        mount: (x, y, yaw) of the laser in the robot's base frame (m, m, rad).
    """

    # The defaults are LidarModel's (a Hokuyo UTM-30LX-like scanner), in study units.
    fov_deg: float = math.degrees(LidarModel.fov)
    beams: int = LidarModel.beams
    range_min: float = LidarModel.range_min
    range_max: float = LidarModel.range_max
    range_sigma: float = LidarModel.range_sigma
    dropout: float = LidarModel.dropout
    rate_hz: float = LidarModel.rate_hz
    mount: tuple[float, float, float] = LidarModel.mount

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if f.name == "mount":
                mount = self.mount
                if isinstance(mount, (str, bytes)) or not isinstance(mount, (list, tuple)) or len(mount) != 3:
                    raise ValueError(f"mount must be [x, y, yaw], got {brief(mount)}")
                object.__setattr__(self, "mount", tuple(_number(v, "mount") for v in mount))
            elif f.name != "beams":
                object.__setattr__(self, f.name, _number(getattr(self, f.name), f.name))
        self.lidar()  # LidarModel's checks

    def lidar(self) -> LidarModel:
        """The simulation's LIDAR model."""
        return LidarModel(
            fov=math.radians(self.fov_deg),
            beams=self.beams,
            range_min=self.range_min,
            range_max=self.range_max,
            range_sigma=self.range_sigma,
            dropout=self.dropout,
            rate_hz=self.rate_hz,
            mount=self.mount,
        )


@dataclass(frozen=True)
class OdometrySetting:
    """Odometry errors (see `planicp.sim.odometry`): the thesis's constant error added to every
    message, Gaussian noise on every increment, and the message rate.

    Attributes:
        translation_per_message: metres added along +x to every message (5e-5).
        rotation_per_message: radians added to every message (5e-5).
        translation_fraction: noise sigma as a fraction of the step (0.01).
        rotation_fraction: noise sigma as a fraction of the rotation (0.01).
        rotation_sigma_min: constant rotation noise sigma, radians per message (1e-5).
        rate_hz: odometry messages per second (100); at least the LIDAR rate.
    """

    translation_per_message: float = 5e-5
    rotation_per_message: float = 5e-5
    translation_fraction: float = 0.01
    rotation_fraction: float = 0.01
    rotation_sigma_min: float = 1e-5
    rate_hz: float = 100.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _number(getattr(self, f.name), f.name))
        self.error_generator()
        self.noise()
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ValueError(f"rate_hz must be a positive number of messages per second, got {brief(self.rate_hz)}")

    def error_generator(self) -> ErrorGenerator:
        """The systematic error of every message."""
        return ErrorGenerator(self.translation_per_message, self.rotation_per_message)

    def noise(self) -> OdometryNoise:
        """The Gaussian noise of every increment."""
        return OdometryNoise(self.translation_fraction, self.rotation_fraction, self.rotation_sigma_min)

    @property
    def drift_deg_per_s(self) -> float:
        """Heading drift of the systematic error, degrees per second."""
        return math.degrees(self.rotation_per_message * self.rate_hz)

    @property
    def drift_mm_per_s(self) -> float:
        """Forward drift of the systematic error, millimetres per second."""
        return 1000.0 * self.translation_per_message * self.rate_hz


@dataclass(frozen=True)
class SuccessCriterion:
    """When a run counts as a success: it finished, planicp's largest position error stayed below
    `max_position_error_m` metres, and (unless `allow_lost_at_end`) the localizer was not lost
    after the last scan."""

    max_position_error_m: float = 0.3
    allow_lost_at_end: bool = False

    def __post_init__(self) -> None:
        value = _number(self.max_position_error_m, "max_position_error_m")
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"max_position_error_m must be a positive number of metres, got {brief(value)}")
        object.__setattr__(self, "max_position_error_m", value)
        if not isinstance(self.allow_lost_at_end, bool):
            raise ValueError(f"allow_lost_at_end must be true or false, got {brief(self.allow_lost_at_end)}")


def _default_sensors() -> dict[str, SensorSetting]:
    return {"utm30": SensorSetting()}


def _default_odometry() -> dict[str, OdometrySetting]:
    return {"thesis": OdometrySetting()}


def _default_icp() -> dict[str, dict[str, Any]]:
    return {"tracking": {}}


@dataclass(frozen=True)
class Study:
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

    name: str
    plans: tuple[PlanSource, ...]
    seeds: tuple[int, ...] = (0,)
    duration_s: float = 60.0
    furniture: tuple[float, ...] = (1.0,)
    people: tuple[float, ...] = (1.0,)
    sensors: Mapping[str, SensorSetting] = field(default_factory=_default_sensors)
    odometry: Mapping[str, OdometrySetting] = field(default_factory=_default_odometry)
    icp: Mapping[str, Mapping[str, Any]] = field(default_factory=_default_icp)
    success: SuccessCriterion = field(default_factory=SuccessCriterion)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise StudyError(f"key 'name' must be a non-empty string, got {brief(self.name)}")
        if not self.plans:
            raise StudyError("key 'plans' must list at least one plan")
        for key in ("seeds", "furniture", "people"):
            values = getattr(self, key)
            if not values:
                raise StudyError(f"key {key!r} must list at least one value")
            if len(set(values)) != len(values):
                raise StudyError(f"key {key!r} lists a value twice: {brief(list(values))}")
        for s in self.seeds:
            if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s < 2**63:
                raise StudyError(f"key 'seeds' must hold integers in [0, 2^63), got {brief(s)}")
        for key in ("furniture", "people"):
            for v in getattr(self, key):
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v >= 0):
                    raise StudyError(f"key {key!r} must hold finite numbers >= 0 (per 100 m^2), got {brief(v)}")
        d = self.duration_s
        if isinstance(d, bool) or not isinstance(d, (int, float)) or not (math.isfinite(d) and d > 0):
            raise StudyError(f"key 'duration_s' must be a positive number of seconds, got {brief(d)}")
        for key in ("sensors", "odometry", "icp"):
            settings = getattr(self, key)
            if not settings:
                raise StudyError(f"key {key!r} must name at least one setting")
            for name in settings:
                if not isinstance(name, str) or not name:
                    raise StudyError(f"key {key!r}: setting names must be non-empty strings, got {brief(name)}")
        icp_keys = sorted(f.name for f in dataclasses.fields(IcpConfig) if f.init)
        for name, changes in self.icp.items():
            unknown = sorted(str(k) for k in changes if k not in icp_keys)
            if unknown:
                raise StudyError(f"unknown key(s) {brief([f'icp.{name}.{k}' for k in unknown])}; known: {icp_keys}")
            try:
                IcpConfig.for_tracking(**dict(changes))
            except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an int past float
                raise StudyError(f"key {brief(f'icp.{name}')}: {one_line(str(exc), 300)}") from None
        for name, sensor in self.sensors.items():
            for oname, odom in self.odometry.items():
                if odom.rate_hz < sensor.rate_hz:
                    raise StudyError(
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
            "sensors": {k: _changed(v) for k, v in self.sensors.items()},
            "odometry": {k: _changed(v) for k, v in self.odometry.items()},
            "icp": {k: dict(v) for k, v in self.icp.items()},
            "success": dataclasses.asdict(self.success),
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
        unknown, known = unknown_fields(cls, data)
        if unknown:
            raise StudyError(f"unknown key(s) {brief(unknown)}; known: {known}")
        for key in ("name", "plans"):
            if key not in data:
                raise StudyError(f"missing key {key!r}")
        kwargs: dict[str, Any] = {"name": data["name"], "plans": _plans(data["plans"])}
        if "seeds" in data:
            kwargs["seeds"] = _seeds(data["seeds"])
        if "duration_s" in data:
            kwargs["duration_s"] = _at("duration_s", _number, data["duration_s"], "duration_s")
        for key in ("furniture", "people"):
            if key in data:
                kwargs[key] = tuple(_at(f"{key}[{i}]", _number, v, key) for i, v in enumerate(_list(data[key], key)))
        if "sensors" in data:
            kwargs["sensors"] = _named(data["sensors"], "sensors", SensorSetting)
        if "odometry" in data:
            kwargs["odometry"] = _named(data["odometry"], "odometry", OdometrySetting)
        if "icp" in data:
            icp = _mapping(data["icp"], "icp")
            kwargs["icp"] = {str(k): dict(_mapping({} if v is None else v, f"icp.{k}")) for k, v in icp.items()}
            for name, changes in kwargs["icp"].items():
                for k, v in changes.items():
                    if isinstance(v, str):
                        changes[k] = _number_text(v)
                    if k == "correspondence_schedule" and isinstance(v, list):
                        changes[k] = tuple(_at(f"icp.{name}.{k}", _number, x, k) for x in v)
        if "success" in data:
            kwargs["success"] = _dataclass(SuccessCriterion, data["success"], "success")
        return cls(**kwargs)


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


MAX_SEEDS = 100_000
"""Most seeds `seeds: {count: ...}` may ask for (each is a run per combination of the other keys)."""


def _changed(setting: Any) -> dict[str, Any]:
    """The fields of a setting that differ from its defaults (so that the YAML stays short)."""
    default = type(setting)()
    out: dict[str, Any] = {}
    for f in dataclasses.fields(setting):
        value = getattr(setting, f.name)
        if value != getattr(default, f.name):
            out[f.name] = list(value) if isinstance(value, tuple) else value
    return out


def _number(value: Any, name: str) -> float:
    if isinstance(value, str):
        value = _number_text(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be a number, got {brief(value)}")
    try:
        return float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise ValueError(f"{name} is too large a number, got {brief(value)}") from None


def _number_text(text: str) -> Any:
    """A number PyYAML left as text (YAML 1.1 needs a dot in `1.0e-4`; `1e-4` is text there)."""
    try:
        return float(text)
    except ValueError:
        return text


def _at(where: str, convert: Any, value: Any, name: str) -> Any:
    try:
        return convert(value, name)
    except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an int past float
        raise StudyError(f"key {brief(where)}: {one_line(str(exc), 300)}") from None


def _list(value: Any, key: str) -> list[Any]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, list):
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return [value]
        raise StudyError(f"key {key!r} must be a list, got {brief(value)}")
    return value


def _mapping(value: Any, key: str) -> Mapping[Any, Any]:
    if not isinstance(value, Mapping):
        raise StudyError(f"key {key!r} must be a mapping, got {brief(value)}")
    return value


def _dataclass(cls: Any, value: Any, key: str) -> Any:
    values = _mapping({} if value is None else value, key)
    known = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(str(k) for k in values if k not in known)
    if unknown:
        raise StudyError(f"unknown key(s) {brief([f'{key}.{k}' for k in unknown])}; known: {known}")
    try:
        return cls(**{str(k): v for k, v in values.items()})
    except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an int past float
        raise StudyError(f"key {brief(key)}: {one_line(str(exc), 300)}") from None


def _named(value: Any, key: str, cls: Any) -> dict[str, Any]:
    return {str(name): _dataclass(cls, v, f"{key}.{name}") for name, v in _mapping(value, key).items()}


def _plans(value: Any) -> tuple[PlanSource, ...]:
    plans = []
    for i, item in enumerate(_list(value, "plans")):
        if isinstance(item, str):
            item = {"path": item}
        if not isinstance(item, Mapping):
            raise StudyError(f"key 'plans[{i}]' must be a path or a mapping with 'path', got {brief(item)}")
        if "path" not in item:
            raise StudyError(f"key 'plans[{i}]' has no 'path'")
        plans.append(_dataclass(PlanSource, item, f"plans[{i}]"))
    return tuple(plans)


def _seeds(value: Any) -> tuple[int, ...]:
    if isinstance(value, Mapping):
        unknown = sorted(str(k) for k in value if k not in ("start", "count"))
        if unknown or "count" not in value:
            raise StudyError(f"key 'seeds' as a mapping needs 'count' and may have 'start', got {brief(dict(value))}")
        start, count = value.get("start", 0), value["count"]
        for k, v in (("start", start), ("count", count)):
            if isinstance(v, bool) or not isinstance(v, int) or v < (1 if k == "count" else 0):
                raise StudyError(f"key 'seeds.{k}' must be an integer >= {1 if k == 'count' else 0}, got {brief(v)}")
        if count > MAX_SEEDS:
            raise StudyError(f"key 'seeds.count' asks for {count} seeds; a study runs at most {MAX_SEEDS}")
        return tuple(range(start, start + count))
    seeds = _list(value, "seeds")
    for s in seeds:
        if isinstance(s, bool) or not isinstance(s, int):
            raise StudyError(f"key 'seeds' must hold integers, got {brief(s)}")
    return tuple(seeds)
